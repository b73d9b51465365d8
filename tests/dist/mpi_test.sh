#!/usr/bin/env bash
# `strata-mpi compress` and `strata-mpi labels encode` end to end (CTest label `mpi`,
# tests/CMakeLists.txt): one case per run.
#   mpi_test.sh CASE STRATA STRATA_MPI MPIEXEC WORKDIR
# Identity cases run `strata compress` (or `strata labels encode`) and `mpirun -np N
# --oversubscribe strata-mpi ...` with the same flags on a generated volume and require the same
# file: byte-identical for compress; for labels the same sections (bytes, by CRC) and metadata,
# the factorisation's timing aside. Error cases require the exit code, a message naming the
# file/flag and no output left behind.
set -euo pipefail
case_name=$1 strata=$2 strata_mpi=$3 mpiexec=$4 work=$5
rm -rf "$work"
mkdir -p "$work"
cd "$work"

fail() { echo "FAIL: $*" >&2; exit 1; }

generate() {  # KIND SIZE [more flags]
  local kind=$1 size=$2
  shift 2
  "$strata" --progress none generate "$kind" --size "$size" "$@" -o in.nrrd >/dev/null
}

# NP FLAGS...: the single-process file and the distributed one must be the same bytes.
identical() {
  local np=$1
  shift
  "$strata" --progress none compress in.nrrd -o single.strata "$@" >single.log
  "$mpiexec" -np "$np" --oversubscribe "$strata_mpi" compress in.nrrd -o "dist$np.strata" "$@" >"dist$np.log" 2>&1 ||
    { cat "dist$np.log" >&2; fail "strata-mpi with $np ranks failed"; }
  cmp single.strata "dist$np.strata" || fail "$np ranks: not byte-identical to strata compress ($*)"
  grep -q "^rank $((np - 1)):" "dist$np.log" || { cat "dist$np.log" >&2; fail "no report of rank $((np - 1))"; }
  echo "ok: $np ranks, $* -> $(stat -c %s single.strata) bytes, identical"
}

# FILE: what `strata info --json` says of a label file (its sections' offsets, sizes and CRCs,
# its metadata), without its name, the factorisation's timing and the sizes that timing's
# digits change.
label_file_summary() {
  "$strata" info --json "$1" |
    grep -v -e '"file":' -e '"factor_seconds":' -e '"metadata_bytes":' -e '"file_bytes":' -e '"bits_per_voxel":'
}

# NP FLAGS...: the distributed label file must equal the single-process one (timing aside).
same_labels() {
  local np=$1
  shift
  "$strata" --progress none labels encode in.nrrd -o single.strata "$@" >single.log
  "$mpiexec" -np "$np" --oversubscribe "$strata_mpi" --progress none labels encode in.nrrd -o "dist$np.strata" "$@" \
    >"dist$np.log" 2>&1 || { cat "dist$np.log" >&2; fail "strata-mpi labels encode with $np ranks failed"; }
  diff <(label_file_summary single.strata) <(label_file_summary "dist$np.strata") >&2 ||
    fail "$np ranks: not the file of strata labels encode ($*)"
  grep -q "^rank $((np - 1)): slices" "dist$np.log" || { cat "dist$np.log" >&2; fail "no report of rank $((np - 1))"; }
  echo "ok: $np ranks, labels $* -> $(stat -c %s single.strata) bytes, same sections and metadata"
}

# EXPECTED_CODE PATTERN NP ARGS...: strata-mpi fails with the code, says PATTERN, leaves no output.
fails() {
  local code=$1 pattern=$2 np=$3
  shift 3
  local status=0
  timeout 60 "$mpiexec" -np "$np" --oversubscribe "$strata_mpi" "$@" >out.log 2>err.log || status=$?
  [ "$status" -eq "$code" ] || { cat out.log err.log >&2; fail "exit $status, expected $code"; }
  grep -q -- "$pattern" err.log || { cat err.log >&2; fail "no message matching '$pattern'"; }
  [ "$(grep -c '^error:' err.log)" -eq 1 ] || { cat err.log >&2; fail "expected one error line (one rank reports)"; }
  ! ls out.strata* >/dev/null 2>&1 || fail "output left behind: $(ls out.strata*)"
  echo "ok: exit $code, $(head -1 err.log)"
}

case "$case_name" in
  fixed)  # default flags; 8 level-0 brick rows: 3 ranks split them 2/3/3, coarse levels leave ranks idle
    generate prisms 80,72,200
    for np in 1 2 3; do identical "$np"; done
    ;;
  odd-core)  # core 13 (odd): ranges start at even rows; other quantization, no zstd, HOSVD only
    generate prisms 80,72,200 --seed 3
    for np in 2 3; do identical "$np" --brick 17 --overlap 2 --rank 8 --quant u8,b8lin --zstd 0 --hooi 0; done
    ;;
  float)  # f32 samples, small input slabs (--memory-limit), more ranks than some levels have rows
    generate marschner-lobb 64,60,90 --dtype f32
    identical 3 --brick 16 --overlap 1 --memory-limit 80M
    ;;
  non-finite)  # NaN and infinite voxels (per-brick masks, all-NaN constant bricks) in a raw f32 volume
    python3 - <<'PY'
