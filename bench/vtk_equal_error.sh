#!/usr/bin/env bash
# Strata against VTK's CPU ray caster at equal image error (docs/benchmarks.md, "At equal image
# error"). Opt-in, never run in CI: needs libvtk9-dev, xvfb, xauth (the VTK side) and
# python3-numpy, python3-pil (image errors; ./setup.sh --bench).
#   bench/vtk_equal_error.sh [volumes...]     default: vtkjs_lidc2_ct ch2better vtk_ironprot
# (the shared CT with a thin metal stent, the 0.5 mm MRI, an electron-density field; also
# prisms<N>, generated, and vtkjs_headsq_mri)
#
# Per volume and per view of a VIEWS-frame orbit (azimuth 30° + 360°/VIEWS per frame, elevation
# 20°, 1024×768, both renderers at the distance strata's default framing picks):
#  1. references at step REF_STEP (1/16 voxel): strata on the uncompressed volume, and VTK on it;
#  2. VTK at its step 0.5; strata on each compressed file (one per COMPRESS entry) at every
#     STEPS × LODS setting; strata on the uncompressed volume at step 0.5;
#  3. each image set's error against its renderer's own reference (strata's: uncompressed, full
#     rank): SNR (error relative to the reference image's signal: the two renderers' images
#     differ in brightness, so absolute errors would favour the darker one), PSNR, max and
#     99.9th-percentile per-pixel difference; and VTK's PSNR against strata's reference;
#  4. the cheapest strata setting (CPU s per view after the first) whose SNR is at least VTK's,
#     then CPU seconds per frame of a FRAMES-frame orbit (first frame included: reading and
#     reconstruction for strata, gradients for VTK) of it, of strata's defaults and of VTK at
#     0.5, alternated REPEATS times, with the load average before each round.
# Environment: VIEWS (4), REF_STEP (0.0625), STEPS ("0.5 0.75 1 1.5"), LODS ("1 2"),
# COMPRESS ("default;--psnr 50;none": `compress` options per file, ';'-separated; "none" renders
# the uncompressed volume itself; the first entry is "strata defaults" in the timing table),
# FRAMES (24), REPEATS (3), IMAGE (1024x768), THREADS (2), BUILD (build/vtk; configured with
# the VTK benchmark on), KEEP (a folder to keep the frames in; default: a temporary one),
# PYTHON (/usr/bin/python3: Debian's, which has the packages above).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${BUILD:-$ROOT/build/vtk}
VIEWS=${VIEWS:-4}
REF_STEP=${REF_STEP:-0.0625}
STEPS=${STEPS:-0.5 0.75 1 1.5}
COMPRESS=${COMPRESS:-default;--psnr 50;none}
LODS=${LODS:-1 2}
FRAMES=${FRAMES:-24}
REPEATS=${REPEATS:-3}
IMAGE=${IMAGE:-1024x768}
THREADS=${THREADS:-2}
VOLUMES=("${@:-vtkjs_lidc2_ct ch2better vtk_ironprot}")
WORK=${KEEP:-$(mktemp -d)}
[ -n "${KEEP:-}" ] || trap 'rm -rf "$WORK"' EXIT
mkdir -p "$WORK"

if [ -z "${STRATA_BIN:-}" ]; then
  cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DSTRATA_BUILD_VTK_BENCH=ON > /dev/null
  cmake --build "$BUILD" --target strata vtk_raycast > /dev/null
fi
STRATA=("${STRATA_BIN:-$BUILD/strata}" --progress none --threads "$THREADS")
VTK=${VTK_BIN:-$BUILD/bench/vtk/vtk_raycast}
ERROR="$ROOT/bench/image_error.py"
PYTHON=${PYTHON:-/usr/bin/python3}
DATA=${DATA:-$ROOT/../shared/data}

