"""Shared fixtures of the Python tests: the `strata` program the files are compared with, small
deterministic volumes, and a reader for the PNG files `strata render` writes."""

import json
import os
import struct
import subprocess
import zlib
from pathlib import Path

import numpy as np
import pytest

import strata


def cli_path():
    path = os.environ.get("STRATA_CLI")
    if not path or not Path(path).is_file():
        pytest.skip("STRATA_CLI does not name the strata program (CTest sets it)")
    return path


@pytest.fixture(scope="session")
def cli():
    """Runs `strata ARGS...` and returns its stdout; fails the test on a non-zero exit."""
    path = cli_path()

    def run(*args, expect_error=False):
        result = subprocess.run([path, "--progress", "none", *map(str, args)], capture_output=True, text=True)
        if expect_error:
            assert result.returncode != 0, f"strata {args} succeeded"
            return result.stderr
        assert result.returncode == 0, f"strata {args} failed: {result.stderr}"
        return result.stdout

    return run


def cli_error_message(stderr):
    """The message of the CLI's `error: <message>` line."""
    line = stderr.strip().splitlines()[0]
    assert line.startswith("error: "), stderr
    return line[len("error: "):]


def scalar_volume(shape=(40, 48, 56), seed=3):
    """A smooth u16 field with fine structure and noise: compressible, but not trivially."""
    rng = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*(np.linspace(0, 1, n) for n in shape), indexing="ij")
    field = 0.5 + 0.3 * np.sin(6 * x + 3 * y) * np.cos(5 * z) + 0.2 * np.exp(-((x - 0.6) ** 2 + (y - 0.4) ** 2) * 40)
    field += 0.02 * rng.standard_normal(shape)
    return np.clip(field * 4000, 0, 65535).astype(np.uint16)


def label_volume(shape=(24, 28, 32), seed=5, labels=(0, 3, 17, 250, 1000)):
    """Nearest-site cells (a small Voronoi partition) with a few label values, u32."""
    rng = np.random.default_rng(seed)
    sites = rng.uniform(0, 1, (12, 3)) * np.array(shape)
    grid = np.stack(np.meshgrid(*(np.arange(n) + 0.5 for n in shape), indexing="ij"), axis=-1)
    nearest = np.argmin(((grid[..., None, :] - sites) ** 2).sum(-1), axis=-1)
    return np.asarray(labels, dtype=np.uint32)[nearest % len(labels)]


def write_raw(path, array):
    """A raw file with the JSON sidecar the CLI reads (dims x, y, z)."""
    path = Path(path)
    array.tofile(path)
    z, y, x = array.shape
    dtype = {np.dtype(np.uint8): "u8", np.dtype(np.uint16): "u16", np.dtype(np.uint32): "u32",
             np.dtype(np.float32): "f32", np.dtype(np.int16): "i16"}[array.dtype]
    Path(str(path) + ".json").write_text(json.dumps({"dims": [x, y, z], "dtype": dtype, "spacing": [1, 1, 1]}))
    return path


@pytest.fixture(scope="session")
def scalar_raw(tmp_path_factory):
    return write_raw(tmp_path_factory.mktemp("scalar") / "scalar.raw", scalar_volume())


@pytest.fixture(scope="session")
def label_raw(tmp_path_factory):
    return write_raw(tmp_path_factory.mktemp("labels") / "labels.raw", label_volume())


def cli_encoded(tmp_path_factory, cli, command, raw):
    """`raw` compressed or encoded by the CLI (`command`) with its defaults."""
    out = tmp_path_factory.mktemp("strata") / (raw.stem + ".strata")
    cli(*command, raw, "-o", out)
    return out


@pytest.fixture(scope="session")
def scalar_file(tmp_path_factory, scalar_raw, cli):
    return cli_encoded(tmp_path_factory, cli, ["compress"], scalar_raw)


@pytest.fixture(scope="session")
def label_file(tmp_path_factory, label_raw, cli):
    return cli_encoded(tmp_path_factory, cli, ["labels", "encode"], label_raw)


def read_png(path):
    """The RGBA pixels of an 8-bit RGBA, non-interlaced PNG as a (h, w, 4) uint8 array."""
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, color, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert (depth, color, interlace) == (8, 6, 0), "expected 8-bit RGBA, not interlaced"
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = zlib.decompress(idat)
    stride = width * 4
    out = np.zeros((height, stride), dtype=np.int32)
    prev = np.zeros(stride, dtype=np.int32)
    for row in range(height):
        kind = raw[row * (stride + 1)]
        line = np.frombuffer(raw, np.uint8, stride, row * (stride + 1) + 1).astype(np.int32)
        cur = np.zeros(stride, dtype=np.int32)
        for i in range(stride):
            a = cur[i - 4] if i >= 4 else 0
            b = prev[i]
            c = prev[i - 4] if i >= 4 else 0
            if kind == 0:
                pred = 0
            elif kind == 1:
                pred = a
            elif kind == 2:
                pred = b
            elif kind == 3:
                pred = (a + b) // 2
            else:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[i] = (line[i] + pred) & 0xFF
        out[row], prev = cur, cur
    return out.astype(np.uint8).reshape(height, width, 4)


assert strata.__name__ == "strata"
