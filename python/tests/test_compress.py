"""strata.compress and strata.labels.encode: the CLI's files, byte for byte, from a path or an
array; reports, progress and argument errors."""

import json
import struct

import numpy as np
import pytest

import strata
from conftest import label_volume, scalar_volume


def test_compress_defaults_match_the_cli_bytes(tmp_path, scalar_raw, scalar_file):
    report = strata.compress(scalar_raw, tmp_path / "path.strata")
    assert (tmp_path / "path.strata").read_bytes() == scalar_file.read_bytes()
    strata.compress(scalar_volume(), tmp_path / "array.strata")
    assert (tmp_path / "array.strata").read_bytes() == scalar_file.read_bytes()
    assert report["file_bytes"] == scalar_file.stat().st_size
    assert report["input_voxels"] == scalar_volume().size
    assert sum(l["bricks"] for l in report["levels"]) > 1 and 0 < report["bits_per_voxel"] < 16


@pytest.mark.parametrize("args,kwargs", [
    (["--rank", "6", "--brick", "16", "--overlap", "1", "--quant", "u8,b8lin", "--hooi", "0", "--zstd", "0"],
     dict(rank=6, brick=16, overlap=1, quant="u8,b8lin", hooi=0, zstd=0)),
    (["--psnr", "45"], dict(psnr=45)),
    (["--max-error", "30", "--coarse-growth", "1.5"], dict(max_error=30, coarse_growth=1.5)),
    (["--codec", "ta-global", "--rank", "8"], dict(codec="ta-global", rank=8)),
])
def test_compress_parameters_match_the_cli_bytes(tmp_path, cli, scalar_raw, args, kwargs):
    cli("compress", scalar_raw, "-o", tmp_path / "cli.strata", *args)
    strata.compress(scalar_volume(), tmp_path / "py.strata", **kwargs)
    assert (tmp_path / "py.strata").read_bytes() == (tmp_path / "cli.strata").read_bytes()


def test_spacing_of_an_array_is_stored(tmp_path):
    strata.compress(scalar_volume((8, 9, 10)), tmp_path / "s.strata", spacing=(3.0, 2.0, 0.5), rank=4, brick=8)
    with strata.open(tmp_path / "s.strata") as f:
        assert f.spacing == (3.0, 2.0, 0.5) and f.shape == (8, 9, 10)
        assert f.metadata["source"]["spacing"] == [0.5, 2.0, 3.0]


def label_file_parts(path):
    """A label file's payload bytes (everything between the header and the metadata) and its
    metadata without the encoder's timings: a Mixture Graph file records how long factorizing
    took (metadata.stats.factor_seconds), so two runs of the CLI itself differ there, and in the
    checksums that cover the metadata, and nowhere else."""
    data = path.read_bytes()
    metadata_offset, metadata_size = struct.unpack_from("<QQ", data, 32)
    metadata = json.loads(data[metadata_offset:metadata_offset + metadata_size])
    metadata["stats"] = {k: v for k, v in metadata["stats"].items() if not k.endswith("seconds")}
    return data[64:metadata_offset], metadata


def test_labels_encode_matches_the_cli_file(tmp_path, cli, label_raw, label_file):
    report = strata.labels.encode(label_raw, tmp_path / "path.strata")
    assert label_file_parts(tmp_path / "path.strata") == label_file_parts(label_file)
    strata.labels.encode(label_volume(), tmp_path / "array.strata")
    assert label_file_parts(tmp_path / "array.strata") == label_file_parts(label_file)
    assert report["sources"] == 5 and report["nodes"] >= 5 and report["max_l1_error"] is not None
    cli("labels", "encode", label_raw, "-o", tmp_path / "cli8.strata", "--bits", "6", "--ids", "fixed",
        "--strategy", "max-occurrence", "--zstd", "0")
    strata.labels.encode(label_volume(), tmp_path / "py8.strata", bits=6, ids="fixed", strategy="max-occurrence", zstd=0)
    assert label_file_parts(tmp_path / "py8.strata") == label_file_parts(tmp_path / "cli8.strata")
    assert label_file_parts(tmp_path / "py8.strata") != label_file_parts(label_file)


