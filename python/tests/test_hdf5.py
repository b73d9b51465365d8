"""HDF5 volumes against the reference library's Python face (Debian's python3-h5py): what h5py
writes, Strata reads exactly (every sample type, either byte order, chunked or contiguous, each
filter HDF5 has, 4-D series, datasets in groups, the voxel size attributes); what Strata writes,
h5py reads equal, with the voxel size where Fiji and Strata look for it."""

import h5py
import numpy as np
import pytest

import strata

DTYPES = [np.uint8, np.int8, np.uint16, np.int16, np.uint32, np.int32, np.uint64, np.int64, np.float32, np.float64]


def sample(dtype, shape=(5, 6, 7)):
    n = int(np.prod(shape))
    if np.issubdtype(dtype, np.floating):
        values = (np.arange(n) - n // 2) * 0.37
    else:
        info = np.iinfo(dtype)
        values = np.linspace(info.min, info.max, n, dtype=np.float64).astype(dtype)
        values[0], values[-1] = info.min, info.max
    return np.asarray(values, dtype=dtype).reshape(shape)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("order", ["<", ">"])
def test_reads_every_dtype_and_byte_order_h5py_writes(tmp_path, dtype, order):
    a = sample(dtype)
    path = tmp_path / "ref.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("data", data=a.astype(np.dtype(dtype).newbyteorder(order)))
    b = strata.read(path)
    assert b.dtype == a.dtype and b.shape == a.shape
    np.testing.assert_array_equal(a, b)


FILTERS = {
    "contiguous": {},
    "chunked": {"chunks": (2, 3, 4)},
    "gzip": {"chunks": (2, 3, 4), "compression": "gzip", "compression_opts": 9},
    "shuffle_gzip": {"chunks": (3, 3, 3), "compression": "gzip", "shuffle": True},
    "fletcher32": {"chunks": (2, 6, 7), "fletcher32": True},
    "scaleoffset": {"chunks": (2, 3, 4), "scaleoffset": 0},
}


@pytest.mark.parametrize("layout", list(FILTERS))
def test_reads_each_layout_and_filter_hdf5_provides(tmp_path, layout):
    a = sample(np.uint16, (9, 10, 11))
    path = tmp_path / f"{layout}.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("scan/recon", data=a, **FILTERS[layout])
    np.testing.assert_array_equal(strata.read(f"{path}:/scan/recon"), a)


def test_szip_when_the_library_has_it(tmp_path):
    if not h5py.h5z.filter_avail(h5py.h5z.FILTER_SZIP):
        pytest.skip("this HDF5 library has no szip")
    a = sample(np.int16, (4, 8, 16))
    path = tmp_path / "szip.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("data", data=a, chunks=(2, 8, 16), compression="szip")
    np.testing.assert_array_equal(strata.read(path), a)


def test_four_dimensional_series_reads_one_volume_at_a_time(tmp_path):
    a = sample(np.float32, (3, 4, 5, 6))
    path = tmp_path / "series.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("t", data=a, chunks=(1, 2, 5, 6), compression="gzip")
    assert strata.info(path)["volumes"] == 3
    for t in range(3):
        np.testing.assert_array_equal(strata.read(path, volume=t), a[t])


def test_voxel_size_from_element_size_um_and_from_spacing(tmp_path):
    path = tmp_path / "sizes.h5"
    with h5py.File(path, "w") as f:
        fiji = f.create_dataset("fiji", data=sample(np.uint8))
        fiji.attrs["element_size_um"] = np.array([2.0, 0.5, 0.25], dtype=np.float32)  # z, y, x
        own = f.create_dataset("own", data=sample(np.uint8))
        own.attrs["spacing"] = [0.1, 0.2, 0.3]  # x, y, z
        own.attrs["unit"] = "mm"
    assert strata.info(f"{path}:/fiji")["spacing"] == pytest.approx((2.0, 0.5, 0.25))
    assert strata.info(f"{path}:/own")["spacing"] == pytest.approx((0.3, 0.2, 0.1))


def test_several_datasets_are_listed(tmp_path):
    path = tmp_path / "two.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("a", data=sample(np.uint8))
        f.create_dataset("b/c", data=sample(np.int16))
    with pytest.raises(Exception, match=r"/a \(5, 6, 7\) u8, /b/c \(5, 6, 7\) i16"):
        strata.read(path)


@pytest.mark.parametrize("dtype", DTYPES)
def test_h5py_reads_what_strata_writes(tmp_path, dtype):
    a = sample(dtype, (70, 9, 66))  # more than one 64-deep chunk row, clipped chunks in x
    path = tmp_path / "out.h5"
    strata.write(path, a, spacing=(3.0, 2.0, 0.5))
    with h5py.File(path, "r") as f:
        d = f["volume"]
        np.testing.assert_array_equal(d[...], a)
        assert d.dtype == a.dtype
        assert d.compression == "gzip" and d.compression_opts == 4
        assert d.chunks == (64, 9, 64)
        np.testing.assert_allclose(d.attrs["spacing"], [0.5, 2.0, 3.0])
        np.testing.assert_allclose(d.attrs["origin"], [0, 0, 0])
        np.testing.assert_allclose(d.attrs["direction"], np.eye(3).ravel())


def test_strata_writes_a_named_dataset_uncompressed(tmp_path):
    a = sample(np.uint64, (3, 4, 5)) | np.uint64(1 << 41)
    path = tmp_path / "labels.h5"
    strata.write(f"{path}:/seg/ids", a, compress=False)
    with h5py.File(path, "r") as f:
        assert f["seg/ids"].compression is None
        np.testing.assert_array_equal(f["seg/ids"][...], a)
    np.testing.assert_array_equal(strata.read(path), a)