import array, math
nx, ny, nz = 64, 60, 70
v = array.array('f', (math.sin(0.1 * x) * math.cos(0.07 * y) + 0.01 * z for z in range(nz) for y in range(ny) for x in range(nx)))
for z in range(nz):
    for y in range(ny):
        for x in range(nx):
            i = (z * ny + y) * nx + x
            if z >= 50 and x < 30: v[i] = math.nan              # an all-NaN region
            elif (x * 7 + y * 3 + z) % 97 == 0: v[i] = math.inf if x % 2 else math.nan
open('in.raw', 'wb').write(v.tobytes())
PY
    "$strata" --progress none compress in.raw --dims 64,60,70 --dtype f32 -o single.strata --brick 16 --overlap 1 >single.log
    for np in 2 3; do
      "$mpiexec" -np "$np" --oversubscribe "$strata_mpi" compress in.raw --dims 64,60,70 --dtype f32 -o dist.strata \
        --brick 16 --overlap 1 >dist.log 2>&1 || { cat dist.log >&2; fail "strata-mpi with $np ranks failed"; }
      cmp single.strata dist.strata || fail "$np ranks: not byte-identical (non-finite voxels)"
      echo "ok: $np ranks, non-finite voxels, identical"
    done
    ;;
  tiny)  # two level-0 rows for three ranks
    generate prisms 40,36,30 --seed 5
    identical 3
    ;;
  refuses-target)
    generate prisms 40,36,30
    fails 2 "--psnr" 2 compress in.nrrd -o out.strata --psnr 40
    fails 2 "--codec" 2 compress in.nrrd -o out.strata --codec ta-global
    ;;
  bad-input)  # a NRRD header with a malformed field: every rank fails to open it, one reports
    printf 'NRRD0004\ntype: ushort\ndimension: 3\nsizes: 80 72 x\nencoding: raw\n\n' >bad.nrrd
    head -c 1000 /dev/zero >>bad.nrrd
    fails 1 "bad.nrrd.*sizes" 3 compress bad.nrrd -o out.strata
    # truncated samples (the header promises more than the file holds)
    printf 'NRRD0004\ntype: ushort\ndimension: 3\nsizes: 80 72 200\nendian: little\nencoding: raw\n\n' >short.nrrd
    head -c 100000 /dev/zero >>short.nrrd
    fails 1 "short.nrrd" 3 compress short.nrrd -o out.strata
    ;;
  bad-output)  # only rank 0 checks the output: the others learn of its failure and exit too
    generate prisms 40,36,30
    fails 1 "missing-dir" 2 compress in.nrrd -o missing-dir/out.strata
    ;;
  labels-blocks)  # 13 block rows: 3 ranks take 4/4/5; labels cross the ranks' borders
    generate fibres 64,48,100 --count 60
    for np in 1 2 3; do same_labels "$np"; done
    # --json: the report of strata labels encode plus one entry per rank, their slices tiling the volume
    "$mpiexec" -np 3 --oversubscribe "$strata_mpi" --progress none labels encode in.nrrd -o json.strata --json >json.log
    python3 - <<'PY' || fail "--json report"
import json
r = json.load(open("json.log"))
ranks = r["ranks"]
assert len(ranks) == 3 and r["nodes"] > 0, r
assert [k["z_begin"] for k in ranks] == [0, 32, 64] and ranks[-1]["z_end"] == 100, ranks
assert all(k["part_bytes"] > 0 and k["input_bytes"] > 0 for k in ranks), ranks
print("ok: --json with", len(ranks), "ranks")
PY
    ;;
  labels-fixed)  # fixed-rate ids, no zstd, 8-slice slabs under --memory-limit (several per rank)
    generate fibres 96,80,100 --count 200 --seed 4
    for np in 2 3; do same_labels "$np" --ids fixed --zstd 0 --memory-limit 65M --no-error; done
    ;;
  labels-idle)  # two block rows for three ranks: rank 0 has no slices; the last row is short
    generate fibres 40,36,12 --count 20
    same_labels 3 --strategy max-occurrence --bits 7
    ;;
  labels-refused)
    generate fibres 40,36,12 --count 20
    fails 2 "--normals" 2 labels encode in.nrrd -o out.strata --normals
    "$strata" --progress none generate marschner-lobb --size 20,20,20 --dtype f32 -o float.nrrd >/dev/null
    fails 1 "float.nrrd.*integer samples" 3 labels encode float.nrrd -o out.strata
    fails 1 "missing-dir" 2 labels encode in.nrrd -o missing-dir/out.strata
    fails 1 "memory-limit" 2 labels encode in.nrrd -o out.strata --memory-limit 1M
    ;;
  *) fail "unknown case $case_name" ;;
esac
