"""Neuroglancer precomputed volumes against stores built here with numpy by the format's
specification (volume.md, sharded.md and the compressed_segmentation README of Neuroglancer):
unsharded raw chunks (plain and gzip, a voxel offset, channels, missing chunks),
compressed_segmentation labels of 32 and 64 bits, sharded stores with the identity hash and with
murmurhash3_x86_128, gzip data, and jpeg chunks written by Pillow. What Strata writes is read back
with the same numpy code."""

import gzip
import json
import struct

import numpy as np
import pytest

import strata

# ---------------------------------------------------------------------------------------------
# Building stores


def chunk_boxes(size, chunk):
    """Every chunk of the grid as (grid position, lo, hi), x y z order."""
    grid = [-(-s // c) for s, c in zip(size, chunk)]
    for gz in range(grid[2]):
        for gy in range(grid[1]):
            for gx in range(grid[0]):
                g = (gx, gy, gz)
                lo = [g[a] * chunk[a] for a in range(3)]
                hi = [min(lo[a] + chunk[a], size[a]) for a in range(3)]
                yield g, lo, hi


def part(volume, lo, hi):
    """The (c, z, y, x) samples of a chunk box of a (c, z, y, x) volume."""
    return volume[:, lo[2]:hi[2], lo[1]:hi[1], lo[0]:hi[0]]


def write_info(root, dtype, size, chunk, encoding, *, channels=1, offset=(0, 0, 0), resolution=(4, 6, 40),
               sharding=None, block=(8, 8, 8), kind=None):
    scale = {"key": "s0", "size": list(size), "voxel_offset": list(offset), "resolution": list(resolution),
             "chunk_sizes": [list(chunk)], "encoding": encoding}
    if encoding == "compressed_segmentation":
        scale["compressed_segmentation_block_size"] = list(block)
    if sharding:
        scale["sharding"] = sharding
    info = {"@type": "neuroglancer_multiscale_volume", "data_type": np.dtype(dtype).name,
            "type": kind or ("segmentation" if encoding == "compressed_segmentation" else "image"),
            "num_channels": channels, "scales": [scale]}
    (root / "s0").mkdir(parents=True)
    (root / "info").write_text(json.dumps(info))


def chunk_name(lo, hi, offset):
    return "_".join(f"{lo[a] + offset[a]}-{hi[a] + offset[a]}" for a in range(3))


def cseg_encode(labels, block):
    """compressed_segmentation of one channel of (z, y, x) labels, blocks padded at the edge."""
    words_per_value = labels.dtype.itemsize // 4
    shape = labels.shape[::-1]  # x, y, z
    grid = [-(-shape[a] // block[a]) for a in range(3)]
    headers, body = [], []
    offset = 2 * grid[0] * grid[1] * grid[2]
    for gz in range(grid[2]):
        for gy in range(grid[1]):
            for gx in range(grid[0]):
                b = labels[gz * block[2]:(gz + 1) * block[2], gy * block[1]:(gy + 1) * block[1],
                           gx * block[0]:(gx + 1) * block[0]]
                table, index = np.unique(b, return_inverse=True)
                index = index.reshape(b.shape)
                bits = next(n for n in (0, 1, 2, 4, 8, 16, 32) if (1 << n) >= len(table))
                padded = np.zeros((block[2], block[1], block[0]), np.uint64)
                padded[:b.shape[0], :b.shape[1], :b.shape[2]] = index
                packed = [0] * -(-bits * padded.size // 32)
                for i, v in enumerate(padded.ravel() if bits else []):  # x fastest
                    packed[(bits * i) // 32] |= int(v) << ((bits * i) % 32)
                values_at = offset
                table_at = offset + len(packed)
                headers += [table_at | (bits << 24), values_at]
                body += packed
                body += list(table.astype(labels.dtype).view(np.uint32))
                offset = table_at + len(table) * words_per_value
    return np.array(headers + body, np.uint32)


def cseg_chunk(channels_labels, block):
    """A chunk of several channels: channel offsets, then each channel's encoding."""
    encoded = [cseg_encode(c, block) for c in channels_labels]
    starts, at = [], len(encoded)
    for e in encoded:
        starts.append(at)
        at += len(e)
    return np.concatenate([np.array(starts, np.uint32)] + encoded).tobytes()


def cseg_decode(data, shape_xyz, block, dtype):
    """One channel of a compressed_segmentation chunk, as (z, y, x)."""
    words = np.frombuffer(data, np.uint32)
    channel = words[int(words[0]):]
    grid = [-(-shape_xyz[a] // block[a]) for a in range(3)]
    out = np.zeros(shape_xyz[::-1], dtype)
    wpv = np.dtype(dtype).itemsize // 4
    h = 0
    for gz in range(grid[2]):
        for gy in range(grid[1]):
            for gx in range(grid[0]):
                table_at, bits, values_at = int(channel[h]) & 0xFFFFFF, int(channel[h]) >> 24, int(channel[h + 1])
                h += 2
                for z in range(gz * block[2], min((gz + 1) * block[2], shape_xyz[2])):
                    for y in range(gy * block[1], min((gy + 1) * block[1], shape_xyz[1])):
                        for x in range(gx * block[0], min((gx + 1) * block[0], shape_xyz[0])):
                            i = (x - gx * block[0]) + block[0] * ((y - gy * block[1]) + block[1] * (z - gz * block[2]))
                            index = (int(channel[values_at + bits * i // 32]) >> (bits * i % 32)) & ((1 << bits) - 1) if bits else 0
                            value = channel[table_at + wpv * index: table_at + wpv * (index + 1)]
                            out[z, y, x] = value.view(dtype)[0]
    return out


def murmurhash3_x86_128_low64(key):
    """MurmurHash3_x86_128 (seed 0) of an 8-byte key: the low 8 bytes of the hash, little endian."""
    m = 0xFFFFFFFF
    rotl = lambda v, r: ((v << r) | (v >> (32 - r))) & m
    c = [0x239B961B, 0xAB0E9789, 0x38B34AE5, 0xA1E38B93]
    h = [0, 0, 0, 0]
    k1, k2 = struct.unpack("<II", key)
    for lane, k in ((0, k1), (1, k2)):  # an 8-byte key is all tail: lanes 0 and 1
        k = (k * c[lane]) & m
        k = rotl(k, 15 + lane)
        h[lane] ^= (k * c[lane + 1]) & m
    h = [v ^ 8 for v in h]

    def spread():
        h[0] = (h[0] + h[1] + h[2] + h[3]) & m
        for i in (1, 2, 3):
            h[i] = (h[i] + h[0]) & m

    def fmix(v):
        v ^= v >> 16
        v = (v * 0x85EBCA6B) & m
        v ^= v >> 13
        v = (v * 0xC2B2AE35) & m
        return v ^ (v >> 16)

    spread()
    h = [fmix(v) for v in h]
    spread()
    return h[0] | (h[1] << 32)


def morton(g, grid):
    bits = [max(0, (n - 1).bit_length()) for n in grid]
    code, j = 0, 0
    for i in range(max(bits)):
        for a in range(3):
            if i < bits[a]:
                code |= ((g[a] >> i) & 1) << j
                j += 1
    return code


def write_shards(folder, chunks, spec):
    """chunks: {chunk id: encoded bytes}; writes <shard>.shard files as sharded.md lays them out."""
    shards = {}
    for cid, data in sorted(chunks.items()):
        shifted = cid >> spec["preshift_bits"]
        hashed = murmurhash3_x86_128_low64(struct.pack("<Q", shifted)) if spec["hash"] != "identity" else shifted
        minishard = hashed & ((1 << spec["minishard_bits"]) - 1)
        shard = (hashed >> spec["minishard_bits"]) & ((1 << spec["shard_bits"]) - 1)
        shards.setdefault(shard, {}).setdefault(minishard, []).append((cid, data))
    for shard, minishards in shards.items():
        index = np.zeros((1 << spec["minishard_bits"], 2), np.uint64)
        body = bytearray()
        for minishard, entries in sorted(minishards.items()):
            ids, starts, sizes = [], [], []
            previous_id, previous_end = 0, 0
            for cid, data in entries:
                if spec.get("data_encoding") == "gzip":
                    data = gzip.compress(data)
                ids.append(cid - previous_id)
                starts.append(len(body) - previous_end)
                sizes.append(len(data))
                previous_id = cid
                body += data
                previous_end = len(body)
            table = np.array([ids, starts, sizes], np.uint64).tobytes()
            if spec.get("minishard_index_encoding") == "gzip":
                table = gzip.compress(table)
            index[minishard] = (len(body), len(body) + len(table))
            body += table
        digits = -(-spec["shard_bits"] // 4)
        (folder / f"{shard:0{digits}x}.shard").write_bytes(index.tobytes() + bytes(body))


def labels(shape, dtype, base, seed):
    rng = np.random.default_rng(seed)
    z, y, x = np.indices(shape)
    ids = base + (x // 5 + 7 * (y // 6) + 31 * (z // 4)) % 23
    ids = ids + (rng.random(shape) < 0.05) * rng.integers(0, 1000, shape)
    return ids.astype(dtype)


# ---------------------------------------------------------------------------------------------
# Reading


@pytest.mark.parametrize("dtype", [np.uint8, np.int8, np.uint16, np.int16, np.uint32, np.int32, np.uint64, np.float32])
def test_reads_unsharded_raw_chunks_with_offset_gzip_and_missing_chunks(tmp_path, dtype):
    root = tmp_path / "raw.precomputed"
    size, chunk, offset = (21, 18, 11), (8, 8, 4), (16, -8, 1000)
    write_info(root, dtype, size, chunk, "raw", offset=offset, kind="image")
    rng = np.random.default_rng(1)
    a = (rng.random((1,) + size[::-1]) * 100 - (0 if np.dtype(dtype).kind == "u" else 50)).astype(dtype)
    expected = a[0].copy()
    for n, (g, lo, hi) in enumerate(chunk_boxes(size, chunk)):
        data = part(a, lo, hi).tobytes()  # C order of (c, z, y, x): x fastest, channel slowest
        if n % 5 == 3:  # missing: zeros
            expected[lo[2]:hi[2], lo[1]:hi[1], lo[0]:hi[0]] = 0
            continue
        (root / "s0" / chunk_name(lo, hi, offset)).write_bytes(gzip.compress(data) if n % 2 else data)
    b = strata.read(root)
    assert b.dtype == np.dtype(dtype) and b.shape == expected.shape
    np.testing.assert_array_equal(b, expected)
    info = strata.info(root)
    assert info["format"] == "precomputed"
    assert info["spacing"] == pytest.approx((40, 6, 4))  # (z, y, x) in nm


def test_reads_each_channel_as_a_volume(tmp_path):
    root = tmp_path / "rgb.precomputed"
    size, chunk = (10, 9, 5), (4, 4, 4)
    write_info(root, np.uint16, size, chunk, "raw", channels=3)
    a = np.arange(3 * 5 * 9 * 10, dtype=np.uint16).reshape(3, 5, 9, 10)
    for _, lo, hi in chunk_boxes(size, chunk):
        (root / "s0" / chunk_name(lo, hi, (0, 0, 0))).write_bytes(part(a, lo, hi).tobytes())
    assert strata.info(root, volume=0)["volumes"] == 3
    for c in range(3):
        np.testing.assert_array_equal(strata.read(root, volume=c), a[c])


@pytest.mark.parametrize("dtype,base", [(np.uint32, 3_000_000_000), (np.uint64, 1 << 41)])
def test_reads_compressed_segmentation_of_two_channels(tmp_path, dtype, base):
    root = tmp_path / "seg.precomputed"
    size, chunk, block = (20, 17, 9), (16, 16, 8), (8, 4, 3)
    write_info(root, dtype, size, chunk, "compressed_segmentation", channels=2, block=block)
    a = np.stack([labels(size[::-1], dtype, base, 1), labels(size[::-1], dtype, base + 99, 2)])
    for _, lo, hi in chunk_boxes(size, chunk):
        p = part(a, lo, hi)
        (root / "s0" / chunk_name(lo, hi, (0, 0, 0))).write_bytes(cseg_chunk(p, block))
    for c in range(2):
        b = strata.read(root, volume=c)
        assert b.dtype == np.dtype(dtype)
        np.testing.assert_array_equal(b, a[c])


@pytest.mark.parametrize("hash_name", ["identity", "murmurhash3_x86_128"])
@pytest.mark.parametrize("encoding", ["raw", "compressed_segmentation"])
def test_reads_sharded_stores(tmp_path, hash_name, encoding):
    root = tmp_path / "sharded.precomputed"
    size, chunk, block = (40, 24, 20), (8, 8, 8), (8, 8, 8)
    spec = {"@type": "neuroglancer_uint64_sharded_v1", "preshift_bits": 1, "hash": hash_name, "minishard_bits": 2,
            "shard_bits": 2, "minishard_index_encoding": "gzip", "data_encoding": "gzip"}
    write_info(root, np.uint64, size, chunk, encoding, sharding=spec, block=block, kind="segmentation")
    a = labels(size[::-1], np.uint64, 1 << 40, 3)[np.newaxis]
    grid = [-(-s // c) for s, c in zip(size, chunk)]
    chunks = {}
    expected = a[0].copy()
    for g, lo, hi in chunk_boxes(size, chunk):
        cid = morton(g, grid)
        if cid % 7 == 2:  # not stored: zeros
            expected[lo[2]:hi[2], lo[1]:hi[1], lo[0]:hi[0]] = 0
            continue
        p = part(a, lo, hi)
        chunks[cid] = p.tobytes() if encoding == "raw" else cseg_chunk(p, block)
    write_shards(root / "s0", chunks, spec)
    assert len(list((root / "s0").glob("*.shard"))) > 1
    np.testing.assert_array_equal(strata.read(root), expected)


@pytest.mark.parametrize("channels", [1, 3])
def test_reads_jpeg_chunks_as_pillow_decodes_them(tmp_path, channels):
    Image = pytest.importorskip("PIL.Image")
    root = tmp_path / "jpeg.precomputed"
    size, chunk = (16, 12, 6), (8, 8, 4)
    write_info(root, np.uint8, size, chunk, "jpeg", channels=channels)
    z, y, x = np.indices(size[::-1])
    a = np.stack([((x * 9 + y * 5 + z * 20 + 60 * c) % 256).astype(np.uint8) for c in range(channels)])
    expected = np.zeros_like(a)
    for _, lo, hi in chunk_boxes(size, chunk):
        p = part(a, lo, hi)
        w, h = hi[0] - lo[0], (hi[1] - lo[1]) * (hi[2] - lo[2])
        pixels = p.reshape(channels, h, w)  # rows of x, one per (y, z)
        image = Image.fromarray(pixels[0] if channels == 1 else np.moveaxis(pixels, 0, -1))
        path = root / "s0" / chunk_name(lo, hi, (0, 0, 0))
        image.save(path, format="JPEG", quality=90)
        decoded = np.asarray(Image.open(path))
        decoded = decoded[np.newaxis] if channels == 1 else np.moveaxis(decoded, -1, 0)
        expected[:, lo[2]:hi[2], lo[1]:hi[1], lo[0]:hi[0]] = decoded.reshape(p.shape)
    for c in range(channels):
        np.testing.assert_array_equal(strata.read(root, volume=c if channels > 1 else None), expected[c])
    assert np.abs(expected.astype(int) - a).max() > 0  # lossy: the comparison is with Pillow's decoding


def test_damaged_chunks_are_refused_naming_the_file(tmp_path):
    root = tmp_path / "bad.precomputed"
    write_info(root, np.uint16, (4, 4, 4), (4, 4, 4), "raw")
    (root / "s0" / "0-4_0-4_0-4").write_bytes(b"\0" * 100)
    with pytest.raises(Exception, match="0-4_0-4_0-4.*chunk.*100 bytes"):
        strata.read(root)


# ---------------------------------------------------------------------------------------------
# Writing


def read_store(root):
    """A one-channel precomputed volume read by the specification, as (z, y, x), and its scale."""
    info = json.loads((root / "info").read_text())
    scale = info["scales"][0]
    dtype = np.dtype(info["data_type"])
    size, chunk, offset = scale["size"], scale["chunk_sizes"][0], scale["voxel_offset"]
    out = np.zeros(size[::-1], dtype)
    for _, lo, hi in chunk_boxes(size, chunk):
        data = (root / scale["key"] / chunk_name(lo, hi, offset)).read_bytes()
        shape_xyz = [hi[a] - lo[a] for a in range(3)]
        if scale["encoding"] == "raw":
            samples = np.frombuffer(data, dtype).reshape(shape_xyz[::-1])
        else:
            samples = cseg_decode(data, shape_xyz, scale["compressed_segmentation_block_size"], dtype)
        out[lo[2]:hi[2], lo[1]:hi[1], lo[0]:hi[0]] = samples
    return out, info


@pytest.mark.parametrize("dtype", [np.uint8, np.int16, np.float32])
def test_written_images_read_by_the_specification(tmp_path, dtype):
    a = (np.random.default_rng(4).random((67, 66, 70)) * 100).astype(dtype)
    root = tmp_path / "out.precomputed"
    strata.write(root, a, spacing=(40.0, 8.0, 4.0))
    b, info = read_store(root)
    np.testing.assert_array_equal(b, a)
    assert info["type"] == "image" and info["scales"][0]["encoding"] == "raw"
    assert info["scales"][0]["resolution"] == [4.0, 8.0, 40.0]
    np.testing.assert_array_equal(strata.read(root), a)


@pytest.mark.parametrize("dtype,base", [(np.uint32, 4_000_000_000), (np.uint64, (1 << 40) + 12345)])
def test_written_labels_read_by_the_specification(tmp_path, dtype, base):
    a = labels((20, 70, 66), dtype, base, 5)
    root = tmp_path / "labels.precomputed"
    strata.write(root, a)
    b, info = read_store(root)
    assert info["type"] == "segmentation" and info["scales"][0]["encoding"] == "compressed_segmentation"
    np.testing.assert_array_equal(b, a)
    assert int(b.max()) >= base
