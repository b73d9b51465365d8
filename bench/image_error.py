#!/usr/bin/env python3
"""Image error of rendered frames against reference frames (bench/vtk_equal_error.sh).

    image_error.py REFERENCE_DIR TEST_DIR      -> one JSON object on stdout

Both folders hold frame_NNNN.png (strata render --orbit, vtk_raycast --frames-dir). Frames are
compared as 8-bit RGB (an alpha channel is dropped: both renderers composite over the same
opaque background). PSNR = 10 log10(255^2 / MSE), MSE over every pixel and channel of every
frame together; SNR = 10 log10(mean square of the reference / MSE), the error relative to the
reference's own signal, which two renderers of different brightness can be compared by; max_abs is the largest difference of one channel of one pixel (0..255);
p999_abs the 99.9th percentile of the per-pixel largest channel difference, which a few
pixels on a silhouette cannot move as they move max_abs.
Needs python3-numpy and python3-pil (./setup.sh --bench).
"""
import json
import math
import pathlib
import sys

import numpy as np
from PIL import Image


def frames(folder):
    paths = sorted(pathlib.Path(folder).glob("frame_*.png"))
    if not paths:
        sys.exit(f"image_error.py: {folder}: no frame_NNNN.png files")
    return paths


def load_rgb(path):
    return np.asarray(Image.open(path).convert("RGB"), dtype=np.float64)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: image_error.py REFERENCE_DIR TEST_DIR")
    reference, test = frames(sys.argv[1]), frames(sys.argv[2])
    if [p.name for p in reference] != [p.name for p in test]:
        sys.exit(f"image_error.py: {sys.argv[1]} and {sys.argv[2]} hold different frames")
    squared, signal, count, worst, per_frame, pixel_diffs = 0.0, 0.0, 0, 0.0, [], []
    for r_path, t_path in zip(reference, test):
        r, t = load_rgb(r_path), load_rgb(t_path)
        if r.shape != t.shape:
            sys.exit(f"image_error.py: {t_path}: {t.shape[1]}x{t.shape[0]} pixels, reference has "
                     f"{r.shape[1]}x{r.shape[0]}")
        d = t - r
        mse = float(np.mean(d * d))
        squared += mse * d.size
        signal += float(np.sum(r * r))
        count += d.size
        worst = max(worst, float(np.max(np.abs(d))))
        pixel_diffs.append(np.max(np.abs(d), axis=2).ravel())
        per_frame.append({"frame": r_path.name, "psnr": psnr(mse)})
    mse = squared / count
    snr = math.inf if mse == 0 else 10 * math.log10(signal / count / mse)
    print(json.dumps({"psnr": psnr(mse), "snr": snr, "rmse": math.sqrt(mse), "max_abs": worst,
                      "p999_abs": float(np.percentile(np.concatenate(pixel_diffs), 99.9)),
                      "frames": per_frame}))


def psnr(mse):
    return math.inf if mse == 0 else 10 * math.log10(255.0 ** 2 / mse)


if __name__ == "__main__":
    main()
