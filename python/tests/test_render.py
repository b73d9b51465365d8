"""strata.render and strata.Renderer: the frames `strata render` writes, as numpy arrays."""

import numpy as np
import pytest

import strata
from conftest import read_png


def test_scalar_frame_equals_the_cli_png(tmp_path, cli, scalar_file):
    cli("render", scalar_file, "-o", tmp_path / "f.png", "--size", "48x32", "--azimuth", "50", "--rank", "8",
        "--tf", "mri")
    ours = strata.render(scalar_file, size=(48, 32), azimuth=50, rank=8, tf="mri")
    assert ours.shape == (32, 48, 4) and ours.dtype == np.uint8
    np.testing.assert_array_equal(ours, read_png(tmp_path / "f.png"))
    assert ours[..., :3].max() > 0  # something is drawn


def test_label_frame_equals_the_cli_png(tmp_path, cli, label_file):
    cli("render", label_file, "-o", tmp_path / "l.png", "--size", "40x40", "--elevation", "60", "--ortho")
    with strata.open(label_file) as lab:
        ours = strata.render(lab, size=(40, 40), elevation=60, ortho=True)
    np.testing.assert_array_equal(ours, read_png(tmp_path / "l.png"))


def test_renderer_keeps_its_caches_and_views_differ(scalar_file):
    with strata.Renderer(scalar_file, background=(0.2, 0.2, 0.2)) as r:
        assert r.kind == "scalar" and r.shape == (40, 48, 56)
        a = r.frame(size=(32, 24), azimuth=0)
        b = r.frame(size=(32, 24), azimuth=90)
        again = r.frame(size=(32, 24), azimuth=0)
        assert r.stats["load"]["cache_hits"] > 0
    np.testing.assert_array_equal(a, again)
    assert not np.array_equal(a, b)
    assert tuple(a[0, 0, :3]) == (51, 51, 51)  # the background in a corner
    tf = {"range": [0, 4000], "points": [{"x": 0.0, "rgba": [1, 0, 0, 0]}, {"x": 1.0, "rgba": [1, 0, 0, 1]}]}
    red = strata.render(scalar_file, size=(32, 24), tf=tf, shading=False)  # no white highlights
    assert red[..., 0].max() > 0 and red[..., 1:3].max() == 0


def test_bad_render_arguments(scalar_file):
    with pytest.raises(ValueError, match="CameraSpec::width"):
        strata.render(scalar_file, size=(0, 10))
    with pytest.raises(ValueError, match="preset_or_path"):
        strata.render(scalar_file, size=(8, 8), tf="no-such-preset")
    with pytest.raises(ValueError, match="lighting"):
        strata.render(scalar_file, size=(8, 8), lighting="sunny")
    with pytest.raises(ValueError, match="background"):
        strata.Renderer(scalar_file, background=(2, 0, 0))
    with pytest.raises(strata.Error):
        strata.render(scalar_file.parent / "missing.strata")
    r = strata.Renderer(scalar_file)
    r.close()
    with pytest.raises(ValueError, match="closed"):
        r.frame(size=(8, 8))
