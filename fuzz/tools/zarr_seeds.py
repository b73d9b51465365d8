"""Writes the sharded and zip seeds of fuzz/corpus/zarr (run from the repository root with
Debian's python3, numpy and python3-zarr): sharded v3 arrays in fuzz_zarr's metadata-NUL-chunk
layout (the chunk bytes are shard (0, 0, 0)), and zip stores written as they are."""
import io
import json
import sys
import zipfile

import numpy as np
import zarr

sys.path.insert(0, "python/tests")
import zarr_shards  # noqa: E402

OUT = "fuzz/corpus/zarr/"


def sharded(location, crc, inner_gzip, empty):
    """A (2, 4, 4) u16 array, one shard of four (2, 2, 2) inner chunks: metadata and the shard."""
    a = np.arange(32, dtype="<u2").reshape(2, 4, 4)
    meta = zarr_shards.sharded_metadata(a.shape, a.dtype, (2, 4, 4), (2, 2, 2), 3, location, crc, inner_gzip)
    shard = zarr_shards.shard_bytes(a, (0, 0, 0), (2, 4, 4), (2, 2, 2), location, crc, empty, inner_gzip)
    return json.dumps(meta).encode(), shard


for name, args in {"v3_sharded_end_crc_gzip": ("end", True, True, {(0, 0, 0)}),
                   "v3_sharded_start_raw": ("start", False, False, ())}.items():
    meta, shard = sharded(*args)
    open(OUT + name, "wb").write(meta + b"\0" + shard)


def zip_bytes(members, compression):
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=compression) as z:
        for key, value in members.items():
            z.writestr(zipfile.ZipInfo(key, date_time=(2020, 1, 1, 0, 0, 0)), value, compress_type=compression)
    return buffer.getvalue()


# zarr-python's own keys for a small v2 array (stored members, as its ZipStore writes them).
memory = zarr.MemoryStore()
z = zarr.create((2, 3, 4), chunks=(2, 2, 2), dtype="<i2", store=memory, compressor=None, fill_value=5)
z[:, :2, :] = np.arange(16, dtype="<i2").reshape(2, 2, 4)
open(OUT + "zip_stored_v2", "wb").write(zip_bytes(dict(memory), zipfile.ZIP_STORED))
meta, shard = sharded("end", True, True, ())
open(OUT + "zip_deflated_v3_sharded", "wb").write(zip_bytes({"zarr.json": meta, "c/0/0/0": shard}, zipfile.ZIP_DEFLATED))
