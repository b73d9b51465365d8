"""numpy-style indexing of strata files: f[z0:z1, y0:y1, x0:x1], f[5], f[..., ::2], f.level(2)[...].

A key becomes the smallest box that holds every index it selects; that box is decoded by the
file's read() (only the bricks it touches), and steps, reversed slices and integer indices are
then applied to the decoded box, so the result is what the same key gives on the decoded volume
as a numpy array.
"""

import numpy as np


def _axis_range(item, n, axis):
    """The indices `item` (an int or a slice) selects on an axis of length n, and whether the
    axis is kept (a slice) or dropped (an int)."""
    if isinstance(item, slice):
        return range(*item.indices(n)), True
    if isinstance(item, (bool, np.bool_)):
        raise TypeError("strata files take integers, slices and ... as indices, not booleans")
    try:
        i = item.__index__()
    except AttributeError:
        raise TypeError(f"strata files take integers, slices and ... as indices, got {type(item).__name__}") from None
    if not -n <= i < n:
        raise IndexError(f"index {i} is out of bounds for axis {axis} with size {n}")
    return range(i % n, i % n + 1), False


def _expand(key):
    """The key as a tuple of three items, `...` and missing trailing axes filled with slices."""
    if not isinstance(key, tuple):
        key = (key,)
    if sum(k is Ellipsis for k in key) > 1:
        raise IndexError("an index can only have a single ellipsis ('...')")
    if any(k is Ellipsis for k in key):
        at = next(i for i, k in enumerate(key) if k is Ellipsis)
        key = key[:at] + (slice(None),) * (3 - (len(key) - 1)) + key[at + 1:]
    if len(key) > 3:
        raise IndexError(f"too many indices: a volume has 3 axes (z, y, x), got {len(key)}")
    return key + (slice(None),) * (3 - len(key))


def getitem(file, key, level=0, **read_args):
    """file[key] at `level`: decodes the bounding box of the key's indices, then indexes it."""
    shape = file.level_shape(level)
    ranges, kept = zip(*(_axis_range(item, n, axis) for axis, (item, n) in enumerate(zip(_expand(key), shape))))
    if any(len(r) == 0 for r in ranges):
        dtype = file.read_dtype(level, read_args.get("as_float", False))
        return np.empty([len(r) for r, keep in zip(ranges, kept) if keep], dtype=dtype)
    box = tuple(slice(min(r[0], r[-1]), max(r[0], r[-1]) + 1) for r in ranges)
    block = file.read(box, level=level, **read_args)
    local = []
    for r, b, keep in zip(ranges, box, kept):
        start = r[0] - b.start
        if not keep:
            local.append(start)
        else:
            stop = start + len(r) * r.step
            local.append(slice(start, stop if stop >= 0 else None, r.step))
    out = block[tuple(local)]
    # A strided or reversed view would keep the whole decoded box alive: return a compact array.
    return np.ascontiguousarray(out) if out.base is not None and out.size < block.size else out


class LevelView:
    """One level of a strata file (file.level(l)): indexing and read() at that level."""

    def __init__(self, file, level):
        self._file = file
        self.level = level

    @property
    def shape(self):
        return self._file.level_shape(self.level)

    @property
    def dtype(self):
        return self._file.read_dtype(self.level)

    def read(self, box=None, **read_args):
        return self._file.read(box, level=self.level, **read_args)

    def __getitem__(self, key):
        return getitem(self._file, key, self.level)

    def __repr__(self):
        return f"<level {self.level} of {self._file!r}, shape={self.shape}>"