json() { "$PYTHON" -c "import json,sys; d=json.load(open(sys.argv[1])); print(eval(sys.argv[2], {'d': d}))" "$1" "$2"; }
after_first_vtk() { json "$1" "'%.3f' % (sum(f['cpu_s'] for f in d['per_frame'][1:]) / (len(d['per_frame']) - 1))"; }
after_first() { json "$1" "'%.3f' % d['summary']['after_first']['cpu_s_per_frame']"; }
bits_per_voxel() { "$PYTHON" -c "import os,sys; print(f'{8 * os.path.getsize(sys.argv[1]) / int(sys.argv[2]):.3f}')" "$1" "$2"; }
load() { cut -d' ' -f1 /proc/loadavg; }

# The volume file and its transfer function.
source_of() {
  case "$1" in
    prisms*) echo "$WORK/$1.nrrd ct" ;;
    ch2better) echo "/usr/share/mricron/templates/ch2better.nii.gz mri" ;;
    vtkjs_lidc2_ct) echo "$DATA/$1.nrrd ct" ;;                          # CT with a thin metal stent
    vtkjs_headsq_mri) echo "$DATA/$1.nrrd mri" ;;
    vtk_ironprot) echo "$DATA/$1.nrrd grayscale" ;;                     # electron density
    *) echo "unknown volume $1 (prisms<N>, ch2better, vtkjs_lidc2_ct, vtkjs_headsq_mri, vtk_ironprot)" >&2
       exit 2 ;;
  esac
}

# strata_frames NAME INPUT STEP LOD FRAMES [extra...]: frames into $dir/NAME, stats NAME.json.
strata_frames() {
  local name=$1 input=$2 step=$3 lod=$4 frames=$5
  shift 5
  rm -rf "$dir/$name"
  "${STRATA[@]}" render "$input" -o "$dir/$name" --orbit "$frames" --size "$IMAGE" --tf "$tf" --step "$step" \
    --lod "$lod" --exact --shading on --distance "$distance" --stats "$dir/$name.json" "$@" > /dev/null
}
vtk_frames() {
  local name=$1 step=$2 frames=$3
  rm -rf "$dir/$name" && mkdir -p "$dir/$name"
  xvfb-run -a "$VTK" "$raw" --orbit "$frames" --threads "$THREADS" --size "$IMAGE" --tf "$tf" --step "$step" \
    --shading on --distance "$distance" --frames-dir "$dir/$name" > "$dir/$name.json"
}

