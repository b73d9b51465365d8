#!/usr/bin/env bash
# Fig. 7-style table of paper 1: SNR for each --quant setting and reconstruction rank K, plus
# bits per voxel, on the sample volumes. Prints a Markdown table (used in docs/benchmarks.md).
#   bench/quant_table.sh [strata-binary]
set -euo pipefail
STRATA=${1:-./build/release/strata}
DATA=$(cd "$(dirname "$0")/../.." && pwd)/shared/data
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

volumes=(/usr/share/mricron/templates/ch2better.nii.gz "$DATA/fibsem_medulla_250.nrrd" "$DATA/vtkjs_lidc2_ct.nrrd")
schemes=(f32 u16,b16lin u16,b12log+ u16,b8log+ u16,b8log u16,b8mu+ u8,b8lin)

echo "| volume | quant | bits/voxel | SNR K=16 | K=12 | K=8 | K=4 |"
echo "| --- | --- | --- | --- | --- | --- | --- |"
for v in "${volumes[@]}"; do
  [ -f "$v" ] || continue
  for q in "${schemes[@]}"; do
    out="$WORK/out.strata"
    "$STRATA" --progress none compress "$v" -o "$out" --quant "$q" > /dev/null
    row="| $(basename "$v") | $q |"
    first=1
    for k in 16 12 8 4; do
      json=$("$STRATA" --progress none eval "$v" "$out" --rank "$k" --json)
      if [ $first = 1 ]; then
        row="$row $(python3 -c 'import json,sys; print("%.3f" % json.load(sys.stdin)["storage"]["bits_per_voxel"])' <<< "$json") |"
        first=0
      fi
      row="$row $(python3 -c 'import json,sys; print("%.2f" % json.load(sys.stdin)["error"]["snr_db"])' <<< "$json") |"
    done
    echo "$row"
  done
done
