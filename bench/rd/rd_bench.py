#!/usr/bin/python3
"""Rate-distortion benchmark: Strata's scalar codec against zfp 1.0 (opt-in; ./setup.sh --bench).

For every volume it runs
  * Strata fixed-rank mode (`strata compress --rank K`, other options at their defaults),
  * Strata target modes (`--psnr`, `--rmse`, `--max-error`), each only if `strata compress --help`
    lists it (otherwise a notice is printed and the mode is skipped),
  * zfp fixed accuracy (`-a tol`) and fixed rate (`-r bits`) on the volume as raw float32,
and records per point: bits per voxel of the whole file (and, for Strata, of level 0's payloads
alone), SNR, PSNR over the source value range, RMSE, max abs error, and compression and
decompression speeds (Mvox/s, process wall time, `--repeats` runs alternating over all points).

Error metrics follow src/core/metrics.cpp: e = x - y in double with x the source sample and y the
decoded float; SNR = 20 log10(rms(x) / rmse), PSNR = 20 log10((max x - min x) / rmse).
Strata's figures come from `strata eval --json` (level 0 at the stored rank); zfp's from the
decompressed raw, with numpy.

Usage: bench/rd/rd_bench.py [--strata build/release/strata] [--out build/rd] [--volumes a,b]
Writes OUT/rd.json, OUT/<volume>.png, and prints the summary tables (Markdown).
"""
import argparse
import json
import math
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
MRICRON = Path("/usr/share/mricron/templates")

# name -> source file (relative to --data unless absolute); generated fields have no file.
VOLUMES = {
    "ch2better": MRICRON / "ch2better.nii.gz",
    "vtkjs_lidc2_ct": "vtkjs_lidc2_ct.nrrd",
    "fibsem_medulla_250": "fibsem_medulla_250.nrrd",
    "vtkjs_headsq_mri": "vtkjs_headsq_mri.nrrd",
    "vtk_ironprot": "vtk_ironprot.nrrd",
    "marschner-lobb": None,
    "prisms": None,
}

RANKS = [2, 4, 8, 12, 16, 24]
PSNR_TARGETS = [28, 30, 35, 40, 45, 50, 55]  # a budget lands 0.1-0.3 dB above: 28 brackets 30
RMSE_FRACTIONS = [1e-2, 3e-3, 1e-3]          # --rmse = fraction x value range (PSNR 40, 50.5, 60)
MAX_ERROR_FRACTIONS = [1 / 16, 1 / 64, 1 / 256, 1 / 1024]  # --max-error = fraction x value range
ZFP_TOLERANCE_FRACTIONS = [2.0 ** -k for k in range(-3, 9)]  # -a = fraction x value range: 8 ... 1/256
ZFP_RATES = [0.25, 0.5, 1, 1.5, 2, 3, 4, 6, 8]
TABLE_PSNRS = [30, 40, 50]

DTYPES = {"u8": np.uint8, "i8": np.int8, "u16": np.uint16, "i16": np.int16, "u32": np.uint32,
          "i32": np.int32, "f32": np.float32, "f64": np.float64}


# ---------------------------------------------------------------------------------------------
# Processes and the machine


def run(cmd, **kw):
    """Runs a command, returns (stdout, wall seconds); raises with its stderr on failure."""
    t = time.perf_counter()
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kw)
    seconds = time.perf_counter() - t
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))}: exit {p.returncode}: {p.stderr.strip()}")
    return p.stdout, seconds


def machine_load():
    out = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    return {"uptime": out, "loadavg": [float(x) for x in Path("/proc/loadavg").read_text().split()[:3]]}


def strata_cmd(args, *rest):
    return [args.strata, "--threads", args.threads, "--progress", "none", *rest]


def strata_target_flags(args):
    """The target-mode flags `strata compress --help` lists (of --psnr, --rmse, --max-error)."""
    help_text, _ = run(strata_cmd(args, "compress", "--help"))
    return [f for f in ("--psnr", "--rmse", "--max-error") if re.search(rf"(^|[\s,]){f}(?![\w-])", help_text, re.M)]


