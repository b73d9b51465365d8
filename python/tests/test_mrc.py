"""MRC volumes against the reference reader and writer (Debian's python3-mrcfile): what mrcfile
writes, Strata reads (every mode Strata takes, either byte order, an extended header, the voxel
size); what Strata writes, mrcfile reads and validates as MRC2014."""

import mrcfile
import numpy as np
import pytest

import strata

MODES = [np.int8, np.int16, np.float32, np.uint16]  # MRC modes 0, 1, 2, 6


def sample(dtype, shape=(4, 5, 6)):
    values = np.arange(np.prod(shape)).reshape(shape) - np.prod(shape) // 2
    if dtype == np.float32:
        values = values * 0.25
    if dtype == np.uint16:
        values = values + 1000
    return (values % 100 if dtype == np.int8 else values).astype(dtype)


@pytest.mark.parametrize("dtype", MODES)
@pytest.mark.parametrize("order", ["<", ">"])
def test_reads_what_mrcfile_writes(tmp_path, dtype, order):
    a = sample(dtype)
    path = tmp_path / "ref.mrc"
    with mrcfile.new(path) as m:
        m.set_data(a.astype(np.dtype(dtype).newbyteorder(order)))
        m.voxel_size = (0.5, 1.25, 2.0)  # x, y, z in Angstrom
        m.set_extended_header(np.zeros(40, dtype=np.uint8))
    b = strata.read(path)
    assert b.dtype == a.dtype and b.shape == a.shape
    np.testing.assert_array_equal(a, b)
    assert strata.info(path)["spacing"] == pytest.approx((2.0, 1.25, 0.5))  # (z, y, x)


@pytest.mark.parametrize("dtype", MODES)
def test_mrcfile_reads_what_strata_writes(tmp_path, dtype):
    a = sample(dtype)
    path = tmp_path / "out.mrc"
    strata.write(path, a, spacing=(3.0, 2.0, 0.5))
    assert mrcfile.validate(str(path), print_file=open("/dev/null", "w"))
    with mrcfile.open(path) as m:
        np.testing.assert_array_equal(m.data, a)
        assert float(m.voxel_size.x) == pytest.approx(0.5)
        assert float(m.voxel_size.z) == pytest.approx(3.0)
        assert float(m.header.dmin) == pytest.approx(float(a.min()))
        assert float(m.header.dmax) == pytest.approx(float(a.max()))
        assert float(m.header.dmean) == pytest.approx(float(a.astype(np.float64).mean()), rel=1e-6)


def test_unsigned_bytes_are_written_as_mode_6_like_mrcfile(tmp_path):
    a = (np.arange(60).reshape(3, 4, 5) * 4).astype(np.uint8)
    strata.write(tmp_path / "em.mrc", a)
    with mrcfile.open(tmp_path / "em.mrc") as m:
        assert m.header.mode == 6 and m.data.dtype == np.uint16
        np.testing.assert_array_equal(m.data, a)


def test_float16_reads_as_float32(tmp_path):
    a = (np.arange(24).reshape(2, 3, 4) * 0.125 - 1).astype(np.float16)
    with mrcfile.new(tmp_path / "half.mrc") as m:
        m.set_data(a)
    b = strata.read(tmp_path / "half.mrc")
    assert b.dtype == np.float32
    np.testing.assert_array_equal(b, a.astype(np.float32))


def test_origin_round_trips_with_mrcfile(tmp_path):
    a = sample(np.float32)
    with mrcfile.new(tmp_path / "o.mrc") as m:
        m.set_data(a)
        m.voxel_size = 1.5
        m.header.origin = (12.5, -3.0, 40.0)  # x, y, z in Angstrom
    info = strata.info(tmp_path / "o.mrc")
    assert info["origin"] == pytest.approx((40.0, -3.0, 12.5))  # (z, y, x)
    assert info["unit"] == "angstrom"
    strata.write(tmp_path / "back.mrc", a, spacing=(1.5, 1.5, 1.5), origin=info["origin"], unit="angstrom")
    with mrcfile.open(tmp_path / "back.mrc") as m:
        assert (float(m.header.origin.x), float(m.header.origin.y), float(m.header.origin.z)) == (12.5, -3.0, 40.0)
