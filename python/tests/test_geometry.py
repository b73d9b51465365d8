"""Where a volume lies, end to end: nibabel's affine, qform/sform codes and units of a real MRI
survive compress then decompress; NRRD's space fields survive a round trip; opened .strata files
behave as numpy arrays (numpy.asarray, dask, xarray)."""

import numpy as np
import pytest

import strata

nib = pytest.importorskip("nibabel")

CH2 = "/usr/share/mricron/templates/ch2better.nii.gz"


def mricron(path):
    import os

    if not os.path.exists(path):
        pytest.skip("mricron-data is not installed")
    return path


def header_placement(img):
    h = img.header
    return img.affine, int(h["qform_code"]), int(h["sform_code"]), h.get_xyzt_units(), h.get_qform(), h.get_sform()


def test_compress_then_decompress_keeps_the_nifti_placement(tmp_path, cli):
    src = mricron(CH2)
    cli("compress", src, "-o", tmp_path / "ch2.strata", "--psnr", "40")
    cli("decompress", tmp_path / "ch2.strata", "-o", tmp_path / "back.nii.gz")
    want = header_placement(nib.load(src))
    got = header_placement(nib.load(tmp_path / "back.nii.gz"))
    np.testing.assert_array_equal(got[0], want[0])  # the affine, exactly
    assert got[1:4] == want[1:4]  # codes and units
    np.testing.assert_array_equal(got[4], want[4])
    np.testing.assert_array_equal(got[5], want[5])


def test_a_coarser_level_lies_over_the_same_anatomy(tmp_path, cli):
    src = mricron(CH2)
    cli("compress", src, "-o", tmp_path / "ch2.strata", "--psnr", "30")
    cli("decompress", tmp_path / "ch2.strata", "--level", "1", "-o", tmp_path / "l1.nii.gz")
    a0, a1 = nib.load(src).affine, nib.load(tmp_path / "l1.nii.gz").affine
    np.testing.assert_allclose(a1[:3, :3], a0[:3, :3] * 2)
    # Level-1 voxel 0 is the mean of level-0 voxels 0 and 1 along each axis: its centre is there.
    np.testing.assert_allclose(a1[:3, 3], a0[:3, :3] @ [0.5, 0.5, 0.5] + a0[:3, 3])


def test_strata_info_gives_the_affine_in_array_order():
    src = mricron(CH2)
    info = strata.info(src)
    a = nib.load(src).affine
    reverse = [2, 1, 0, 3]
    np.testing.assert_allclose(info["affine"], a[reverse][:, reverse])
    assert info["world_space"] == "RAS"
    assert info["origin"] == pytest.approx(tuple(a[:3, 3][::-1]))


def test_nrrd_space_fields_round_trip(tmp_path):
    a = np.arange(60, dtype=np.int16).reshape(3, 4, 5)
    strata.write(tmp_path / "a.nrrd", a, spacing=(2.0, 1.0, 0.5), origin=(-5.0, 4.0, 3.0), unit="mm")
    text = (tmp_path / "a.nrrd").read_bytes().split(b"\n\n")[0].decode()
    assert "space origin: (3,4,-5)" in text
    assert 'space units: "mm" "mm" "mm"' in text
    info = strata.info(tmp_path / "a.nrrd")
    assert info["origin"] == (-5.0, 4.0, 3.0)
    assert info["spacing"] == (2.0, 1.0, 0.5)
    assert info["unit"] == "mm"


def test_64_bit_ids_round_trip_exactly(tmp_path):
    ids = (np.arange(24, dtype=np.uint64).reshape(2, 3, 4) * (1 << 40)) + (1 << 41)
    strata.write(tmp_path / "ids.nrrd", ids)
    back = strata.read(tmp_path / "ids.nrrd")
    assert back.dtype == np.uint64
    np.testing.assert_array_equal(back, ids)


def test_opened_files_are_arrays_to_numpy_dask_and_xarray(tmp_path, cli):
    vol = strata.generate("prisms", (20, 24, 28), seed=3)
    strata.compress(vol, tmp_path / "p.strata", rank=8, brick=16)
    f = strata.open(tmp_path / "p.strata")
    assert f.ndim == 3 and f.size == 20 * 24 * 28 and len(f) == 20
    whole = np.asarray(f)
    assert whole.shape == f.shape and whole.dtype == f.dtype
    np.testing.assert_array_equal(whole, f.read())
    np.testing.assert_array_equal(np.asarray(f, dtype=np.float64), whole.astype(np.float64))
    da = pytest.importorskip("dask.array")
    d = da.from_array(f, chunks=(8, 12, 14))
    np.testing.assert_array_equal(d.compute(), whole)
    np.testing.assert_array_equal(d[3:9, ::2, 5].compute(), whole[3:9, ::2, 5])
    xr = pytest.importorskip("xarray")
    x = xr.DataArray(np.asarray(f), dims=("z", "y", "x"))
    assert x.shape == f.shape


def test_decompress_writes_every_level_as_an_ome_zarr_pyramid(tmp_path, cli):
    zarr = pytest.importorskip("zarr")
    vol = strata.generate("prisms", (24, 40, 36), seed=5)
    strata.write(tmp_path / "v.nrrd", vol, spacing=(2.0, 0.5, 0.5), origin=(10.0, -4.0, 3.0), unit="um")
    cli("compress", tmp_path / "v.nrrd", "-o", tmp_path / "v.strata", "--brick", "16", "--rank", "8")
    cli("decompress", tmp_path / "v.strata", "-o", tmp_path / "v.ome.zarr")
    f = strata.open(tmp_path / "v.strata")
    group = zarr.open_group(str(tmp_path / "v.ome.zarr"), mode="r")
    datasets = group.attrs["multiscales"][0]["datasets"]
    assert len(datasets) == f.levels
    for level, d in enumerate(datasets):
        a = group[d["path"]]
        assert a.shape == f.level_shape(level) and a.dtype == f.dtype
        scale = next(t["scale"] for t in d["coordinateTransformations"] if t["type"] == "scale")
        assert scale == pytest.approx([s * 2**level for s in (2.0, 0.5, 0.5)])
    np.testing.assert_array_equal(group["0"][:], f.read())
    # Each level reads back through strata's own OME-Zarr reader with its placement.
    info = strata.info(tmp_path / "v.ome.zarr", level=1)
    assert info["spacing"] == pytest.approx((4.0, 1.0, 1.0))
    assert info["origin"] == pytest.approx((10.0 + 1.0, -4.0 + 0.25, 3.0 + 0.25))