for volume in ${VOLUMES[*]}; do
  read -r raw tf < <(source_of "$volume")
  dir="$WORK/$volume"
  mkdir -p "$dir"
  [[ $volume == prisms* ]] && "${STRATA[@]}" generate prisms --size "${volume#prisms}" -o "$raw" > /dev/null
  IFS=';' read -r -a variants <<< "$COMPRESS"
  files=()
  for i in "${!variants[@]}"; do
    opts=${variants[$i]}
    files[i]=$dir/c$i.strata
    if [ "$opts" = none ]; then files[i]=$raw; continue; fi  # the uncompressed volume
    [ "$opts" = default ] && opts=""
    # shellcheck disable=SC2086  # the options are separate words
    "${STRATA[@]}" compress "$raw" -o "${files[i]}" $opts > /dev/null
  done
  voxels=$("${STRATA[@]}" info "$raw" --json | "$PYTHON" -c "import json,sys; d=json.load(sys.stdin)['dims']; print(d[0]*d[1]*d[2])")
  # The distance strata's default framing picks (same aspect ratio at any size).
  "${STRATA[@]}" render "$raw" -o "$dir/fit.png" --size 64x48 --tf "$tf" --stats "$dir/fit.json" > /dev/null
  distance=$(json "$dir/fit.json" "d['frames'][0]['distance']")

  echo "## $volume ($raw, tf $tf, distance $distance, $VIEWS views, reference step $REF_STEP, load $(load))"
  strata_frames ref "$raw" "$REF_STEP" 1 "$VIEWS"
  vtk_frames vtk_ref "$REF_STEP" "$VIEWS"
  vtk_frames vtk 0.5 "$VIEWS"
  strata_frames plain "$raw" 0.5 1 "$VIEWS"
  candidates=()
  for i in "${!variants[@]}"; do
    for step in $STEPS; do
      for lod in $LODS; do
        strata_frames "c${i}_s${step}_l${lod}" "${files[i]}" "$step" "$lod" "$VIEWS"
        candidates+=("c${i}_s${step}_l${lod}")
      done
    done
  done

  echo
  echo "| images | data (bits/voxel) | SNR (dB) | PSNR (dB) | max / p99.9 diff | CPU s/view (after the first) |"
  echo "| --- | --- | --- | --- | --- | --- |"
  row() {  # row LABEL NAME REFERENCE DATA CPU
    "$PYTHON" "$ERROR" "$dir/$3" "$dir/$2" > "$dir/$2.err.json"
    echo "| $1 | $4 | $(json "$dir/$2.err.json" "'%.2f | %.2f | %.0f / %.0f' % (d['snr'], d['psnr'], d['max_abs'], d['p999_abs'])") | $5 |"
  }
  row "VTK, step 0.5" vtk vtk_ref raw "$(after_first_vtk "$dir/vtk.json")"
  row "strata, step 0.5" plain ref raw "$(after_first "$dir/plain.json")"
  for c in "${candidates[@]}"; do
    i=${c%%_*}; i=${i#c}; rest=${c#*_s}
    row "strata, step ${rest%_l*}, --lod ${rest##*_l}" "$c" ref \
      "${variants[$i]} ($(bits_per_voxel "${files[i]}" "$voxels"))" "$(after_first "$dir/$c.json")"
  done
  "$PYTHON" "$ERROR" "$dir/ref" "$dir/vtk" > "$dir/vtk.cross.json"
  echo
  echo "References: strata $(after_first "$dir/ref.json"), VTK $(after_first_vtk "$dir/vtk_ref.json") CPU s per view." \
    "VTK's step-0.5 images against strata's reference: PSNR $(json "$dir/vtk.cross.json" "round(d['psnr'], 2)") dB."

  # The cheapest candidate whose SNR is at least VTK's.
  best=$("$PYTHON" - "$dir" "${candidates[@]}" <<'EOF'
import json, sys
d = sys.argv[1]
snr = lambda name: json.load(open(f"{d}/{name}.err.json"))["snr"]
ok = [(json.load(open(f"{d}/{c}.json"))["summary"]["after_first"]["cpu_s_per_frame"], c)
      for c in sys.argv[2:] if snr(c) >= snr("vtk")]
print(min(ok)[1] if ok else "")
EOF
)
  echo
  if [ -z "$best" ]; then
    echo "No strata setting reaches VTK's image error on $volume."
    continue
  fi
  i=${best%%_*}; i=${i#c}; rest=${best#*_s}; step=${rest%_l*}; lod=${rest##*_l}
  echo "Cheapest strata setting at VTK's SNR or better: ${variants[$i]}, step $step, --lod $lod." \
    "CPU s per frame of a $FRAMES-frame orbit (first frame included):"
  echo
  echo "| round | load before | strata, chosen | strata defaults | VTK step 0.5 | ratio chosen / VTK | ratio defaults / VTK |"
  echo "| --- | --- | --- | --- | --- | --- | --- |"
  for r in $(seq 1 "$REPEATS"); do
    l=$(load)
    strata_frames time_best "${files[i]}" "$step" "$lod" "$FRAMES"
    strata_frames time_default "${files[0]}" 0.5 1 "$FRAMES"
    vtk_frames time_vtk 0.5 "$FRAMES"
    s=$(json "$dir/time_best.json" "d['summary']['cpu_s_per_frame']")
    s0=$(json "$dir/time_default.json" "d['summary']['cpu_s_per_frame']")
    v=$(json "$dir/time_vtk.json" "d['cpu_s_per_frame']")
    "$PYTHON" -c "import sys; r,l,s,s0,v=sys.argv[1:]; s,s0,v=float(s),float(s0),float(v); print(f'| {r} | {l} | {s:.3f} | {s0:.3f} | {v:.3f} | {s/v:.2f} | {s0/v:.2f} |')" \
      "$r" "$l" "$s" "$s0" "$v"
  done
  echo
done