# ---------------------------------------------------------------------------------------------
# Volumes


def read_raw(path):
    """A raw file with its Strata JSON sidecar -> (numpy array z,y,x, sidecar)."""
    meta = json.loads(Path(str(path) + ".json").read_text())
    x, y, z = meta["dims"]
    return np.fromfile(path, dtype=DTYPES[meta["dtype"]]).reshape(z, y, x), meta


def prepare_volume(args, name, work):
    """Brings one volume to WORK/<name>.raw (source sample type) and .f32 (zfp's input)."""
    raw = work / f"{name}.raw"
    src = VOLUMES[name]
    if src is None:
        run(strata_cmd(args, "generate", name, "--size", args.gen_size, "-o", raw))
    else:
        src = Path(src) if Path(src).is_absolute() else Path(args.data) / src
        if not src.exists():
            return None
        run(strata_cmd(args, "convert", src, raw))
    data, meta = read_raw(raw)
    f32 = work / f"{name}.f32"
    data.astype(np.float32).tofile(f32)
    lo, hi = float(data.min()), float(data.max())
    return {"name": name, "source": str(src) if src else f"strata generate {name} --size {args.gen_size}",
            "raw": raw, "f32": f32, "dims": meta["dims"], "dtype": meta["dtype"],
            "voxels": int(data.size), "range": [lo, hi], "data": data}


# ---------------------------------------------------------------------------------------------
# Metrics (the definitions of src/core/metrics.cpp)


def error_metrics(original, decoded):
    x = original.astype(np.float64).ravel()
    e = x - decoded.astype(np.float64).ravel()
    rmse = math.sqrt(float(np.dot(e, e)) / x.size)
    signal_rms = math.sqrt(float(np.dot(x, x)) / x.size)
    value_range = float(x.max() - x.min())
    inf = float("inf")
    return {"snr_db": 20 * math.log10(signal_rms / rmse) if rmse > 0 else inf,
            "psnr_db": (20 * math.log10(value_range / rmse) if value_range > 0 else -inf) if rmse > 0 else inf,
            "rmse": rmse, "max_abs_error": float(np.abs(e).max())}


def bits_per_voxel(nbytes, voxels):
    return 8.0 * nbytes / voxels


# ---------------------------------------------------------------------------------------------
# Coders: one compression + decompression each, returning the point's figures and a timing job


def strata_point(args, vol, work, coder, flags):
    """Compresses with `strata compress FLAGS`, evaluates level 0 with `strata eval --json`."""
    out = work / f"{vol['name']}.strata"
    dec = work / f"{vol['name']}.strata.f32.raw"
    compress = strata_cmd(args, "compress", vol["raw"], "-o", out, *flags)
    decompress = strata_cmd(args, "decompress", out, "--float", "-o", dec)
    run(compress)
    report = json.loads(run(strata_cmd(args, "eval", vol["raw"], out, "--json"))[0])
    s, e = report["storage"], report["error"]
    level0 = s["levels"][0]
    point = {"coder": coder, "flags": [str(f) for f in flags],
             "bpv": s["bits_per_voxel"],
             "bpv_level0": level0["bits_per_voxel"] if "bits_per_voxel" in level0 else None,
             "snr_db": e["snr_db"], "psnr_db": e["psnr_db"], "rmse": e["rmse"],
             "max_abs_error": e["max_abs_error"], "rank": e["rank"],
             "eval_decode_mvox_s": report["decode_mvox_per_s"]}
    # The float decode through `decompress` must give eval's figures (same metric definitions).
    run(decompress)
    check = error_metrics(vol["data"], read_raw(dec)[0])
    point["psnr_check_db"] = check["psnr_db"] - point["psnr_db"]
    if abs(point["psnr_check_db"]) > 1e-3:
        print(f"  warning: {coder} {flags}: numpy PSNR differs from eval by {point['psnr_check_db']:.4g} dB")
    return point, (compress, decompress)


