"""DICOM series against the reference writer (Debian's python3-pydicom): a small CT-like series
written at test time with shuffled file names, an oblique orientation, a rescale slope and
intercept and signed 16-bit samples; Strata's array, spacing, origin and direction are compared
with what numpy computes from the tags. Also: several series in one folder, one chosen by its
UID; an RLE-compressed series; a missing tag named. (DICOM is read only: nothing to write back.)"""

import numpy as np
import pydicom
import pytest
from pydicom.dataset import FileDataset, FileMetaDataset
from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian, RLELossless, generate_uid

import strata

ROWS, COLUMNS = 5, 6
PIXEL_SPACING = (0.6, 0.8)  # (between rows = y, between columns = x)
GAP = 1.5
# An oblique plane: the row direction turned 20 degrees about z, the column direction tilted.
ANGLE = np.deg2rad(20)
ROW = np.array([np.cos(ANGLE), np.sin(ANGLE), 0.0])
COLUMN = np.array([-np.sin(ANGLE) * np.cos(0.3), np.cos(ANGLE) * np.cos(0.3), np.sin(0.3)])
NORMAL = np.cross(ROW, COLUMN)
ORIGIN = np.array([-120.5, 33.25, 80.0])


def stored_slice(k):
    """Slice k's stored values: signed, some negative, within 12 bits."""
    y, x = np.mgrid[0:ROWS, 0:COLUMNS]
    return (x * 37 - y * 101 + k * 211 - 900).astype(np.int16)


def write_slice(path, k, series_uid, *, slope=1.0, intercept=-1024.0, description="CT", syntax=ExplicitVRLittleEndian,
                drop=None):
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = CTImageStorage
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = FileDataset(str(path), {}, file_meta=meta, preamble=b"\0" * 128)
    ds.SOPClassUID = CTImageStorage
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.SeriesInstanceUID = series_uid
    ds.SeriesDescription = description
    ds.Modality = "CT"
    ds.Rows, ds.Columns = ROWS, COLUMNS
    ds.SamplesPerPixel = 1
    ds.PhotometricInterpretation = "MONOCHROME2"
    ds.BitsAllocated, ds.BitsStored, ds.HighBit = 16, 12, 11
    ds.PixelRepresentation = 1
    ds.PixelSpacing = list(PIXEL_SPACING)
    ds.SliceThickness = 5.0  # deliberately not the gap: spacing comes from the positions
    ds.ImageOrientationPatient = [f"{v:.10f}" for v in (*ROW, *COLUMN)]
    ds.ImagePositionPatient = [f"{v:.10f}" for v in ORIGIN + k * GAP * NORMAL]
    ds.RescaleSlope = f"{slope:g}"
    ds.RescaleIntercept = f"{intercept:g}"
    ds.PixelData = stored_slice(k).tobytes()
    if syntax != ExplicitVRLittleEndian:
        ds.compress(syntax)
    if drop:
        delattr(ds, drop)
    ds.save_as(str(path), write_like_original=False)


def write_series(folder, count, series_uid, shuffle_seed=7, **kwargs):
    folder.mkdir(exist_ok=True)
    names = np.random.default_rng(shuffle_seed).permutation(count)  # file names unrelated to positions
    for k in range(count):
        write_slice(folder / f"img{names[k]:03d}.dcm", k, series_uid, **kwargs)


def expected(count, slope=1.0, intercept=-1024.0):
    return np.stack([stored_slice(k) * slope + intercept for k in range(count)])  # (z, y, x)


def test_reads_an_oblique_rescaled_series(tmp_path):
    write_series(tmp_path / "ct", 6, generate_uid())
    a = strata.read(tmp_path / "ct")
    assert a.dtype == np.int16  # slope 1, integral intercept, 12-bit values: int16 like CT HU
    np.testing.assert_array_equal(a, expected(6))
    info = strata.info(tmp_path / "ct")
    assert info["format"] == "dicom"
    assert info["spacing"] == pytest.approx((GAP, PIXEL_SPACING[0], PIXEL_SPACING[1]))  # (z, y, x)
    assert info["world_space"] == "LPS" and info["unit"] == "mm"
    np.testing.assert_allclose(info["origin"], ORIGIN[::-1], atol=1e-6)  # (z, y, x)
    # The affine in array order, back to (x, y, z); its columns over the spacing are the axes.
    reverse = [2, 1, 0, 3]
    xyz = np.array(info["affine"])[reverse][:, reverse]
    direction = xyz[:3, :3] / np.array(info["spacing"][::-1])  # column c: index axis c (x, y, z)
    np.testing.assert_allclose(direction[:, 0], ROW, atol=1e-6)
    np.testing.assert_allclose(direction[:, 1], COLUMN, atol=1e-6)
    np.testing.assert_allclose(direction[:, 2], NORMAL, atol=1e-6)


def test_slope_other_than_one_gives_float(tmp_path):
    write_series(tmp_path / "pet", 4, generate_uid(), slope=0.25, intercept=3.5)
    a = strata.read(tmp_path / "pet")
    assert a.dtype == np.float32
    np.testing.assert_allclose(a, expected(4, 0.25, 3.5), rtol=1e-6)


def test_several_series_are_listed_and_one_is_chosen(tmp_path):
    first, second = generate_uid(), generate_uid()
    write_series(tmp_path / "mixed", 3, first, description="scout")
    for k in range(2):
        write_slice(tmp_path / "mixed" / f"b{k}.dcm", k, second, description="thin")
    with pytest.raises(strata.Error) as refused:
        strata.read(tmp_path / "mixed")
    assert first in str(refused.value) and second in str(refused.value)
    assert '"scout" (3 slices)' in str(refused.value) and '"thin" (2 slices)' in str(refused.value)
    np.testing.assert_array_equal(strata.read(f"{tmp_path / 'mixed'}:{second}"), expected(2))


def test_reads_rle_compressed_slices(tmp_path):
    write_series(tmp_path / "rle", 3, generate_uid(), syntax=RLELossless)
    assert pydicom.dcmread(next((tmp_path / "rle").iterdir())).file_meta.TransferSyntaxUID == RLELossless
    np.testing.assert_array_equal(strata.read(tmp_path / "rle"), expected(3))


def test_missing_position_is_named(tmp_path):
    write_series(tmp_path / "bad", 2, generate_uid())
    write_slice(tmp_path / "bad" / "late.dcm", 2, pydicom.dcmread(next((tmp_path / "bad").iterdir())).SeriesInstanceUID,
                drop="ImagePositionPatient")
    with pytest.raises(strata.Error, match=r"late\.dcm: ImagePositionPatient \(0020,0032\): missing"):
        strata.read(tmp_path / "bad")


def test_reads_the_frames_of_an_implicit_vr_multi_frame_file(tmp_path):
    path = tmp_path / "frames.dcm"
    write_slice(path, 0, generate_uid(), intercept=0.0)
    ds = pydicom.dcmread(path)
    ds.file_meta.TransferSyntaxUID = pydicom.uid.ImplicitVRLittleEndian
    frames = np.stack([stored_slice(k) for k in range(3)])
    ds.NumberOfFrames = 3
    ds.SpacingBetweenSlices = 2.0  # one ImagePositionPatient: frames lie this far apart along the normal
    ds.PixelData = frames.tobytes()
    ds.save_as(str(path), write_like_original=False)
    np.testing.assert_array_equal(strata.read(path), frames)
    assert strata.info(path)["spacing"] == pytest.approx((2.0, PIXEL_SPACING[0], PIXEL_SPACING[1]))
