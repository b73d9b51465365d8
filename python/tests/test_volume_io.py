"""strata.read / write / info: numpy arrays in and out of every format, in (z, y, x) order."""

import json

import numpy as np
import pytest

import strata
from conftest import cli_error_message, write_raw

DTYPES = [np.uint8, np.int8, np.uint16, np.int16, np.uint32, np.int32, np.float32, np.float64]


def sample(dtype, shape=(5, 6, 7)):
    """Distinct values in every voxel, negative ones for signed types, so a transposed or
    truncated round trip cannot pass."""
    values = np.arange(np.prod(shape)).reshape(shape)
    if np.issubdtype(dtype, np.signedinteger) or np.issubdtype(dtype, np.floating):
        values = values - values.size // 2
    if np.issubdtype(dtype, np.floating):
        values = values * 0.25
    return (values % 127 if np.dtype(dtype).itemsize == 1 else values).astype(dtype)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("ext", [".raw", ".nrrd", ".tif", ".nii.gz"])
def test_round_trip_every_dtype_and_format(tmp_path, dtype, ext):
    if ext == ".nii.gz" and dtype == np.int8:
        pytest.skip("NIfTI writing takes every type but i8 (README, Formats)")
    a = sample(dtype)
    path = tmp_path / f"v{ext}"
    strata.write(path, a, spacing=(3.0, 2.0, 0.5))
    b = strata.read(path)
    assert b.dtype == a.dtype and b.shape == a.shape and b.flags.c_contiguous
    np.testing.assert_array_equal(a, b)
    meta = strata.info(path)
    assert meta["shape"] == (5, 6, 7) and meta["dtype"] == a.dtype
    if ext != ".tif":
        assert meta["spacing"] == pytest.approx((3.0, 2.0, 0.5))


def test_axis_order_matches_the_cli(tmp_path, cli):
    a = sample(np.uint16)
    strata.write(tmp_path / "v.nrrd", a)
    info = json.loads(cli("info", tmp_path / "v.nrrd", "--json"))
    assert info["dims"] == [7, 6, 5]  # x, y, z: the array's shape reversed
    # The CLI's raw output is the array's memory, byte for byte.
    cli("convert", tmp_path / "v.nrrd", tmp_path / "v.raw")
    assert (tmp_path / "v.raw").read_bytes() == a.tobytes()
    assert json.loads((tmp_path / "v.raw.json").read_text())["dims"] == [7, 6, 5]


def test_reads_what_the_cli_generates(tmp_path, cli):
    cli("generate", "prisms", "--size", "20,12,9", "--seed", "4", "-o", tmp_path / "p.nrrd")
    cli("convert", tmp_path / "p.nrrd", tmp_path / "p.raw")
    a = strata.read(tmp_path / "p.nrrd")
    assert a.shape == (9, 12, 20) and a.dtype == np.uint16
    assert a.tobytes() == (tmp_path / "p.raw").read_bytes()
    np.testing.assert_array_equal(strata.generate("prisms", (9, 12, 20), seed=4), a)


def test_raw_without_sidecar_needs_shape_and_dtype(tmp_path):
    a = sample(np.int16)
    a.byteswap().tofile(tmp_path / "plain.raw")
    with pytest.raises(ValueError) as e:
        strata.read(tmp_path / "plain.raw")
    assert isinstance(e.value, strata.Error) and "ReadOptions::raw_dims" in str(e.value)
    b = strata.read(tmp_path / "plain.raw", shape=(5, 6, 7), dtype="i16", big_endian=True)
    np.testing.assert_array_equal(a, b)
    assert strata.read(tmp_path / "plain.raw", shape=(5, 6, 7), dtype=np.int16).dtype == np.int16


def test_strided_and_byte_swapped_arrays_are_written_as_their_values(tmp_path):
    base = sample(np.float32, (10, 12, 14))
    view = base[::2, 1:, ::-3]
    strata.write(tmp_path / "view.raw", view)
    np.testing.assert_array_equal(strata.read(tmp_path / "view.raw"), view)
    swapped = base.astype(base.dtype.newbyteorder(">"))
    strata.write(tmp_path / "swapped.raw", swapped)
    np.testing.assert_array_equal(strata.read(tmp_path / "swapped.raw"), base)


@pytest.mark.parametrize("bad", [np.zeros((4, 4, 4), np.float16),
                                 np.zeros((4, 4, 4), bool), np.zeros((4, 4, 4), np.complex64)])
def test_unsupported_dtypes_raise_type_error(tmp_path, bad):
    with pytest.raises(TypeError, match="not supported"):
        strata.write(tmp_path / "v.raw", bad)
    assert not (tmp_path / "v.raw").exists()


def test_bad_arguments_raise_python_errors(tmp_path):
    with pytest.raises(ValueError, match="3-D"):
        strata.write(tmp_path / "v.raw", np.zeros((4, 4), np.uint8))
    with pytest.raises(ValueError, match="at least one voxel"):
        strata.write(tmp_path / "v.raw", np.zeros((0, 4, 4), np.uint8))
    with pytest.raises(TypeError, match="numpy array"):
        strata.write(tmp_path / "v.raw", [[[1]]])
    with pytest.raises(TypeError, match="path"):
        strata.read(42)
    with pytest.raises(ValueError, match="spacing"):
        strata.write(tmp_path / "v.raw", np.zeros((2, 2, 2), np.uint8), spacing=(1, 0, 1))
    with pytest.raises(TypeError):
        strata.read(tmp_path / "v.raw", shape=(2, 2, 2), dtype="complex")


def test_library_errors_keep_the_cli_message(tmp_path, cli):
    missing = tmp_path / "missing.nrrd"
    with pytest.raises(strata.Error) as e:
        strata.read(missing)
    assert isinstance(e.value, RuntimeError)
    assert str(e.value) == cli_error_message(cli("info", missing, expect_error=True))
    (tmp_path / "broken.nrrd").write_bytes(b"NRRD0004\ntype: ushort\ndimension: 3\nsizes: 4 4\n\n")
    with pytest.raises(strata.FormatError) as e:
        strata.read(tmp_path / "broken.nrrd")
    assert str(e.value) == cli_error_message(cli("info", tmp_path / "broken.nrrd", expect_error=True))
    with pytest.raises(strata.Error, match="unknown|extension|format"):
        strata.write(tmp_path / "v.xyz", np.zeros((2, 2, 2), np.uint8))


def test_raw_sidecar_written(tmp_path):
    a = sample(np.uint8)
    write_raw(tmp_path / "mine.raw", a)
    np.testing.assert_array_equal(strata.read(tmp_path / "mine.raw"), a)
    strata.write(tmp_path / "theirs.raw", a, spacing=(2, 1, 1))
    side = json.loads((tmp_path / "theirs.raw.json").read_text())
    assert side["dims"] == [7, 6, 5] and side["spacing"] == [1, 1, 2]
