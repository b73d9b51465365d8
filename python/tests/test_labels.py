"""strata.open on Mixture Graph files: decoded labels, box queries, label fractions and palettes,
each against the CLI's `strata labels` commands."""

import json

import numpy as np
import pytest

import strata
from conftest import label_volume


@pytest.fixture()
def lab(label_file):
    with strata.open(label_file) as f:
        yield f


def test_attributes_and_level0_bit_exact(lab):
    assert isinstance(lab, strata.LabelFile)
    assert lab.codec == "mixture-graph" and lab.shape == (24, 28, 32) and lab.dtype == np.uint32
    assert list(lab.labels) == [0, 3, 17, 250, 1000] and lab.levels == 6
    assert lab.metadata["codec"] == "mixture-graph" and lab.node_count >= 5
    np.testing.assert_array_equal(lab[...], label_volume())
    np.testing.assert_array_equal(lab[3:9, -5:, ::2], label_volume()[3:9, -5:, ::2])


def test_coarse_levels_match_labels_decode(tmp_path, cli, label_file, lab):
    cli("labels", "decode", label_file, "--level", "2", "-o", tmp_path / "l2.raw")
    dominant = strata.read(tmp_path / "l2.raw")
    assert lab.level_shape(2) == dominant.shape == (6, 7, 8)
    np.testing.assert_array_equal(lab.level(2)[...], dominant)
    np.testing.assert_array_equal(lab.read(np.s_[1:4, 2:7, 0:5], level=2), dominant[1:4, 2:7, 0:5])


def test_every_level_into_an_ome_zarr_and_a_precomputed_pyramid(tmp_path, cli, label_file, lab):
    zarr = pytest.importorskip("zarr")
    cli("labels", "decode", label_file, "-o", tmp_path / "cells.ome.zarr")
    cli("labels", "decode", label_file, "-o", tmp_path / "cells.precomputed")
    image = zarr.open(str(tmp_path / "cells.ome.zarr"), mode="r")
    assert len(image.attrs["multiscales"][0]["datasets"]) == lab.levels
    info = json.loads((tmp_path / "cells.precomputed" / "info").read_text())
    assert info["type"] == "segmentation" and len(info["scales"]) == lab.levels
    for level in range(lab.levels):
        expected = lab.level(level)[...]  # level 0 exact, then the dominant label
        np.testing.assert_array_equal(image[str(level)][...], expected)
        np.testing.assert_array_equal(strata.read(tmp_path / "cells.precomputed", level=level), expected)


@pytest.mark.parametrize("method", ["hybrid", "footprint", "naive", "coarse"])
@pytest.mark.parametrize("box", ["0,0,0:32,28,24", "3,5,2:29,17,21", "7,1,11:8,27,12"])
def test_queries_equal_the_cli(cli, label_file, lab, method, box):
    theirs = json.loads(cli("labels", "query", label_file, "--box", box, "--method", method, "--json"))
    ours = lab.query(box, method=method)
    assert list(ours) == [row["label"] for row in theirs["labels"]]
    for row in theirs["labels"]:
        count, sigma = ours[row["label"]]
        assert count == pytest.approx(row["count"], rel=1e-12, abs=1e-9)
        assert sigma == pytest.approx(row["sigma"], rel=1e-12, abs=1e-9)


def test_naive_query_counts_the_voxels(lab):
    x0, y0, z0, x1, y1, z1 = 2, 3, 4, 30, 20, 22
    ours = lab.query(np.s_[z0:z1, y0:y1, x0:x1], method="naive")
    values, counts = np.unique(label_volume()[z0:z1, y0:y1, x0:x1], return_counts=True)
    assert ours == {int(v): (float(c), 0.0) for v, c in zip(values, counts)}
    with pytest.raises(ValueError, match="box"):
        lab.query(((0, 25), (0, 1), (0, 1)))
    with pytest.raises(strata.Error, match="hybrid"):
        lab.query(method="fast")


def test_fraction_matches_labels_decode(tmp_path, cli, label_file, lab):
    cli("labels", "decode", label_file, "--level", "1", "--label", "17", "-o", tmp_path / "f.raw")
    theirs = strata.read(tmp_path / "f.raw")
    ours = lab.fraction(17, 1)
    assert ours.dtype == np.float32 and ours.shape == lab.level_shape(1)
    np.testing.assert_array_equal(ours, theirs)
    np.testing.assert_array_equal(lab.fraction(17), (label_volume() == 17).astype(np.float32))
    with pytest.raises(strata.Error, match="does not occur"):
        lab.fraction(18)
    with pytest.raises(ValueError, match="level"):
        lab.fraction(17, 6)


def test_palette_matches_labels_palette(tmp_path, cli, label_file, lab):
    colors = {3: (1, 0, 0, 1), 1000: (0, 0.5, 1, 0.25), 77: (1, 1, 1, 1), "default": (0.1, 0.2, 0.3, 0.4)}
    (tmp_path / "colors.json").write_text(json.dumps({str(k): v for k, v in colors.items()}))
    cli("labels", "palette", label_file, "--colors", tmp_path / "colors.json", "-o", tmp_path / "palette.json")
    theirs = np.asarray(json.loads((tmp_path / "palette.json").read_text())["rgba"], dtype=np.float32)
    ours = lab.palette(colors)
    assert ours.shape == (lab.node_count, 4) and ours.dtype == np.float32
    np.testing.assert_array_equal(ours, theirs)
    # Level 0 voxels are the labels' own nodes: their colour is the label's.
    rgba = ours[lab.read_nodes(np.s_[0:4, 0:4, 0:4])]
    expected = np.array([colors.get(int(v), colors["default"]) for v in label_volume()[0:4, 0:4, 0:4].ravel()])
    np.testing.assert_allclose(rgba.reshape(-1, 4), expected, rtol=1e-6)
    with pytest.raises(ValueError, match="r, g, b, a"):
        lab.palette({3: (1, 0, 0)})
    with pytest.raises(TypeError, match="label values"):
        lab.palette({"red": (1, 0, 0, 1)})


def test_labels_from_a_strata_file_refuse_floats(lab):
    with pytest.raises(ValueError, match="as_float"):
        lab.read(as_float=True)


def test_64_bit_ids_above_2_to_the_40_encode_decode_and_query_exactly(tmp_path, cli):
    small = label_volume()[:16, :20, :24]
    ids = (small.astype(np.uint64) + np.uint64(1)) * np.uint64(1 << 40) + np.uint64(7)  # every id above 2^40
    strata.write(tmp_path / "ids.nrrd", ids)
    cli("labels", "encode", tmp_path / "ids.nrrd", "-o", tmp_path / "ids.strata")
    f = strata.open(tmp_path / "ids.strata")
    assert f.dtype == np.uint64
    np.testing.assert_array_equal(f.read(), ids)
    cli("labels", "decode", tmp_path / "ids.strata", "-o", tmp_path / "back.nrrd")
    np.testing.assert_array_equal(strata.read(tmp_path / "back.nrrd"), ids)
    box = np.s_[2:14, 3:17, 5:21]
    values, counts = np.unique(ids[box], return_counts=True)
    assert f.query(box, method="naive") == {int(v): (float(c), 0.0) for v, c in zip(values, counts)}
    hybrid = f.query(box)
    assert set(hybrid) <= {int(v) for v in np.unique(ids)} and min(hybrid) > 1 << 40