def zfp_point(args, vol, work, coder, flags):
    """zfp on the float32 raw: -h stores the header so the stream decodes on its own."""
    nx, ny, nz = vol["dims"]
    out = work / f"{vol['name']}.zfp"
    dec = work / f"{vol['name']}.zfp.f32"
    compress = ["zfp", "-q", "-h", "-f", "-3", nx, ny, nz, *flags, "-i", vol["f32"], "-z", out]
    # OpenMP compression (same stream as serial) for fixed accuracy; Debian's zfp 1.0.0 CLI aborts
    # in free() after writing a fixed-rate stream with -x omp, so fixed rate runs serially.
    # zfp 1.0 decompresses serially only.
    threads = args.threads if coder == "zfp-accuracy" else 1
    if threads > 1:
        compress += ["-x", f"omp={threads}"]
    decompress = ["zfp", "-q", "-h", "-z", out, "-o", dec]
    run(compress)
    run(decompress)
    decoded = np.fromfile(dec, dtype=np.float32)
    point = {"coder": coder, "flags": [str(f) for f in flags],
             "bpv": bits_per_voxel(out.stat().st_size, vol["voxels"]), "bpv_level0": None,
             "compress_threads": threads,
             **error_metrics(vol["data"], decoded)}
    return point, (compress, decompress)


def sweep(args, vol, work, target_flags):
    """Every point of every coder for one volume: [(point, (compress cmd, decompress cmd))]."""
    span = vol["range"][1] - vol["range"][0]
    runs = []
    for k in RANKS:
        runs.append(strata_point(args, vol, work, "strata-rank", ["--rank", k]))
    targets = {"--psnr": ("strata-psnr", PSNR_TARGETS),
               "--rmse": ("strata-rmse", [f * span for f in RMSE_FRACTIONS]),
               "--max-error": ("strata-max-error", [f * span for f in MAX_ERROR_FRACTIONS])}
    for flag, (coder, values) in targets.items():
        if flag not in target_flags:
            continue
        for v in values:
            try:
                runs.append(strata_point(args, vol, work, coder, [flag, f"{v:.6g}"]))
            except RuntimeError as err:
                print(f"  notice: {coder} {flag} {v:.6g} failed, point skipped: {err}")
    for f in ZFP_TOLERANCE_FRACTIONS:
        runs.append(zfp_point(args, vol, work, "zfp-accuracy", ["-a", f"{f * span:.6g}"]))
    for r in ZFP_RATES:
        runs.append(zfp_point(args, vol, work, "zfp-rate", ["-r", r]))
    return runs


def time_points(args, vol, runs):
    """Compression and decompression speed of every point, --repeats rounds over all points in
    turn (so a load spike hits every coder alike); Mvox/s of process wall time."""
    for point, _ in runs:
        point["compress_mvox_s"], point["decompress_mvox_s"] = [], []
    for _ in range(args.repeats):
        for point, (compress, decompress) in runs:
            for key, cmd in (("compress_mvox_s", compress), ("decompress_mvox_s", decompress)):
                seconds = run(cmd)[1]
                point[key].append(vol["voxels"] / seconds / 1e6)


# ---------------------------------------------------------------------------------------------
# Summary


def curve(points, coder, rate_key="bpv"):
    pts = sorted((p[rate_key], p["psnr_db"]) for p in points if p["coder"] == coder and p.get(rate_key) is not None)
    return [p for p in pts if math.isfinite(p[1])]


def bpv_at_psnr(pts, target):
    """Bits per voxel at which a curve (sorted by rate) first reaches `target` dB, by linear
    interpolation between its neighbouring points; None outside the measured range."""
    for (r0, q0), (r1, q1) in zip(pts, pts[1:]):
        if q0 <= target <= q1 and q1 > q0:
            return r0 + (r1 - r0) * (target - q0) / (q1 - q0)
        if q0 == target:
            return r0
    if pts and pts[-1][1] == target:
        return pts[-1][0]
    return None


