"""Zarr v3 sharding_indexed arrays written with numpy as zarr-specs (codecs/sharding-indexed) says,
since zarr-python 2 cannot write them: inner chunks of the bytes codec (little-endian), gzip
optionally, an index of little-endian u64 (offset, nbytes) per inner chunk in C order, 2^64-1 for
an empty one, with its crc32c optionally, at the end or the start of the shard. Shared by
test_zarr.py and fuzz/tools/zarr_seeds.py."""
import gzip
import itertools

import numpy as np

EMPTY = 2**64 - 1


def crc32c(data):
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0x82F63B78 if crc & 1 else crc >> 1
    return crc ^ 0xFFFFFFFF


def sharded_metadata(shape, dtype, shard, inner, fill, location, crc, inner_gzip=True):
    inner_codecs = [{"name": "bytes", "configuration": {"endian": "little"}}]
    if inner_gzip:
        inner_codecs.append({"name": "gzip", "configuration": {"level": 1}})
    index_codecs = [{"name": "bytes", "configuration": {"endian": "little"}}] + ([{"name": "crc32c"}] if crc else [])
    return {"zarr_format": 3, "node_type": "array", "shape": list(shape), "data_type": np.dtype(dtype).name,
            "chunk_grid": {"name": "regular", "configuration": {"chunk_shape": list(shard)}},
            "chunk_key_encoding": {"name": "default"}, "fill_value": fill,
            "codecs": [{"name": "sharding_indexed", "configuration": {
                "chunk_shape": list(inner), "codecs": inner_codecs, "index_codecs": index_codecs,
                "index_location": location}}]}


def shard_bytes(padded, cell, shard, inner, location, crc, empty=(), inner_gzip=True):
    """Shard `cell` of `padded` (the array padded to whole shards with the fill value); the inner
    chunks whose grid cells (of the whole array) are in `empty` are left out."""
    per = [s // c for s, c in zip(shard, inner)]
    index_bytes = 16 * int(np.prod(per)) + (4 if crc else 0)
    data, entries = b"", []
    for local in itertools.product(*map(range, per)):
        start = [c * s + i * n for c, s, i, n in zip(cell, shard, local, inner)]
        if tuple(s // n for s, n in zip(start, inner)) in empty:
            entries.append((EMPTY, EMPTY))
            continue
        chunk = padded[tuple(slice(s, s + n) for s, n in zip(start, inner))].astype(padded.dtype.newbyteorder("<")).tobytes()
        chunk = gzip.compress(chunk, mtime=0) if inner_gzip else chunk
        entries.append(((index_bytes if location == "start" else 0) + len(data), len(chunk)))
        data += chunk
    index = np.array(entries, dtype="<u8").tobytes()
    if crc:
        index += crc32c(index).to_bytes(4, "little")
    return index + data if location == "start" else data + index
