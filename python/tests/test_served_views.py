"""The chunked views of `strata serve` read by the field's own client over HTTP: zarr-python
(with fsspec's HTTP store) opens /zarr/<name> of a running server, and every level equals what
`strata decompress -o x.ome.zarr` writes (scalars) or `strata labels decode --level L` decodes
(labels, exact). The Neuroglancer precomputed view is read with plain HTTP requests and its raw
chunk compared the same way."""

import json
import re
import subprocess
import urllib.error
import urllib.request

import numpy as np
import pytest

import strata

from conftest import cli_path

zarr = pytest.importorskip("zarr")
pytest.importorskip("aiohttp")  # fsspec's HTTP filesystem


@pytest.fixture(scope="module")
def server(scalar_file, label_file):
    """`strata serve` on both files, on a free port; yields its root URL."""
    process = subprocess.Popen([cli_path(), "serve", str(scalar_file), str(label_file), "--port", "0"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    root = None
    for line in process.stdout:
        match = re.search(r"Serving on (\S+)", line)
        if match:
            root = match.group(1).rstrip("/")
            break
    assert root, process.stderr.read()
    yield root
    process.terminate()
    process.wait(timeout=10)


def test_zarr_python_reads_every_level_of_a_scalar_file(server, scalar_file, cli, tmp_path):
    image = zarr.open(f"{server}/zarr/scalar", mode="r")
    multiscales = image.attrs["multiscales"][0]
    assert [d["path"] for d in multiscales["datasets"]] == [str(level) for level in range(len(multiscales["datasets"]))]
    cli("decompress", scalar_file, "-o", tmp_path / "local.ome.zarr")
    local = zarr.open(str(tmp_path / "local.ome.zarr"), mode="r")
    for dataset in multiscales["datasets"]:
        served = image[dataset["path"]][...]
        np.testing.assert_array_equal(served, local[dataset["path"]][...])
    # The finest level is what `decompress` gives: the decode at the stored rank in the source type.
    cli("decompress", scalar_file, "-o", tmp_path / "level0.nrrd")
    np.testing.assert_array_equal(image["0"][...], strata.read(tmp_path / "level0.nrrd"))


def test_zarr_python_reads_exact_labels_and_dominant_levels(server, label_file, label_raw, cli, tmp_path):
    image = zarr.open(f"{server}/zarr/labels", mode="r")
    levels = len(image.attrs["multiscales"][0]["datasets"])
    source = np.fromfile(label_raw, dtype=np.uint32).reshape(image["0"].shape)
    np.testing.assert_array_equal(image["0"][...], source)
    for level in range(1, levels):
        cli("labels", "decode", label_file, "--level", level, "-o", tmp_path / f"l{level}.nrrd")
        np.testing.assert_array_equal(image[str(level)][...], strata.read(tmp_path / f"l{level}.nrrd"))


def test_precomputed_info_and_a_chunk_over_http(server, label_raw):
    info = json.load(urllib.request.urlopen(f"{server}/precomputed/labels/info"))
    assert info["type"] == "segmentation" and info["data_type"] == "uint32"
    scale = info["scales"][0]
    x, y, z = scale["size"]
    assert scale["chunk_sizes"] == [[64, 64, 64]] and max(x, y, z) <= 64
    name = f"0-{x}_0-{y}_0-{z}"
    body = urllib.request.urlopen(f"{server}/precomputed/labels/{scale['key']}/{name}").read()
    assert len(body) > 0
    with pytest.raises(urllib.error.HTTPError) as outside:
        urllib.request.urlopen(f"{server}/precomputed/labels/{scale['key']}/0-{x + 1}_0-{y}_0-{z}")
    assert outside.value.code == 404
    image = json.load(urllib.request.urlopen(f"{server}/precomputed/scalar/info"))
    assert image["type"] == "image" and image["scales"][0]["encoding"] == "raw"


def test_convert_reads_its_own_served_ome_zarr_back(server, scalar_file, label_file, label_raw, cli, tmp_path):
    """`strata convert URL out` reads the served OME-Zarr over HTTP with its geometry: every level
    of the scalar file equals `decompress --level L` (in the source type), the labels' level 0
    their source ids."""
    levels = len(json.load(urllib.request.urlopen(f"{server}/zarr/scalar/.zattrs"))["multiscales"][0]["datasets"])
    assert levels >= 2
    for level in range(levels):
        cli("convert", f"{server}/zarr/scalar", tmp_path / f"served{level}.nrrd", "--level", level)
        cli("decompress", scalar_file, "--level", level, "-o", tmp_path / f"local{level}.nrrd")
        served, local = strata.read(tmp_path / f"served{level}.nrrd"), strata.read(tmp_path / f"local{level}.nrrd")
        # Coarser levels decompress to float; the views hold them in the source type, rounded.
        limits = np.iinfo(served.dtype)
        np.testing.assert_array_equal(served, np.clip(np.rint(local), limits.min, limits.max).astype(served.dtype))
    local_info = json.loads(cli("info", tmp_path / "local0.nrrd", "--json"))
    served_info = json.loads(cli("info", f"{server}/zarr/scalar", "--json"))
    assert served_info["format"] == "zarr"
    assert served_info["spacing"] == local_info["spacing"]
    cli("convert", f"{server}/zarr/labels/", tmp_path / "labels.nrrd")
    source = np.fromfile(label_raw, dtype=np.uint32)
    np.testing.assert_array_equal(strata.read(tmp_path / "labels.nrrd").ravel(), source)


def test_convert_names_the_url_when_the_served_image_is_missing(server, cli, tmp_path):
    error = cli("convert", f"{server}/zarr/no-such-dataset", tmp_path / "x.nrrd", expect_error=True)
    assert f"{server}/zarr/no-such-dataset" in error
    assert "Traceback" not in error and "terminate" not in error
