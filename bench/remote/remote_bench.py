#!/usr/bin/python3
"""What reading a .strata file over HTTP costs, against reading it locally: bytes and requests
for `strata info`, for a 64^3 box and for a coarse level, and wall times, over loopback to
tests/support/range_server.py (no injected latency: the figures are the protocol's overhead).

  bench/remote/remote_bench.py build/release/strata --size 512 --work /tmp/remote-bench [--rounds 3]

Generates u8 prisms of SIZE^3 and compresses them with the default settings (once, kept in
--work), then prints one JSON object.
"""
import argparse
import json
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

SERVER = Path(__file__).resolve().parents[2] / "tests" / "support" / "range_server.py"


def run(cmd):
    start = time.monotonic()
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return time.monotonic() - start, out


def server_stats(base, clear=False):
    with urllib.request.urlopen(f"{base}/{'__clear' if clear else '__stats'}", timeout=10) as r:
        return json.loads(r.read())


def best(strata, args, rounds, base=None):
    """Fastest of `rounds` runs of `strata ARGS`, with the server's count of the last."""
    times = []
    for _ in range(rounds):
        if base:
            server_stats(base, clear=True)
        seconds, out = run([strata, "--progress", "none", *args])
        times.append(seconds)
    result = {"seconds": round(min(times), 4), "stdout": out}
    if base:
        result["server"] = server_stats(base)
    return result


def main():
    p = argparse.ArgumentParser()
    p.add_argument("strata")
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--work", default="/tmp/remote-bench")
    p.add_argument("--rounds", type=int, default=3)
    a = p.parse_args()
    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    local = work / f"prisms{a.size}.strata"
    if not local.exists():
        run([a.strata, "--progress", "none", "generate", "prisms", "--size", str(a.size), "--dtype", "u8", "-o",
             str(work / "p.nrrd")])
        run([a.strata, "--progress", "none", "compress", str(work / "p.nrrd"), "-o", str(local)])
    server = subprocess.Popen([sys.executable, str(SERVER), str(work)], stdout=subprocess.PIPE, text=True)
    try:
        base = f"http://127.0.0.1:{int(server.stdout.readline().split()[1])}"
        url = f"{base}/ok/{local.name}"
        c = a.size // 2
        box = f"{c - 32},{c - 32},{c - 32}:{c + 32},{c + 32},{c + 32}"
        report = {"file": str(local), "file_bytes": local.stat().st_size, "box": box}
        cases = {"info": ["info", "{}", "--json"],
                 "box64": ["decompress", "{}", "--box", box, "-o", str(work / "box-{}.nrrd")],
                 "level1": ["decompress", "{}", "--level", "1", "-o", str(work / "level1-{}.nrrd")]}
        for name, template in cases.items():
            here = best(a.strata, [t.format(local) if t == "{}" else t.format("local") for t in template], a.rounds)
            there = best(a.strata, [t.format(url) if t == "{}" else t.format("http") for t in template], a.rounds, base)
            entry = {"local_seconds": here["seconds"], "http_seconds": there["seconds"],
                     "bytes_fetched": there["server"]["bytes"], "requests": there["server"]["requests"],
                     "share_of_file": round(there["server"]["bytes"] / report["file_bytes"], 5)}
            if name != "info":
                entry["identical"] = (work / f"{name.replace('box64', 'box')}-local.nrrd").read_bytes() == \
                    (work / f"{name.replace('box64', 'box')}-http.nrrd").read_bytes()
            report[name] = entry
        print(json.dumps(report, indent=2))
    finally:
        server.kill()
        server.wait()


if __name__ == "__main__":
    main()