def test_progress_callback_sees_every_task_to_its_end(tmp_path):
    calls = []
    strata.compress(scalar_volume(), tmp_path / "p.strata", progress=lambda *c: calls.append(c))
    tasks = {}
    for task, done, total in calls:
        assert isinstance(task, str) and 0 <= done <= total
        assert done >= tasks.get(task, (0, 0))[0] or done == 0  # never backwards within a task run
        tasks[task] = (done, total)
    assert tasks and all(done == total for done, total in tasks.values())


def test_progress_bar_draws_on_stderr(tmp_path, capsys):
    strata.labels.encode(label_volume(), tmp_path / "l.strata", progress=True)
    err = capsys.readouterr().err
    assert "100.0%" in err and "|" in err


def test_an_exception_in_the_callback_is_raised_after_the_call(tmp_path):
    def callback(task, done, total):
        raise KeyError("stop")

    with pytest.raises(KeyError, match="stop"):
        strata.compress(scalar_volume((16, 16, 16)), tmp_path / "x.strata", progress=callback)


def test_bad_parameters_raise_value_errors(tmp_path, scalar_raw):
    a = scalar_volume((16, 16, 16))
    out = tmp_path / "x.strata"
    with pytest.raises(strata.ParameterError, match="CodecParams::rank"):
        strata.compress(a, out, rank=40)
    with pytest.raises(ValueError, match="BrickLayout::overlap"):
        strata.compress(a, out, brick=8, overlap=4)
    with pytest.raises(ValueError, match="at most one error target"):
        strata.compress(a, out, psnr=40, rmse=2)
    with pytest.raises(ValueError, match="quant, hooi"):
        strata.compress(a, out, psnr=40, quant="f32")
    with pytest.raises(ValueError, match="ErrorTarget::value"):
        strata.compress(a, out, psnr=-1)
    with pytest.raises(ValueError, match="codec"):
        strata.compress(a, out, codec="zfp")
    with pytest.raises(ValueError, match="hooi"):
        strata.compress(a, out, hooi=1000)
    with pytest.raises(strata.Error, match="u16,b8log"):
        strata.compress(a, out, quant="u12")
    with pytest.raises(ValueError, match="input file"):
        strata.compress(scalar_raw, scalar_raw)
    with pytest.raises(ValueError, match="raw files"):
        strata.compress(a, out, shape=(1, 2, 3))
    with pytest.raises(TypeError, match="progress"):
        strata.compress(a, out, progress="yes")
    with pytest.raises(ValueError, match="bits"):
        strata.labels.encode(label_volume(), out, bits=0)
    assert not out.exists()


def test_labels_encode_refuses_float_samples(tmp_path):
    with pytest.raises(TypeError, match="integer samples"):
        strata.labels.encode(np.zeros((4, 4, 4), np.float32), tmp_path / "l.strata")
    with pytest.raises(TypeError, match="not supported"):
        strata.labels.encode(np.zeros((4, 4, 4), np.float16), tmp_path / "l.strata")
    assert not (tmp_path / "l.strata").exists()


def test_codecs_lists_the_registry_and_compress_takes_each_fixed_rank_name(tmp_path):
    entries = strata.codecs()
    names = {e["name"] for e in entries}
    assert {"ta-bricked", "ta-global"} <= names
    assert {e["mode"] for e in entries} == {"fixed-rank", "error-target"}
    assert [e["distributed"] for e in entries if e["name"] == "ta-global"] == [False]
    a = scalar_volume((16, 16, 16))
    for e in entries:
        if e["mode"] == "fixed-rank":
            strata.compress(a, tmp_path / "c.strata", codec=e["name"], rank=4, brick=8, overlap=1)
            assert strata.open(tmp_path / "c.strata").codec == e["name"]
    with pytest.raises(strata.ParameterError, match="CodecParams::zstd_level"):
        strata.compress(a, tmp_path / "x.strata", zstd=20)
