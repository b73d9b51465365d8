"""Zarr and OME-Zarr against the reference library (Debian's python3-zarr 2.x, numcodecs): what
zarr writes (every sample type, either byte order, C and F order, each compressor, missing
chunks with a fill value, "/" keys, groups), Strata reads exactly; what Strata writes, zarr reads
back equal, with NGFF multiscales whose scale and translation carry the spacing and origin."""

import json

import numpy as np
import pytest

import strata
import zarr_shards

zarr = pytest.importorskip("zarr")
numcodecs = pytest.importorskip("numcodecs")

DTYPES = ["u1", "i1", "u2", "i2", "u4", "i4", "u8", "i8", "f4", "f8"]
COMPRESSORS = {
    "none": None,
    "gzip": numcodecs.GZip(level=5),
    "zlib": numcodecs.Zlib(level=5),
    "zstd": numcodecs.Zstd(level=3),
    "blosc-lz4-shuffle": numcodecs.Blosc(cname="lz4", clevel=5, shuffle=numcodecs.Blosc.SHUFFLE),
    "blosc-zstd-bitshuffle": numcodecs.Blosc(cname="zstd", clevel=5, shuffle=numcodecs.Blosc.BITSHUFFLE),
    "blosc-zlib": numcodecs.Blosc(cname="zlib", clevel=5, shuffle=numcodecs.Blosc.NOSHUFFLE),
    "blosc-blosclz": numcodecs.Blosc(cname="blosclz", clevel=5),
}


def sample(dtype, shape=(5, 7, 9)):
    rng = np.random.default_rng(4)
    dtype = np.dtype(dtype)
    if dtype.kind == "f":
        return rng.uniform(-1e3, 1e3, size=shape).astype(dtype)
    info = np.iinfo(dtype)
    return rng.integers(info.min, info.max, size=shape, dtype=dtype, endpoint=True)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("byteorder", ["<", ">"])
@pytest.mark.parametrize("order", ["C", "F"])
def test_reads_every_type_order_and_byte_order(tmp_path, dtype, byteorder, order):
    a = sample(dtype)
    path = tmp_path / "a.zarr"
    z = zarr.open_array(str(path), mode="w", shape=a.shape, chunks=(2, 3, 4),
                        dtype=np.dtype(dtype).newbyteorder(byteorder), order=order, compressor=None)
    z[...] = a
    b = strata.read(path)
    assert b.dtype == a.dtype and b.shape == a.shape
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("name", list(COMPRESSORS))
def test_reads_every_compressor(tmp_path, name):
    a = sample("u2", (20, 33, 40))
    path = tmp_path / f"{name}.zarr"
    z = zarr.open_array(str(path), mode="w", shape=a.shape, chunks=(8, 16, 16), dtype=a.dtype,
                        compressor=COMPRESSORS[name])
    z[...] = a
    np.testing.assert_array_equal(strata.read(path), a)


def test_missing_chunks_nan_fill_and_slash_keys(tmp_path):
    path = tmp_path / "sparse.zarr"
    store = zarr.NestedDirectoryStore(str(path))
    z = zarr.create((4, 6, 8), chunks=(2, 3, 4), dtype="f4", store=store, fill_value=np.nan)
    z[0:2, 0:3, 0:4] = 1.5
    expected = z[...]
    assert (path / "0" / "0" / "0").is_file()  # "/" keys: nested folders
    b = strata.read(path)
    np.testing.assert_array_equal(b, expected)
    assert np.isnan(b[3, 5, 7])


def test_labels_with_ids_above_2_to_40(tmp_path):
    a = (np.arange(4 * 5 * 6, dtype=np.uint64).reshape(4, 5, 6) + (1 << 41))
    z = zarr.open_array(str(tmp_path / "ids.zarr"), mode="w", shape=a.shape, chunks=(3, 3, 3), dtype="<u8",
                        compressor=numcodecs.Blosc(cname="zstd", shuffle=numcodecs.Blosc.BITSHUFFLE))
    z[...] = a
    np.testing.assert_array_equal(strata.read(tmp_path / "ids.zarr"), a)


def ome_zattrs(scale, translation, unit="micrometer", extra_axes=()):
    axes = [{"name": n, "type": t} for n, t in extra_axes]
    axes += [{"name": n, "type": "space", "unit": unit} for n in "zyx"]
    return {"multiscales": [{"version": "0.4", "axes": axes, "datasets": [
        {"path": "0", "coordinateTransformations": [{"type": "scale", "scale": list(scale)},
                                                     {"type": "translation", "translation": list(translation)}]}]}]}


