"""Strata: compressed multiresolution 3D volumes from Python.

Volumes are numpy arrays of shape (z, y, x): C order over Strata's x-fastest samples, so a
volume file's bytes and the array's memory are the same. Shapes, spacings and boxes given as
slices or pairs follow that (z, y, x) order; only the CLI's box text "x0,y0,z0:x1,y1,z1" keeps
the command line's x-first order. See docs/python.md.

    import strata
    vol = strata.read("ct.nrrd")                      # numpy (z, y, x), the file's dtype
    strata.compress(vol, "ct.strata", rank=16)        # the CLI's defaults otherwise
    f = strata.open("ct.strata")
    roi = f[10:50, :, 100:200]                        # decodes only the bricks it touches
    img = strata.render(f, size=(512, 512), azimuth=45)
"""

from . import labels
from ._strata import (
    Error,
    FormatError,
    LabelFile,
    ParameterError,
    Renderer,
    ScalarFile,
    codecs,
    compress,
    generate,
    info,
    open,
    read,
    set_threads,
    threads,
    write,
)

__all__ = [
    "Error", "FormatError", "ParameterError", "ScalarFile", "LabelFile", "Renderer",
    "read", "write", "info", "generate", "codecs", "compress", "open", "render", "labels",
    "threads", "set_threads",
]


def render(source, *, volume=None, background=(0.0, 0.0, 0.0), cache_bytes=None, max_bricks=None, colors=None,
           **frame):
    """One frame of `source` (a path, or a file from strata.open) as a (height, width, 4) uint8
    RGBA array, as `strata render` draws it.

    The keyword arguments of Renderer.frame (size=(width, height), azimuth, elevation, distance,
    fov, ortho, tf, rank, lod, feature_scale, step, shading, lighting, lod_bias) choose the view;
    volume, background, cache_bytes, max_bricks and colors are Renderer's. For several frames of
    one volume, keep a Renderer: it caches the decoded bricks between frames.
    """
    session = {"volume": volume, "background": background, "colors": colors}
    if cache_bytes is not None:
        session["cache_bytes"] = cache_bytes
    if max_bricks is not None:
        session["max_bricks"] = max_bricks
    with Renderer(source, **session) as renderer:
        return renderer.frame(**frame)
