"""strata.open on TA files: attributes, slicing against `strata decompress --box`, levels, ranks,
and the errors of bad boxes, closed, missing and corrupt files."""

import numpy as np
import pytest

import strata
from conftest import cli_error_message, scalar_volume


def cli_decompress(cli, tmp_path, strata_file, *args):
    out = tmp_path / "cli_out.raw"
    cli("decompress", strata_file, "-o", out, *args)
    return strata.read(out)


def test_attributes(scalar_file):
    with strata.open(scalar_file) as f:
        assert isinstance(f, strata.ScalarFile)
        assert f.codec == "ta-bricked" and f.shape == (40, 48, 56) and f.dtype == np.uint16
        assert f.rank == 16 and f.brick == 32 and f.quant == "u16,b8log+" and f.volume is None
        assert f.levels == 2 and f.level_shape(1) == (20, 24, 28) and f.level(1).shape == (20, 24, 28)
        assert f.metadata["codec"] == "ta-bricked" and f.metadata["source"]["dims"] == [56, 48, 40]
        lo, hi = f.value_range
        assert lo < hi
    assert f.closed
    with pytest.raises(ValueError, match="closed"):
        f.shape


def test_slicing_equals_the_cli_box(tmp_path, cli, scalar_file):
    f = strata.open(scalar_file)
    ours = f[3:29, 10:40, 5:51]
    theirs = cli_decompress(cli, tmp_path, scalar_file, "--box", "5,10,3:51,40,29")
    assert ours.dtype == np.uint16 and ours.shape == (26, 30, 46)
    np.testing.assert_array_equal(ours, theirs)
    # The same box in the other spellings read() takes.
    np.testing.assert_array_equal(f.read("5,10,3:51,40,29"), theirs)
    np.testing.assert_array_equal(f.read(((3, 29), (10, 40), (5, 51))), theirs)


def test_levels_ranks_and_float_match_the_cli(tmp_path, cli, scalar_file):
    f = strata.open(scalar_file)
    coarse = f.level(1)[2:17, :, 4:]
    theirs = cli_decompress(cli, tmp_path, scalar_file, "--level", "1", "--rank", "5", "--box", "4,0,2:28,24,17")
    low = f.read(np.s_[2:17, :, 4:], level=1, rank=5)
    assert low.dtype == np.float32 and coarse.dtype == np.float32
    np.testing.assert_array_equal(low, theirs)
    assert not np.array_equal(low, coarse)  # rank 5 is not the stored rank 16
    whole = f.read(as_float=True)
    np.testing.assert_array_equal(whole, cli_decompress(cli, tmp_path, scalar_file, "--float"))
    # Reconstruction error grows as the rank drops (the rank slider).
    original = scalar_volume().astype(np.float64)
    errors = [np.sqrt(np.mean((f.read(rank=k, as_float=True) - original) ** 2)) for k in (2, 6, 16)]
    assert errors[0] > errors[1] > errors[2]


def test_numpy_indexing_semantics(scalar_file):
    f = strata.open(scalar_file)
    full = f[...]
    assert full.shape == f.shape
    for key in [np.s_[5], np.s_[-1, 3], np.s_[::3, 1:-1:4, ::-5], np.s_[..., 7], np.s_[2:3, 4, -9:],
                np.s_[10:2:-2, ::7], np.s_[:, :, 60:], np.s_[100:, 0], np.s_[-100:3]]:
        ours = f[key]
        np.testing.assert_array_equal(ours, full[key], err_msg=str(key))
        assert ours.shape == full[key].shape
    level = f.level(1)
    np.testing.assert_array_equal(level[::2, 3], level[...][::2, 3])
    with pytest.raises(IndexError):
        f[40]
    with pytest.raises(IndexError):
        f[0, 0, 0, 0]
    with pytest.raises(TypeError):
        f[None]
    with pytest.raises(TypeError):
        f[np.array([1, 2])]


def test_bad_boxes_levels_and_ranks_raise_value_errors(scalar_file):
    f = strata.open(scalar_file)
    for box in [((0, 41), (0, 5), (0, 5)), ((5, 5), (0, 5), (0, 5)), "0,0,0:57,48,40", ((-1, 3), (0, 1), (0, 1))]:
        with pytest.raises(ValueError, match="box"):
            f.read(box)
    with pytest.raises(TypeError, match="box"):
        f.read(3)
    with pytest.raises(ValueError, match="step 1"):
        f.read(np.s_[::2, :, :])
    with pytest.raises(strata.ParameterError, match="level"):
        f.read(level=2)
    with pytest.raises(ValueError, match="level"):
        f.level(-1)
    with pytest.raises(ValueError, match="rank"):
        f.read(rank=17)


def test_missing_and_corrupt_files_raise_the_cli_messages(tmp_path, cli, scalar_file):
    missing = tmp_path / "missing.strata"
    with pytest.raises(strata.Error) as e:
        strata.open(missing)
    assert str(e.value) == cli_error_message(cli("decompress", missing, "-o", tmp_path / "o.raw", expect_error=True))

    data = bytearray(scalar_file.read_bytes())
    data[200:260] = bytes(60)  # inside the first brick's payload: its checksum no longer matches
    corrupt = tmp_path / "corrupt.strata"
    corrupt.write_bytes(bytes(data))
    f = strata.open(corrupt)
    with pytest.raises(strata.FormatError) as e:
        f[...]
    message = cli_error_message(cli("decompress", corrupt, "-o", tmp_path / "o.raw", expect_error=True))
    assert str(e.value) == message and "checksum" in message

    truncated = tmp_path / "truncated.strata"
    truncated.write_bytes(scalar_file.read_bytes()[:-100])
    with pytest.raises(strata.FormatError) as e:
        strata.open(truncated)
    assert str(e.value) == cli_error_message(cli("decompress", truncated, "-o", tmp_path / "o.raw", expect_error=True))

    not_strata = tmp_path / "volume.strata"
    strata.write(tmp_path / "v.raw", scalar_volume((4, 4, 4)))
    not_strata.write_bytes((tmp_path / "v.raw").read_bytes())
    with pytest.raises(strata.Error):
        strata.open(not_strata)


def test_global_codec_file(tmp_path):
    strata.compress(scalar_volume(), tmp_path / "g.strata", codec="ta-global", rank=8)
    f = strata.open(tmp_path / "g.strata")
    assert f.codec == "ta-global" and f.rank == 8
    err = np.abs(f.read(as_float=True) - scalar_volume()).mean()
    assert err < 0.05 * scalar_volume().mean()
