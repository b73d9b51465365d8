#!/usr/bin/env bash
# Tables 2 and 3 of the Mixture Graph paper, measured with `strata labels encode --json` on the
# sample label volumes, the mricron atlases and a generated fibres volume, and the calibration of
# box-query sigmas (`strata labels calibrate`: 30 random boxes each of 64^3 and 128^3, hybrid
# against exact counts). Every encoded file is decoded at level 0 and compared with its input
# (must be bit-exact). Prints Markdown tables.
#   bench/label_tables.sh [strata-binary] [table2|table3|sigma|all]
# Environment: STRATA_THREADS (default 2), FIBRES_SIZE (default 512), FIBRES_COUNT (default 10000).
set -euo pipefail
STRATA=$(realpath "${1:-./build/release/strata}")
WHICH=${2:-all}
THREADS=${STRATA_THREADS:-2}
DATA=$(cd "$(dirname "$0")/../.." && pwd)/shared/data
ATLAS=/usr/share/mricron/templates
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

strata() { "$STRATA" --threads "$THREADS" --progress none "$@"; }

# Encodes $1 with the remaining arguments, checks level 0 decodes bit-exactly, prints the JSON.
encode_checked() {
  local input=$1
  shift
  local out="$WORK/labels.strata"
  local json
  json=$(strata labels encode "$input" -o "$out" --json "$@")
  strata labels decode "$out" --level 0 -o "$WORK/level0.nrrd" > /dev/null
  local max_error
  max_error=$(strata compare "$input" "$WORK/level0.nrrd" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["max_abs_error"])')
  if [ "$max_error" != "0.0" ]; then
    echo "level 0 of $input is not bit-exact (max error $max_error)" >&2
    exit 1
  fi
  echo "$json"
}

table2_row() {
  local name=$1 input=$2
  encode_checked "$input" | python3 -c '
import json, sys
r = json.load(sys.stdin)
r.update(name=sys.argv[1], dims="x".join(str(d) for d in r["dims"]), bg=100 * r["background_fraction"],
         raw=r["raw_histogram_bytes"] / 2**20, mib=r["file_bytes"] / 2**20, bins=2 ** r["bits"])
print("| {name} | {dims} | {mip_voxels:,} | {mip_levels} | {sources:,} | {bg:.1f} | {nnz_per_voxel:.3f} | "
      "{raw:.1f} MiB | {input_pairs:,} | {nodes:,} | {mib:.2f} MiB | {bits_per_voxel:.3f} | {bins} | "
      "{max_l1_error:.5f} | {depth} | {seconds:.2f} s |".format(**r))
' "$name"
}

table2() {
  local fibres="$WORK/fibres.nrrd"
  strata generate fibres --size "${FIBRES_SIZE:-512}" --count "${FIBRES_COUNT:-10000}" --seed 1 -o "$fibres" > /dev/null
  echo "| volume | resolution | voxels (all levels) | mip levels | segments | background % | non-zeros/voxel | raw histogram | input pairs | nodes | file | bits/voxel | bins | max l1 | depth | encode |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
  table2_row fibsem_medulla_250_gt "$DATA/fibsem_medulla_250_gt.nrrd"
  table2_row fibsem_medulla_250_ws "$DATA/fibsem_medulla_250_ws.nrrd"
  table2_row vtk_frog_tissue "$DATA/vtk_frog_tissue.nrrd"
  table2_row gala_fibsem_test_gt "$DATA/gala_fibsem_test_gt.nrrd"
  table2_row aal "$ATLAS/aal.nii.gz"
  table2_row inia19-NeuroMaps "$ATLAS/inia19-NeuroMaps.nii.gz"
  table2_row "fibres (generated, ${FIBRES_COUNT:-10000} ids)" "$fibres"
}

table3() {
  local input="$DATA/fibsem_medulla_250_ws.nrrd"
  echo "| strategy | bits | nodes | file | bits/voxel | max l1 | encode |"
  echo "| --- | --- | --- | --- | --- | --- | --- |"
  for strategy in max-reduction max-occurrence; do
    for bits in 4 5 6 7 8 9; do
      encode_checked "$input" --bits "$bits" --strategy "$strategy" | python3 -c '
import json, sys
r = json.load(sys.stdin)
r.update(mib=r["file_bytes"] / 2**20)
print("| {strategy} | {bits} | {nodes:,} | {mib:.2f} MiB | {bits_per_voxel:.3f} | {max_l1_error:.5f} | "
      "{seconds:.2f} s |".format(**r))
'
    done
  done
}

sigma_row() {
  local name=$1 input=$2
  encode_checked "$input" > /dev/null
  strata labels calibrate "$WORK/labels.strata" --sizes 64,128 --boxes 30 --json | python3 -c '
import json, sys
r = json.load(sys.stdin)
w = r["worst"]
print("| {} | {:,} | {:.2f}% | {:.2f}% | {:.3f}% | {:.3f}% | {} | {:.3g} |".format(
    sys.argv[1], r["pairs"], 100 * r["outside_1_sigma"], 100 * r["outside_2_sigma"], 100 * r["outside_3_sigma"],
    100 * r["outside_6_sigma"], w["z"] if isinstance(w["z"], str) else "{:.2f}".format(w["z"]), r["mean_abs_error"]))
' "$name"
}

sigma() {
  local generated="$WORK/generated.nrrd"
  echo "| volume | label/box pairs | > 1σ | > 2σ | > 3σ | > 6σ | worst \|error\|/σ | mean \|error\| (voxels) |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- |"
  for v in fibsem_medulla_250_gt fibsem_medulla_250_ws fibsem_medulla_250_sp vtk_frog_tissue gala_fibsem_test_gt; do
    sigma_row "$v" "$DATA/$v.nrrd"
  done
  sigma_row aal "$ATLAS/aal.nii.gz"
  sigma_row inia19-NeuroMaps "$ATLAS/inia19-NeuroMaps.nii.gz"
  for kind in "fibres 256 4000" "voronoi 256 2000" "superpixels 256 200"; do
    set -- $kind
    strata generate "$1" --size "$2" --count "$3" --seed 1 -o "$generated" > /dev/null
    sigma_row "$1 $2³ (generated, count $3)" "$generated"
  done
}

case "$WHICH" in
  table2) table2 ;;
  table3) table3 ;;
  sigma) sigma ;;
  all) table2; echo; table3; echo; sigma ;;
  *) echo "usage: $0 [strata-binary] [table2|table3|sigma|all]" >&2; exit 2 ;;
esac
