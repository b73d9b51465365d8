#!/usr/bin/env python3
"""Request-to-image latency of `strata serve`, driven over loopback the way the browser client does.

Starts `strata serve` on a free port with a scalar `.strata` file and a label `.strata` file,
then measures, each as median / p95 / max over repeated requests (standard library only):

- slice: `GET slice` across x, y and z at level 0, `--slice-step` slices apart (one request in
  flight, as a slice view scrolls); reported per axis size;
- coarse: `GET render?quality=coarse` JPEG frames of w x h while the azimuth moves 3 degrees
  per frame (one request in flight, as a dragging client keeps it);
- settle: after each coarse drag, the `quality=exact` PNG of the camera where the drag stopped
  (the time the client waits for the sharp frame);
- rank: an exact frame after a rank change (bytes read must stay 0: models are cached);
- palette: `POST palette` on the label dataset with a new colour for some labels (the server's
  own `palette_ms` and the whole request).

Writes JSON (--out) with the figures, the machine's load before and after, and the commands.
Example (after `./setup.sh`):

    build/release/strata compress /usr/share/mricron/templates/ch2better.nii.gz -o /tmp/ch2.strata
    build/release/strata labels encode /usr/share/mricron/templates/aal.nii.gz -o /tmp/aal.strata
    python3 bench/viewer/viewer_latency.py --strata build/release/strata \\
        --scalar /tmp/ch2.strata --labels /tmp/aal.strata --out build/viewer_latency.json
"""
import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request


def machine_load():
    with open("/proc/loadavg") as f:
        one, five, fifteen = f.read().split()[:3]
    return {"load1": float(one), "load5": float(five), "load15": float(fifteen), "cpus": os.cpu_count()}


def summarize(ms):
    ms = sorted(ms)
    p95 = ms[min(len(ms) - 1, int(round(0.95 * (len(ms) - 1))))]
    return {"n": len(ms), "median_ms": round(statistics.median(ms), 2), "p95_ms": round(p95, 2),
            "max_ms": round(ms[-1], 2), "min_ms": round(ms[0], 2)}