def test_ome_zarr_spacing_and_volumes_from_the_reference_group(tmp_path, cli):
    a = sample("i2", (2, 3, 4, 5, 6))  # t, c, z, y, x
    path = tmp_path / "tc.ome.zarr"
    root = zarr.open_group(str(path), mode="w")
    root.create_dataset("0", data=a, chunks=(1, 1, 2, 5, 6))
    root.attrs.update(ome_zattrs((1, 1, 2.0, 0.75, 0.5), (0, 0, 3, 4, 5), extra_axes=(("t", "time"), ("c", "channel"))))
    info = strata.info(path, volume=0)
    assert info["volumes"] == 6 and info["shape"] == (4, 5, 6)
    assert info["spacing"] == pytest.approx((2.0, 0.75, 0.5))
    for t in range(2):
        for c in range(3):
            np.testing.assert_array_equal(strata.read(path, volume=3 * t + c), a[t, c])
    # The origin travels through strata's reader and writer: convert, then the new .zattrs.
    cli("convert", path, tmp_path / "copy.ome.zarr", "--volume", "4")
    attrs = json.loads((tmp_path / "copy.ome.zarr" / ".zattrs").read_text())
    transforms = attrs["multiscales"][0]["datasets"][0]["coordinateTransformations"]
    assert transforms[0]["scale"] == pytest.approx([2.0, 0.75, 0.5])
    assert transforms[1]["translation"] == pytest.approx([3, 4, 5])
    assert attrs["multiscales"][0]["axes"][2]["unit"] == "micrometer"
    np.testing.assert_array_equal(zarr.open_array(str(tmp_path / "copy.ome.zarr" / "0"), mode="r")[...], a[1, 1])


def test_dataset_of_a_group(tmp_path):
    root = zarr.open_group(str(tmp_path / "g.zarr"), mode="w")
    root.create_dataset("raw", data=sample("u1"))
    root.create_dataset("seg/cells", data=sample("u8"))
    np.testing.assert_array_equal(strata.read(f"{tmp_path / 'g.zarr'}:/seg/cells"), sample("u8"))


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("compress", [True, False])
def test_zarr_reads_what_strata_writes(tmp_path, dtype, compress):
    a = sample(dtype, (70, 66, 65))  # partial edge chunks on every axis
    path = tmp_path / "out.ome.zarr"
    strata.write(path, a, spacing=(3.0, 2.0, 0.5), compress=compress)
    root = zarr.open_group(str(path), mode="r")
    b = root["0"][...]
    assert b.dtype == a.dtype
    np.testing.assert_array_equal(b, a)
    ms = root.attrs["multiscales"][0]
    assert ms["version"] == "0.4"
    assert [ax["name"] for ax in ms["axes"]] == ["z", "y", "x"]
    assert ms["datasets"][0]["coordinateTransformations"][0]["scale"] == pytest.approx([3.0, 2.0, 0.5])
    assert (root["0"].compressor is not None) == compress


@pytest.mark.parametrize("compression", ["stored", "deflated"])
def test_zip_store_of_the_reference_library(tmp_path, cli, compression):
    """zarr.ZipStore (stored members by default, deflated on request) read as the folder would be,
    by the module and by `strata convert`."""
    import zipfile

    a = sample("u2", (12, 17, 23))
    path = tmp_path / "image.ome.zarr.zip"
    store = zarr.ZipStore(str(path), mode="w",
                          compression=zipfile.ZIP_STORED if compression == "stored" else zipfile.ZIP_DEFLATED)
    root = zarr.group(store=store)
    root.create_dataset("0", data=a, chunks=(5, 8, 8), compressor=numcodecs.Blosc(cname="lz4"))
    root.attrs.update(ome_zattrs((2.0, 0.75, 0.5), (1, 2, 3)))
    store.close()
    np.testing.assert_array_equal(strata.read(path), a)
    assert strata.info(path)["spacing"] == pytest.approx((2.0, 0.75, 0.5))
    cli("convert", path, tmp_path / "copy.nrrd")
    np.testing.assert_array_equal(strata.read(tmp_path / "copy.nrrd"), a)


def write_sharded(path, a, shard, inner, fill, location, crc, empty=(), missing=()):
    """`a` as a sharded v3 array in the folder `path` (shard files "c/i/j/k"), leaving out the
    shards in `missing` and the inner chunks in `empty`. Returns what must be read."""
    import itertools

    path.mkdir()
    (path / "zarr.json").write_text(json.dumps(zarr_shards.sharded_metadata(a.shape, a.dtype, shard, inner, fill, location, crc)))
    grid = [-(-n // s) for n, s in zip(a.shape, shard)]
    padded = np.full([g * s for g, s in zip(grid, shard)], fill, dtype=a.dtype)
    padded[tuple(slice(0, n) for n in a.shape)] = a
    for cell in itertools.product(*map(range, grid)):
        window = tuple(slice(c * s, (c + 1) * s) for c, s in zip(cell, shard))
        if cell in missing:
            padded[window] = fill
            continue
        key = path / "c" / "/".join(map(str, cell))
        key.parent.mkdir(parents=True, exist_ok=True)
        key.write_bytes(zarr_shards.shard_bytes(padded, cell, shard, inner, location, crc, empty))
    for cell in empty:
        padded[tuple(slice(c * n, (c + 1) * n) for c, n in zip(cell, inner))] = fill
    return padded[tuple(slice(0, n) for n in a.shape)]


@pytest.mark.parametrize("location", ["end", "start"])
@pytest.mark.parametrize("crc", [True, False])
def test_sharded_v3_array_written_with_numpy(tmp_path, location, crc):
    a = sample("i4", (9, 13, 17))
    expected = write_sharded(tmp_path / "s.zarr", a, (4, 8, 8), (2, 4, 4), -5, location, crc,
                             empty={(0, 0, 0), (4, 3, 4)}, missing={(1, 1, 0)})
    np.testing.assert_array_equal(strata.read(tmp_path / "s.zarr"), expected)
    assert (expected == -5).any()