def summary_rows(volumes):
    rows = []
    for vol in volumes:
        pts = vol["points"]
        for target in TABLE_PSNRS:
            row = {"volume": vol["name"], "psnr_db": target}
            for key, coder, rate_key in (("strata_rank", "strata-rank", "bpv"),
                                         ("strata_rank_level0", "strata-rank", "bpv_level0"),
                                         ("strata_target", "strata-psnr", "bpv"),
                                         ("zfp_accuracy", "zfp-accuracy", "bpv"),
                                         ("zfp_rate", "zfp-rate", "bpv")):
                row[key] = bpv_at_psnr(curve(pts, coder, rate_key), target)
            for key, num in (("target_over_zfp", "strata_target"), ("rank_over_zfp", "strata_rank")):
                a, b = row[num], row["zfp_accuracy"]
                row[key] = a / b if a is not None and b else None
            rows.append(row)
    return rows


def speed_rows(volumes):
    """Per volume and coder: the speeds of the point closest to 40 dB PSNR (min-max of the runs)."""
    rows = []
    for vol in volumes:
        for coder in dict.fromkeys(p["coder"] for p in vol["points"]):
            pts = [p for p in vol["points"] if p["coder"] == coder and p.get("compress_mvox_s")]
            if not pts:
                continue
            p = min(pts, key=lambda p: abs(p["psnr_db"] - 40))
            rows.append({"volume": vol["name"], "coder": coder, "flags": " ".join(p["flags"]),
                         "bpv": p["bpv"], "psnr_db": p["psnr_db"],
                         "compress_mvox_s": [min(p["compress_mvox_s"]), max(p["compress_mvox_s"])],
                         "decompress_mvox_s": [min(p["decompress_mvox_s"]), max(p["decompress_mvox_s"])]})
    return rows


def fmt(v, spec=".3f"):
    return "—" if v is None else format(v, spec)


