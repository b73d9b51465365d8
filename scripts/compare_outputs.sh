#!/usr/bin/env bash
# Shows that two builds of `strata` write the same outputs: .strata files (scalar and label
# volumes), decoded volumes, query results and rendered images, byte for byte. Metadata fields
# that record timings (keys ending in "seconds") are the only bytes allowed to differ, with the
# checksums of the metadata and header that cover them.
#
#   scripts/compare_outputs.sh OLD_STRATA NEW_STRATA [WORK_DIR]
#
# Restructurings that must not change behaviour run it with the binary built before the change.
# Inputs: generated volumes, and the shared real volumes when ../shared/data has them.
set -euo pipefail
old=$(realpath "$1")
new=$(realpath "$2")
work=${3:-$(mktemp -d)}
here=$(cd "$(dirname "$0")/.." && pwd)
shared="$here/../shared/data"
mkdir -p "$work/in" "$work/old" "$work/new"

# Same-named outputs of every command, once per binary.
run_both() {  # run_both <command line with @OUT@ for the output dir>
  for side in old new; do
    local bin=${!side}
    eval "\"$bin\" --progress none ${1//@OUT@/$work/$side}" >/dev/null
  done
}

"$new" --progress none generate prisms --size 70,62,50 --seed 3 -o "$work/in/prisms.nrrd" >/dev/null
"$new" --progress none generate superpixels --size 48,40,36 --seed 4 -o "$work/in/sp.nrrd" >/dev/null
scalar_inputs=("$work/in/prisms.nrrd")
label_inputs=("$work/in/sp.nrrd")
[[ -f "$shared/vtkjs_headsq_mri.nrrd" ]] && scalar_inputs+=("$shared/vtkjs_headsq_mri.nrrd")
mricron=/usr/share/mricron/templates
[[ -f "$mricron/ch2better.nii.gz" ]] && scalar_inputs+=("$mricron/ch2better.nii.gz")
[[ -f "$shared/fibsem_medulla_250_ws.nrrd" ]] && label_inputs+=("$shared/fibsem_medulla_250_ws.nrrd")

for input in "${scalar_inputs[@]}"; do
  name=$(basename "$input" .nrrd)
  name=${name%.nii.gz}
  run_both "compress '$input' -o @OUT@/$name.strata --rank 12"
  run_both "compress '$input' -o @OUT@/$name.b12.strata --rank 16 --quant u16,b12log+ --brick 16"
  run_both "decompress @OUT@/$name.strata -o @OUT@/$name.decoded.nrrd"
  run_both "decompress @OUT@/$name.strata -o @OUT@/$name.decoded.nii"
  run_both "decompress @OUT@/$name.strata --level 1 --rank 6 -o @OUT@/$name.l1r6.nrrd"
  run_both "render @OUT@/$name.strata -o @OUT@/$name.png --size 160x120 --azimuth 30 --exact"
  run_both "render @OUT@/$name.strata -o @OUT@/$name.unshaded.png --size 160x120 --shading off --tf mri --exact"
  run_both "render '$input' -o @OUT@/$name.plain.png --size 160x120 --exact"
done
for input in "${label_inputs[@]}"; do
  name=$(basename "$input" .nrrd)
  run_both "labels encode '$input' -o @OUT@/$name.strata"
  run_both "labels decode @OUT@/$name.strata --level 1 -o @OUT@/$name.l1.nrrd"
  run_both "labels query @OUT@/$name.strata --box 3,5,7:30,33,29 --json > @OUT@/$name.query.json"
  run_both "labels query @OUT@/$name.strata --box 1,2,3:40,37,33 --method coarse --json > @OUT@/$name.coarse.json"
  run_both "render @OUT@/$name.strata -o @OUT@/$name.png --size 160x120 --exact"
done

# Compares two .strata files (or JSON reports) with timing keys and the reports' own file names
# removed.
compare_strata() {
  python3 - "$1" "$2" <<'EOF'
import json, struct, sys

def drop_timing(node):
    if isinstance(node, dict):
        return {k: drop_timing(v) for k, v in node.items() if not k.endswith('seconds') and k != 'file'}
    if isinstance(node, list):
        return [drop_timing(v) for v in node]
    return node

if sys.argv[1].endswith('.json'):
    if drop_timing(json.load(open(sys.argv[1]))) != drop_timing(json.load(open(sys.argv[2]))):
        sys.exit(f'{sys.argv[2]}: differs')
    sys.exit(0)

def parts(path):
    data = open(path, 'rb').read()
    index_offset, index_count, meta_offset, meta_size = struct.unpack_from('<QQQQ', data, 16)
    meta = json.loads(data[meta_offset:meta_offset + meta_size])
    index = data[index_offset:index_offset + 64 * index_count]
    return data[:12], data[64:meta_offset], index, drop_timing(meta)

a, b = parts(sys.argv[1]), parts(sys.argv[2])
for what, x, y in zip(('header', 'payloads', 'index', 'metadata'), a, b):
    if x != y:
        sys.exit(f'{sys.argv[2]}: {what} differs')
EOF
}

status=0
for f in "$work"/old/*; do
  name=$(basename "$f")
  g="$work/new/$name"
  if [[ "$name" == *.strata || "$name" == *.json ]]; then
    compare_strata "$f" "$g" || status=1
  elif ! cmp -s "$f" "$g"; then
    echo "$g: differs" >&2
    status=1
  fi
done
count=$(ls "$work/old" | wc -l)
if [[ $status == 0 ]]; then
  echo "identical: $count outputs in $work/{old,new}"
fi
exit $status
