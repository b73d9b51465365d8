"""Careless or hostile arguments to the bindings: each is a Python exception in Strata's words,
never a crash of the interpreter and never pybind11's or the JSON library's text. The cases that
crashed run in a subprocess, so a regression fails the test instead of ending pytest."""

import math
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import strata
from conftest import scalar_volume

PYBIND11_TEXT = "Unable to cast Python instance to C++ type"


def run_python(code, *args):
    """Runs `code` in a fresh interpreter (the test's environment, so the same `strata`)."""
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code), *map(str, args)], capture_output=True,
                          text=True, timeout=240)


def test_a_view_whose_copy_does_not_fit_raises_memory_error(tmp_path):
    # A 2048^3 uint16 view of one sample: its contiguous copy (16 GiB) cannot be allocated under
    # an 8 GiB address-space limit. numpy's failure was swallowed and the copy dereferenced: SIGSEGV.
    result = run_python("""
        import resource, sys
        import numpy as np
        import strata
        resource.setrlimit(resource.RLIMIT_AS, (8 << 30, 8 << 30))
        out = sys.argv[1]
        views = {
            "zero strides": np.lib.stride_tricks.as_strided(np.zeros(1, np.uint16), (2048,) * 3, (0, 0, 0)),
            "byte-swapped": np.lib.stride_tricks.as_strided(np.zeros(1, ">u2"), (2048,) * 3, (0, 0, 0)),
        }
        calls = {
            "compress": lambda v: strata.compress(v, out + "/c.strata"),
            "labels.encode": lambda v: strata.labels.encode(v, out + "/l.strata"),
            "write": lambda v: strata.write(out + "/w.nrrd", v),
        }
        for view_name, view in views.items():
            for call_name, call in calls.items():
                try:
                    call(view)
                    print(call_name, view_name, "returned")
                except MemoryError as e:
                    print(call_name, view_name, "MemoryError:", e)
        """, tmp_path)
    assert result.returncode == 0, f"the interpreter died ({result.returncode}): {result.stderr}"
    lines = result.stdout.splitlines()
    assert len(lines) == 6, result.stdout + result.stderr
    for line in lines:
        assert "MemoryError: array: the (2048, 2048, 2048)" in line, line
        assert "GiB" in line and "C-contiguous" in line, line
    assert not any(tmp_path.iterdir())


def test_a_huge_generated_volume_raises_memory_error():
    result = run_python("""
        import resource
        import strata
        resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))
        try:
            strata.generate("sphere", (2048, 2048, 2048))
        except MemoryError as e:
            print("MemoryError:", e)
        """)
    assert result.returncode == 0, f"the interpreter died ({result.returncode}): {result.stderr}"
    assert result.stdout.startswith("MemoryError: Volume: cannot allocate 34359738368 bytes"), \
        result.stdout + result.stderr


@pytest.mark.parametrize("make", [
    lambda a: a[::-1, :, ::-2],                                              # negative strides
    lambda a: np.broadcast_to(a[:1, :1, :], a.shape),                        # zero strides
    lambda a: a.astype(a.dtype.newbyteorder(">")),                           # non-native byte order
    lambda a: np.asfortranarray(a),                                          # Fortran order
    lambda a: np.lib.stride_tricks.as_strided(a, a.shape, a.strides, writeable=False),  # read-only
])
def test_any_strides_byte_order_and_read_only_arrays_are_taken_by_value(tmp_path, make):
    view = make(scalar_volume((6, 7, 8)))
    strata.write(tmp_path / "v.nrrd", view)
    np.testing.assert_array_equal(strata.read(tmp_path / "v.nrrd"), view)
    strata.compress(view, tmp_path / "v.strata", brick=8, rank=4)
    assert strata.open(tmp_path / "v.strata").shape == view.shape


@pytest.mark.parametrize("bad, error, words", [
    (np.array(3, np.uint16), ValueError, "3-D array"),                      # 0-d
    (np.zeros(8, np.uint16), ValueError, "3-D array"),                      # 1-d
    (np.zeros((2, 2, 2, 2), np.uint16), ValueError, "3-D array"),           # 4-d
    (np.zeros((2, 0, 2), np.uint16), ValueError, "at least one voxel"),
    (np.zeros((2, 2, 2), object), TypeError, "not supported"),
    (np.zeros((2, 2, 2), "U3"), TypeError, "not supported"),
    (np.zeros((2, 2, 2), [("a", "<u2"), ("b", "<f4")]), TypeError, "not supported"),
    (np.zeros((2, 2, 2), ">c8"), TypeError, "not supported"),
    (np.zeros((2, 2, 2), bool), TypeError, "not supported"),
    ([[[1, 2]]], TypeError, "numpy array|a path"),                          # neither array nor path
    (np.uint16(3), TypeError, "numpy array|a path"),
])
def test_arrays_the_bindings_cannot_take_raise_python_errors(tmp_path, bad, error, words):
    for call in (lambda: strata.write(tmp_path / "v.nrrd", bad), lambda: strata.compress(bad, tmp_path / "v.strata"),
                 lambda: strata.labels.encode(bad, tmp_path / "l.strata")):
        with pytest.raises(error, match=words):
            call()
    assert not any(tmp_path.iterdir())