def print_tables(result):
    print(f"\nload at start: {result['load_start']['uptime']}\nload at end:   {result['load_end']['uptime']}")
    print(f"strata: {result['strata']}; target modes: {', '.join(result['strata_target_flags']) or 'none'}; "
          f"run time {result['run_seconds']:.0f} s\n")
    print("Bits per voxel needed for a PSNR (linear interpolation on each curve; — = outside the measured range)\n")
    print("| volume | PSNR dB | Strata rank (file) | Strata rank (level 0) | Strata target (file) | zfp accuracy "
          "| zfp rate | rank / zfp-acc | target / zfp-acc |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in result["summary"]:
        print(f"| {r['volume']} | {r['psnr_db']} | {fmt(r['strata_rank'])} | {fmt(r['strata_rank_level0'])} | "
              f"{fmt(r['strata_target'])} | {fmt(r['zfp_accuracy'])} | {fmt(r['zfp_rate'])} | "
              f"{fmt(r['rank_over_zfp'], '.2f')} | {fmt(r['target_over_zfp'], '.2f')} |")
    print(f"\nSpeeds at the point nearest 40 dB (Mvox/s of process wall time, min–max of {result['repeats']} runs)\n")
    print("| volume | coder | setting | bits/voxel | PSNR dB | compress | decompress |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in result["speeds"]:
        c, d = r["compress_mvox_s"], r["decompress_mvox_s"]
        print(f"| {r['volume']} | {r['coder']} | {r['flags']} | {r['bpv']:.3f} | {r['psnr_db']:.2f} | "
              f"{c[0]:.1f}–{c[1]:.1f} | {d[0]:.1f}–{d[1]:.1f} |")


# ---------------------------------------------------------------------------------------------
# Plots


STYLE = {"strata-rank": ("tab:blue", "o"), "strata-psnr": ("tab:green", "s"), "strata-rmse": ("tab:olive", "v"),
         "strata-max-error": ("tab:purple", "^"), "zfp-accuracy": ("tab:red", "D"), "zfp-rate": ("tab:orange", "x")}


def plot_volume(vol, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter

    fig, (ax_psnr, ax_max) = plt.subplots(1, 2, figsize=(11, 4.2), dpi=90)
    for coder, (colour, marker) in STYLE.items():
        pts = sorted((p for p in vol["points"] if p["coder"] == coder), key=lambda p: p["bpv"])
        if not pts:
            continue
        bpv = [p["bpv"] for p in pts]
        ax_psnr.plot(bpv, [p["psnr_db"] for p in pts], marker=marker, color=colour, ms=4, label=coder)
        ax_max.plot(bpv, [p["max_abs_error"] for p in pts], marker=marker, color=colour, ms=4, label=coder)
        if pts[0]["bpv_level0"] is not None:
            ax_psnr.plot([p["bpv_level0"] for p in pts], [p["psnr_db"] for p in pts], ls="--", color=colour,
                         lw=1, label=f"{coder} (level 0 only)")
    for ax in (ax_psnr, ax_max):
        ax.set_xscale("log", base=2)
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.set_xlabel("bits per voxel")
        ax.grid(True, which="both", alpha=0.3)
    ax_psnr.set_ylabel("PSNR (dB, over the source value range)")
    ax_max.set_ylabel("max abs error")
    ax_max.set_yscale("log")
    ax_psnr.legend(fontsize=7, loc="lower right")
    lo, hi = vol["range"]
    fig.suptitle(f"{vol['name']}  {'x'.join(map(str, vol['dims']))} {vol['dtype']}, range [{lo:g}, {hi:g}]",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


# ---------------------------------------------------------------------------------------------


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--strata", default=str(REPO / "build/release/strata"), help="strata binary")
    p.add_argument("--out", default=str(REPO / "build/rd"), help="output folder (rd.json, PNGs)")
    p.add_argument("--data", default=str(REPO.parent / "shared/data"), help="sample volumes folder")
    p.add_argument("--volumes", default=",".join(VOLUMES), help="comma-separated subset of: " + ", ".join(VOLUMES))
    p.add_argument("--gen-size", default=160, type=int, help="edge of the generated fields (default 160)")
    p.add_argument("--threads", default=2, type=int, help="threads for strata and zfp compression")
    p.add_argument("--repeats", default=3, type=int, help="timing runs per point")
    args = p.parse_args()
    args.strata = str(Path(args.strata).resolve())
    return args


def main():
    args = parse_args()
    if shutil.which("zfp") is None:
        sys.exit("zfp not found: run ./setup.sh --bench")
    out = Path(args.out)
    work = out / "work"
    work.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    result = {"strata": args.strata, "threads": args.threads, "repeats": args.repeats,
              "load_start": machine_load(), "volumes": []}
    print(f"load at start: {result['load_start']['uptime']}")
    target_flags = strata_target_flags(args)
    result["strata_target_flags"] = target_flags
    for flag in ("--psnr", "--rmse", "--max-error"):
        if flag not in target_flags:
            print(f"notice: `strata compress --help` lists no {flag}: that target mode is skipped")
    for name in args.volumes.split(","):
        vol = prepare_volume(args, name, work)
        if vol is None:
            print(f"notice: {name}: source file missing, skipped")
            continue
        print(f"{name}: {'x'.join(map(str, vol['dims']))} {vol['dtype']}, range {vol['range']}", flush=True)
        runs = sweep(args, vol, work, target_flags)
        time_points(args, vol, runs)
        vol["points"] = [p for p, _ in runs]
        plot_volume(vol, out / f"{name}.png")
        result["volumes"].append({k: v for k, v in vol.items() if k not in ("data", "raw", "f32")})
        for suffix in (".raw", ".raw.json", ".f32", ".strata", ".strata.f32.raw", ".strata.f32.raw.json", ".zfp",
                       ".zfp.f32"):
            (work / f"{name}{suffix}").unlink(missing_ok=True)
    result["load_end"] = machine_load()
    result["run_seconds"] = time.perf_counter() - t0
    result["summary"] = summary_rows(result["volumes"])
    result["speeds"] = speed_rows(result["volumes"])
    (out / "rd.json").write_text(json.dumps(result, indent=1))
    print_tables(result)
    print(f"\nwrote {out / 'rd.json'} and {len(result['volumes'])} PNGs in {out}")


if __name__ == "__main__":
    main()
