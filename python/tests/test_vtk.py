"""VTK image data against independent writers and readers. No VTK library is installed (Debian's
python3-vtk9 pulls in Qt and MPI, hundreds of MB), so the .vti files are written here the way
vtkXMLImageDataWriter lays them out, with numpy, base64 and zlib, and Strata's .vti output is
decoded the same way; Debian's python3-meshio reads Strata's legacy .vtk output."""

import base64
import struct
import zlib

import numpy as np
import pytest

import strata

meshio = pytest.importorskip("meshio")

TYPES = {np.uint8: "UInt8", np.int8: "Int8", np.uint16: "UInt16", np.int16: "Int16", np.uint32: "UInt32",
         np.int32: "Int32", np.float32: "Float32", np.float64: "Float64", np.uint64: "UInt64", np.int64: "Int64"}


def sample(dtype, shape=(4, 5, 6)):
    values = np.arange(np.prod(shape)).reshape(shape) * 7 - 50
    if np.dtype(dtype).kind == "u":
        values = values + 50
    if np.dtype(dtype).itemsize == 1:
        values = values % 100
    return values.astype(dtype)


def vti_text(array, data_array, appended=b"", order="LittleEndian", header="UInt32", compressor=None):
    z, y, x = array.shape
    extent = f"0 {x - 1} 0 {y - 1} 0 {z - 1}"
    comp = f' compressor="{compressor}"' if compressor else ""
    head = (f'<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order="{order}" '
            f'header_type="{header}"{comp}>\n'
            f'<ImageData WholeExtent="{extent}" Origin="1 2 3" Spacing="0.5 1.25 2" Direction="1 0 0 0 1 0 0 0 1">\n'
            f'<Piece Extent="{extent}"><PointData Scalars="v">{data_array}</PointData></Piece>\n</ImageData>\n')
    return head.encode() + appended + b"</VTKFile>\n"


def header_words(values, header, order):
    return struct.pack(("<" if order == "LittleEndian" else ">") + ("I" if header == "UInt32" else "Q") * len(values),
                       *values)


def zlib_payload(raw, header, order, block=37):
    blocks = [zlib.compress(raw[i:i + block]) for i in range(0, len(raw), block)]
    table = header_words([len(blocks), block, len(raw) % block] + [len(b) for b in blocks], header, order)
    return table, b"".join(blocks)


@pytest.mark.parametrize("dtype", list(TYPES))
@pytest.mark.parametrize("encoding", ["ascii", "binary", "raw", "base64", "zlib-binary", "zlib-raw"])
def test_reads_vti_written_as_vtk_does(tmp_path, dtype, encoding):
    a = sample(dtype)
    order = "BigEndian" if encoding in ("raw", "zlib-binary") else "LittleEndian"
    header = "UInt64" if encoding in ("base64", "zlib-raw") else "UInt32"
    raw = a.astype(np.dtype(dtype).newbyteorder("<" if order == "LittleEndian" else ">")).tobytes()
    kind = TYPES[dtype]
    compressor = "vtkZLibDataCompressor" if encoding.startswith("zlib") else None
    appended = b""
    if encoding == "ascii":
        element = f'<DataArray type="{kind}" Name="v" format="ascii">{" ".join(map(str, a.ravel().tolist()))}</DataArray>'
    elif encoding == "binary":
        text = base64.b64encode(header_words([len(raw)], header, order) + raw).decode()
        element = f'<DataArray type="{kind}" Name="v" format="binary">{text}</DataArray>'
    elif encoding == "zlib-binary":
        table, blocks = zlib_payload(raw, header, order)
        text = base64.b64encode(table).decode() + base64.b64encode(blocks).decode()
        element = f'<DataArray type="{kind}" Name="v" format="binary">{text}</DataArray>'
    else:
        element = f'<DataArray type="{kind}" Name="v" format="appended" offset="0"/>'
        if encoding == "zlib-raw":
            table, blocks = zlib_payload(raw, header, order)
            payload = table + blocks
        else:
            payload = header_words([len(raw)], header, order) + raw
        if encoding == "base64":
            appended = b'<AppendedData encoding="base64">_' + base64.b64encode(payload) + b"</AppendedData>\n"
        else:
            appended = b'<AppendedData encoding="raw">_' + payload + b"</AppendedData>\n"
    path = tmp_path / "in.vti"
    path.write_bytes(vti_text(a, element, appended, order, header, compressor))
    b = strata.read(path)
    assert b.dtype == a.dtype and b.shape == a.shape
    np.testing.assert_array_equal(a, b)
    assert strata.info(path)["spacing"] == pytest.approx((2.0, 1.25, 0.5))  # (z, y, x)


def decode_vti(path):
    """Our .vti output decoded independently: the XML up to AppendedData, then the array."""
    data = path.read_bytes()
    marker = data.index(b"<AppendedData")
    start = data.index(b"_", marker) + 1
    xml = data[:marker].decode()
    kind = xml.split('DataArray type="')[1].split('"')[0]
    dtype = {v: k for k, v in TYPES.items()}[kind]
    extent = [int(v) for v in xml.split('WholeExtent="')[1].split('"')[0].split()]
    shape = (extent[5] + 1, extent[3] + 1, extent[1] + 1)
    assert 'header_type="UInt64"' in xml and 'byte_order="LittleEndian"' in xml
    if "vtkZLibDataCompressor" in xml:
        count, block, last = struct.unpack_from("<3Q", data, start)
        sizes = struct.unpack_from(f"<{count}Q", data, start + 24)
        at = start + 24 + 8 * count
        raw = b""
        for size in sizes:
            raw += zlib.decompress(data[at:at + size])
            at += size
        assert len(raw) == (count - 1) * block + (last or block)
    else:
        (nbytes,) = struct.unpack_from("<Q", data, start)
        raw = data[start + 8:start + 8 + nbytes]
    assert data.rstrip().endswith(b"</VTKFile>")
    spacing = [float(v) for v in xml.split('Spacing="')[1].split('"')[0].split()]
    return np.frombuffer(raw, dtype=dtype).reshape(shape), spacing


@pytest.mark.parametrize("dtype", list(TYPES))
@pytest.mark.parametrize("compress", [True, False])
def test_vti_written_by_strata_decodes_as_vtk_reads_it(tmp_path, dtype, compress):
    a = sample(dtype, shape=(30, 40, 50))
    path = tmp_path / "out.vti"
    strata.write(path, a, spacing=(3.0, 2.0, 0.5), compress=compress)
    b, spacing = decode_vti(path)
    np.testing.assert_array_equal(a, b)
    assert spacing == [0.5, 2.0, 3.0]
    np.testing.assert_array_equal(strata.read(path), a)


@pytest.mark.parametrize("dtype", [np.uint8, np.int8, np.uint16, np.int16, np.uint32, np.int32, np.float32, np.float64])
def test_meshio_reads_legacy_vtk_written_by_strata(tmp_path, dtype):
    a = sample(dtype)
    path = tmp_path / "out.vtk"
    strata.write(path, a, spacing=(3.0, 2.0, 0.5))
    mesh = meshio.read(path)
    values = next(iter(mesh.point_data.values()))
    np.testing.assert_array_equal(values.ravel(), a.ravel())  # x fastest, as VTK orders points
    z, y, x = a.shape
    assert mesh.points[1] == pytest.approx((0.5, 0, 0))
    assert mesh.points[x] == pytest.approx((0, 2.0, 0))
    assert mesh.points[-1] == pytest.approx(((x - 1) * 0.5, (y - 1) * 2.0, (z - 1) * 3.0))
    np.testing.assert_array_equal(strata.read(path), a)
