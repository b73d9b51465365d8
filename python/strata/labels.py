"""Label (segmentation) volumes as Mixture Graphs: strata.labels.encode writes one; strata.open
returns a LabelFile for it (decoding, box queries, label fractions, palettes)."""

from ._strata import labels as _labels

encode = _labels.encode

__all__ = ["encode"]