class Server:
    """`strata serve` on a free loopback port; the address is read from its output."""

    def __init__(self, strata, files, cache_mb):
        self.proc = subprocess.Popen([strata, "serve", *files, "--port", "0", "--cache-mb", str(cache_mb)],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.base = None
        lines = []
        deadline = time.time() + 120
        while time.time() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                break
            lines.append(line)
            m = re.search(r"Serving on (http://[0-9.]+:[0-9]+)", line)
            if m:
                self.base = m.group(1)
                break
        if self.base is None:
            self.stop()
            sys.exit("strata serve printed no address:\n" + "".join(lines))
        # Keep draining its output so the pipe never fills.
        threading.Thread(target=lambda: [None for _ in self.proc.stdout], daemon=True).start()

    def stop(self):
        self.proc.terminate()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()


def request(base, path, body=None):
    """(ms, status, headers, body bytes)."""
    data = json.dumps(body).encode() if body is not None else None
    req = urllib.request.Request(base + path, data=data, method="POST" if data else "GET",
                                 headers={"Content-Type": "application/json"} if data else {})
    t0 = time.perf_counter()
    try:
        with urllib.request.urlopen(req, timeout=60) as r:
            payload = r.read()
            status, headers = r.status, dict(r.headers)
    except urllib.error.HTTPError as e:
        payload, status, headers = e.read(), e.code, dict(e.headers)
    ms = (time.perf_counter() - t0) * 1000
    if status != 200:
        sys.exit(f"{path}: HTTP {status}: {payload[:300]!r}")
    return ms, status, headers, payload


def find_datasets(base, scalar_name, labels_name):
    _, _, _, body = request(base, "/api/datasets")
    sets = json.loads(body)
    by_name = {d["name"]: d for d in sets}
    return by_name[scalar_name], by_name[labels_name]


def bench_slices(base, ds, repeats, step):
    out = {}
    dims = ds["dims"]
    for axis, a in (("z", 2), ("y", 1), ("x", 0)):
        n = dims[a]
        times = []
        for i in range(repeats):
            index = (n // 4 + step * i) % n  # scrolling through the volume, not one cached slice
            ms, _, headers, _ = request(base, f"/api/datasets/{ds['id']}/slice?axis={axis}&index={index}&level=0")
            times.append(ms)
        w, h = headers.get("X-Strata-Dims", "?,?").split(",")
        out[axis] = {"image": f"{w}x{h}", "step": step, **summarize(times)}
    return out


def stats_of(headers):
    return json.loads(headers.get("X-Strata-Stats", "{}"))


def bench_frames(base, ds, args):
    """Drags of `frames_per_drag` coarse frames, each followed by the exact frame where it stops."""
    coarse, settle, coarse_scale = [], [], []
    seq = 0
    az = 30.0
    size = f"w={args.width}&h={args.height}"
    for drag in range(args.drags):
        for _ in range(args.frames_per_drag):
            az += 3.0
            seq += 1
            ms, _, headers, _ = request(base, f"/api/datasets/{ds['id']}/render?{size}&az={az}&el=20"
                                              f"&quality=coarse&client=bench&seq={seq}")
            coarse.append(ms)
            coarse_scale.append(stats_of(headers).get("image_scale", 0))
        seq += 1
        ms, _, headers, _ = request(base, f"/api/datasets/{ds['id']}/render?{size}&az={az}&el=20"
                                          f"&quality=exact&client=bench&seq={seq}")
        settle.append(ms)
    return {"coarse": {**summarize(coarse), "fps_median": round(1000 / statistics.median(coarse), 1),
                       "image_scale_median": statistics.median(coarse_scale)},
            "settle": summarize(settle)}


def bench_rank(base, ds, args):
    """Exact frames at one camera while the rank slider moves: no bytes may be read."""
    rank = ds.get("rank", 0)
    if rank < 2:
        return None
    size = f"w={args.width}&h={args.height}"
    request(base, f"/api/datasets/{ds['id']}/render?{size}&az=0&el=20&quality=exact&rank={rank}")
    times, read = [], 0
    for k in [max(1, rank // 2), max(1, rank // 4), rank, max(1, rank // 2)]:
        ms, _, headers, _ = request(base, f"/api/datasets/{ds['id']}/render?{size}&az=0&el=20&quality=exact&rank={k}")
        times.append(ms)
        read += stats_of(headers).get("load", {}).get("bytes_read", 0)
    return {**summarize(times), "bytes_read": read}


def bench_palette(base, ds, repeats):
    label_hi = int(ds["value_range"][1])
    request_ms, server_ms = [], []
    for i in range(repeats):
        colors = {str(l): "#%02x%02x%02x" % ((37 * (l + i)) % 256, (91 * l) % 256, (53 * i) % 256)
                  for l in range(1, min(label_hi, 40) + 1)}
        ms, _, _, body = request(base, f"/api/datasets/{ds['id']}/palette", {"colors": colors})
        request_ms.append(ms)
        server_ms.append(json.loads(body)["palette_ms"])
    return {"request": summarize(request_ms), "server": summarize(server_ms)}


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--strata", required=True, help="strata binary")
    p.add_argument("--scalar", required=True, help="scalar .strata file")
    p.add_argument("--labels", required=True, help="label .strata file")
    p.add_argument("--out", required=True, help="JSON output")
    p.add_argument("--width", type=int, default=1024)
    p.add_argument("--height", type=int, default=768)
    p.add_argument("--drags", type=int, default=8, help="camera drags, each ending in an exact frame")
    p.add_argument("--frames-per-drag", type=int, default=15)
    p.add_argument("--slices", type=int, default=60, help="slice requests per axis")
    p.add_argument("--slice-step", type=int, default=7,
                   help="slices scrolled per request (7: a new 28-voxel brick layer every fourth request)")
    p.add_argument("--palettes", type=int, default=40)
    p.add_argument("--cache-mb", type=int, default=1024)
    args = p.parse_args()

    result = {"command": " ".join(sys.argv), "load_start": machine_load()}
    server = Server(args.strata, [args.scalar, args.labels], args.cache_mb)
    try:
        scalar, labels = find_datasets(server.base, os.path.basename(args.scalar), os.path.basename(args.labels))
        result["scalar"] = {"name": scalar["name"], "dims": scalar["dims"], "rank": scalar.get("rank")}
        result["labels"] = {"name": labels["name"], "dims": labels["dims"], "label_count": labels.get("label_count")}
        t0 = time.perf_counter()
        # The first exact frame loads the whole cut: reported apart (a cold start).
        ms, _, headers, _ = request(server.base, f"/api/datasets/{scalar['id']}/render?w={args.width}&h={args.height}"
                                                 f"&quality=exact")
        result["first_exact_frame_ms"] = round(ms, 1)
        result["frames"] = bench_frames(server.base, scalar, args)
        result["rank_change_exact"] = bench_rank(server.base, scalar, args)
        result["slices_scalar"] = bench_slices(server.base, scalar, args.slices, args.slice_step)
        result["slices_labels"] = bench_slices(server.base, labels, args.slices, args.slice_step)
        result["palette"] = bench_palette(server.base, labels, args.palettes)
        result["run_seconds"] = round(time.perf_counter() - t0, 1)
    finally:
        server.stop()
    result["load_end"] = machine_load()
    with open(args.out, "w") as f:
        json.dump(result, f, indent=2)
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
