"""`.strata` files read from an HTTP server with range requests (docs/architecture.md, "Remote
files"): strata.open, `strata info` and `strata decompress` on a URL served by
tests/support/range_server.py on 127.0.0.1, against the same file read locally; how little of
the file a box fetches; and the errors of a server that ignores ranges, a missing file, a
truncated file and a connection reset on every attempt."""

import json
import os
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

import strata

SERVER = Path(__file__).resolve().parents[2] / "tests" / "support" / "range_server.py"
# 256^3 keeps the test quick; the 512^3 figures are in docs/benchmarks.md ("Remote files").
SIZE = 256
BOX = np.s_[100:164, 70:134, 40:104]  # 64^3, not aligned to bricks


@pytest.fixture(scope="module")
def served(tmp_path_factory, cli):
    """(local path, base URL) of a compressed prisms volume, served until the module's tests end."""
    folder = tmp_path_factory.mktemp("remote")
    cli("generate", "prisms", "--size", SIZE, "--dtype", "u8", "-o", folder / "p.nrrd")
    cli("compress", folder / "p.nrrd", "-o", folder / "p.strata", "--hooi", "0")
    server = subprocess.Popen([sys.executable, str(SERVER), str(folder)], stdout=subprocess.PIPE, text=True)
    try:
        line = server.stdout.readline()
        assert line.startswith("PORT "), line
        yield folder / "p.strata", f"http://127.0.0.1:{int(line.split()[1])}"
    finally:
        server.kill()
        server.wait()


def server_stats(base, clear=False):
    with urllib.request.urlopen(f"{base}/{'__clear' if clear else '__stats'}", timeout=10) as r:
        return json.loads(r.read())


@pytest.fixture
def fast_retries(monkeypatch):
    """Retries that give up quickly, for the failures every attempt meets."""
    monkeypatch.setenv("STRATA_HTTP_ATTEMPTS", "3")
    monkeypatch.setenv("STRATA_HTTP_BACKOFF_MS", "20")


def test_box_equals_the_local_decode_and_fetches_little(served):
    local, base = served
    server_stats(base, clear=True)
    with strata.open(f"{base}/ok/p.strata") as remote:
        assert remote.shape == (SIZE, SIZE, SIZE)
        ours = remote[BOX]
        transfer = remote.transfer
    with strata.open(local) as f:
        np.testing.assert_array_equal(ours, f[BOX])
        assert f.transfer == {"bytes_fetched": 0, "requests": 0, "retries": 0, "cache_hits": 0}
    sent = server_stats(base)
    size = local.stat().st_size
    assert sent["bytes"] == transfer["bytes_fetched"] and sent["requests"] == transfer["requests"]
    assert sent["bytes"] < 0.05 * size, f"{sent} of a {size}-byte file"
    print(f"64^3 box of a {SIZE}^3 file of {size} bytes: {sent['bytes']} bytes in {sent['requests']} requests")
    assert transfer["retries"] == 0


def test_cli_info_and_decompress(served, cli, tmp_path):
    local, base = served
    url = f"{base}/ok/p.strata"
    remote = json.loads(cli("info", url, "--json"))
    here = json.loads(cli("info", local, "--json"))
    assert remote["file"] == url and remote["file_bytes"] == here["file_bytes"]
    assert remote["levels"] == here["levels"]
    assert remote["transfer"]["requests"] >= 2 and remote["transfer"]["bytes_fetched"] > 0
    assert "transfer" not in here
    cli("decompress", url, "-o", tmp_path / "remote.nrrd", "--level", "1")
    cli("decompress", local, "-o", tmp_path / "local.nrrd", "--level", "1")
    np.testing.assert_array_equal(strata.read(tmp_path / "remote.nrrd"), strata.read(tmp_path / "local.nrrd"))


def test_transient_failures_are_retried(served, fast_retries):
    local, base = served
    with strata.open(f"{base}/flaky/p.strata") as remote, strata.open(local) as f:
        np.testing.assert_array_equal(remote[BOX], f[BOX])
        assert remote.transfer["retries"] > 0


@pytest.mark.parametrize(
    "mode, name, message",
    [
        ("norange", "p.strata", "does not support HTTP range requests"),
        ("ok", "missing.strata", "404 Not Found"),
        ("truncate", "p.strata", "lies outside the"),
        ("reset", "p.strata", "failed 3 times; giving up"),
    ],
)
def test_failures_name_the_url_and_the_problem(served, fast_retries, mode, name, message):
    _, base = served
    url = f"{base}/{mode}/{name}"
    start = time.monotonic()
    with pytest.raises(Exception) as error:
        strata.open(url)
    assert url in str(error.value) and message in str(error.value), str(error.value)
    assert time.monotonic() - start < 30


def test_cli_reports_a_failure(served, cli, fast_retries):
    _, base = served
    stderr = cli("info", f"{base}/norange/p.strata", expect_error=True)
    assert "error:" in stderr and "range requests" in stderr and f"{base}/norange/p.strata" in stderr