def test_integers_beyond_64_bits_and_bad_origins_are_named_not_pybind11_text(tmp_path, scalar_file, label_file):
    f = strata.open(scalar_file)
    with pytest.raises(ValueError, match=r"box: expected integers in \[-2\^63, 2\^63-1\]") as e:
        f.read(((0, 2 ** 70), (0, 1), (0, 1)))
    assert PYBIND11_TEXT not in str(e.value)
    with pytest.raises(ValueError, match=r"shape: expected integers in \[-2\^63, 2\^63-1\]"):
        strata.generate("sphere", (2 ** 64, 8, 8))
    with pytest.raises(TypeError, match=r"origin: expected three numbers \(z, y, x\)") as e:
        strata.write(tmp_path / "v.nrrd", np.zeros((2, 2, 2), np.uint8), origin=("a", 0, 0))
    assert PYBIND11_TEXT not in str(e.value)
    with pytest.raises(ValueError, match="origin: expected finite numbers"):
        strata.write(tmp_path / "v.nrrd", np.zeros((2, 2, 2), np.uint8), origin=(math.nan, 0, 0))
    lab = strata.open(label_file)
    with pytest.raises(ValueError, match=r"colors: label: expected integers in \[-2\^63, 2\^63-1\]") as e:
        lab.palette({2 ** 64: (1, 0, 0, 1)})
    assert PYBIND11_TEXT not in str(e.value)
    assert not (tmp_path / "v.nrrd").exists()


def test_nan_palette_colours_are_refused(label_file):
    lab = strata.open(label_file)
    for bad in [(math.nan, 0, 0, 1), (0, 0, 0, math.inf), (1e300, 0, 0, 1)]:
        with pytest.raises(ValueError, match=r"colors\[3\]: expected four finite numbers"):
            lab.palette({3: bad})
        with pytest.raises(ValueError, match=r"colors\['default'\]: expected four finite numbers"):
            lab.palette({"default": bad})
    assert lab.palette({3: (1, 0, 0, 1)}).shape == (lab.node_count, 4)


def test_nan_in_a_colour_map_or_transfer_function_dict_is_named_not_json_library_text(label_file, scalar_file):
    for call in (lambda: strata.Renderer(label_file, colors={"default": [math.nan, 0, 0, 1]}),
                 lambda: strata.Renderer(label_file).set_colors({"labels": {"3": [0, math.inf, 0, 1]}})):
        with pytest.raises(ValueError, match="colors: expected finite numbers") as e:
            call()
        assert "json.exception" not in str(e.value) and "last read" not in str(e.value)
    with pytest.raises(ValueError, match="tf: expected finite numbers"):
        strata.render(scalar_file, size=(8, 8), tf={"range": [0, math.nan], "points": []})
    with pytest.raises(TypeError, match=r"colors: expected JSON data"):
        strata.Renderer(label_file, colors={"default": {1, 2}})


def test_set_threads_refuses_negative_and_huge_counts():
    before = strata.threads()
    for bad in (-1, -100, 10 ** 6):
        with pytest.raises(ValueError, match="n: the thread count"):
            strata.set_threads(bad)
        assert strata.threads() == before
    strata.set_threads(1)
    assert strata.threads() == 1
    strata.set_threads(0)
    assert strata.threads() == before


def test_read_and_frame_ranks_follow_the_cli_rule(scalar_file, label_file):
    f = strata.open(scalar_file)
    with pytest.raises(strata.ParameterError, match=r"rank: expected 1\.\.16 \(the stored rank of .*scalar\.strata\)"):
        f.read(rank=17)
    with pytest.raises(strata.ParameterError, match="rank: expected 1..16"):
        strata.render(scalar_file, size=(8, 8), rank=17)
    with pytest.raises(strata.ParameterError, match="stores no Tucker rank"):
        strata.render(label_file, size=(8, 8), rank=2)
    assert strata.render(scalar_file, size=(8, 8), rank=16).shape == (8, 8, 4)

