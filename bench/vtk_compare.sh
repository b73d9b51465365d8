#!/usr/bin/env bash
# Strata's CPU ray caster against VTK's (vtkFixedPointVolumeRayCastMapper): the same volumes,
# image size, transfer function, sample distance, shading and 24-frame orbit on 2 threads.
# Reports CPU seconds per frame for both and their ratio, plus Strata's LOD orbit frame rate.
# Opt-in, never run in CI: needs libvtk9-dev and xvfb (apt-get install libvtk9-dev xvfb xauth).
#   bench/vtk_compare.sh [sizes...]          default sizes: 256 512
# Environment: FRAMES (24), IMAGE (1024x768), TF (ct), STEP (0.5), THREADS (2), TARGET_FPS (10).
# The LOD orbit is progressive with --target-fps; its frame rate excludes the first (loading) frame,
# its decode share includes it.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$ROOT/build/vtk
FRAMES=${FRAMES:-24}
IMAGE=${IMAGE:-1024x768}
TF=${TF:-ct}
STEP=${STEP:-0.5}
THREADS=${THREADS:-2}
SIZES=("${@:-256 512}")
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DSTRATA_BUILD_TESTS=OFF -DSTRATA_BUILD_BENCH=OFF \
  -DSTRATA_BUILD_VTK_BENCH=ON > /dev/null
cmake --build "$BUILD" --target strata vtk_raycast > /dev/null
STRATA="$BUILD/strata"
VTK="$BUILD/bench/vtk/vtk_raycast"

field() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))$2)" "$1"; }

echo "| volume | Strata CPU s/frame (--lod 1 --exact) | VTK CPU s/frame | ratio | Strata LOD orbit frames/s (--target-fps) | decode share of the LOD orbit |"
echo "| --- | --- | --- | --- | --- | --- |"
for size in ${SIZES[*]}; do
  raw="$WORK/prisms$size.nrrd"
  "$STRATA" --progress none generate prisms --size "$size" -o "$raw" > /dev/null
  "$STRATA" --progress none --threads "$THREADS" compress "$raw" -o "$WORK/v.strata" > /dev/null
  common=(--size "$IMAGE" --tf "$TF" --step "$STEP" --shading on)
  "$STRATA" --progress none --threads "$THREADS" render "$WORK/v.strata" -o "$WORK/exact" --orbit "$FRAMES" \
    --lod 1 --exact "${common[@]}" --stats "$WORK/exact.json" > /dev/null
  "$STRATA" --progress none --threads "$THREADS" render "$WORK/v.strata" -o "$WORK/lod" --orbit "$FRAMES" \
    "${common[@]}" --target-fps "${TARGET_FPS:-10}" --stats "$WORK/lod.json" > /dev/null
  xvfb-run -a "$VTK" "$raw" --orbit "$FRAMES" --threads "$THREADS" "${common[@]}" > "$WORK/vtk.json"
  s=$(field "$WORK/exact.json" '["summary"]["cpu_s_per_frame"]')
  v=$(field "$WORK/vtk.json" '["cpu_s_per_frame"]')
  fps=$(field "$WORK/lod.json" '["summary"]["after_first"]["frames_per_s"]')
  share=$(field "$WORK/lod.json" '["summary"]["decode_share"]')
  python3 -c "import sys; s,v,f,d=map(float,sys.argv[2:]); print(f'| prisms {sys.argv[1]}^3 | {s:.3f} | {v:.3f} | {s/v:.2f} | {f:.1f} | {100*d:.1f}% |')" \
    "$size" "$s" "$v" "$fps" "$share"
done
