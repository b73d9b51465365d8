#!/usr/bin/python3
"""Read throughput of Strata's HDF5 and Zarr readers against h5py and zarr-python, side by side.

Writes the raw volume once as chunked HDF5 (h5py, gzip) and Zarr v2 (zarr-python's default
compressor, blosc lz4 with byte shuffle), in the chunk shape given, then reads each whole file
ROUNDS times, alternating Strata and the reference tool, and prints one JSON object: every time,
min and max per reader, the ratio of throughputs (reference time / Strata time: above 1 means
Strata reads faster) and the load average before and after.

  PYTHONPATH=build/release/python bench/formats/read_throughput.py p1024.raw --shape 1024,1024,1024 \
      --dtype u8 --chunks 64 --rounds 5 [--threads 1]
"""
import argparse
import json
import os
import time

import h5py
import numpy as np
import zarr

import strata


def write_references(raw, shape, dtype, chunks, h5_path, zarr_path):
    source = np.memmap(raw, dtype=dtype, mode="r", shape=shape)
    if not os.path.exists(h5_path):
        with h5py.File(h5_path + ".tmp", "w") as f:
            d = f.create_dataset("volume", shape=shape, dtype=dtype, chunks=chunks, compression="gzip")
            for z in range(0, shape[0], chunks[0]):
                d[z:z + chunks[0]] = source[z:z + chunks[0]]
        os.rename(h5_path + ".tmp", h5_path)
    if not os.path.exists(zarr_path):
        a = zarr.open(zarr_path + ".tmp", mode="w", shape=shape, dtype=dtype, chunks=chunks)
        for z in range(0, shape[0], chunks[0]):
            a[z:z + chunks[0]] = source[z:z + chunks[0]]
        os.rename(zarr_path + ".tmp", zarr_path)
    return source


def timed(read):
    start = time.perf_counter()
    array = read()
    return time.perf_counter() - start, array


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("raw")
    parser.add_argument("--shape", required=True, help="x,y,z (as strata generate --size)")
    parser.add_argument("--dtype", default="u8")
    parser.add_argument("--chunks", type=int, default=64)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--threads", type=int, default=0, help="strata.set_threads (0: all)")
    args = parser.parse_args()
    x, y, z = (int(v) for v in args.shape.split(","))
    shape = (z, y, x)
    dtype = np.dtype({"u8": "uint8", "u16": "uint16"}.get(args.dtype, args.dtype))
    chunks = (args.chunks,) * 3
    stem = os.path.splitext(args.raw)[0]
    h5_path, zarr_path = stem + ".h5", stem + ".zarr"
    source = write_references(args.raw, shape, dtype, chunks, h5_path, zarr_path)
    if args.threads:
        strata.set_threads(args.threads)

    readers = {
        "hdf5": {"strata": lambda: strata.read(h5_path, dataset="/volume"),
                 "h5py": lambda: h5py.File(h5_path, "r")["volume"][...]},
        "zarr": {"strata": lambda: strata.read(zarr_path),
                 "zarr-python": lambda: zarr.open(zarr_path, mode="r")[...]},
    }
    result = {"shape_zyx": shape, "dtype": str(dtype), "chunks": chunks, "rounds": args.rounds,
              "strata_threads": strata.threads(), "load_before": os.getloadavg()}
    for fmt, pair in readers.items():
        times = {name: [] for name in pair}
        for _ in range(args.rounds):
            for name, read in pair.items():  # alternating, so both see the same load
                seconds, array = timed(read)
                if not np.array_equal(array, source):
                    raise SystemExit(f"{name} read {fmt} wrong")
                del array
                times[name].append(round(seconds, 3))
        ours, theirs = times["strata"], [t for n, t in times.items() if n != "strata"][0]
        result[fmt] = {"seconds": times,
                       "min_max": {n: [min(t), max(t)] for n, t in times.items()},
                       "throughput_ratio_min_max": [round(min(a / b for a, b in zip(theirs, ours)), 3),
                                                    round(max(a / b for a, b in zip(theirs, ours)), 3)],
                       "gib_per_s_strata_best": round(source.nbytes / 2**30 / min(ours), 3)}
    result["load_after"] = os.getloadavg()
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
