#!/usr/bin/env bash
# Strong scaling of `strata-mpi compress` or `strata-mpi labels encode` (docs/distributed.md):
# one input, the single-process command and strata-mpi on 1 and 2 ranks, alternated round by
# round, wall time per run, the load average before each run, and each rank's report line
# (bytes read, exchanged or sent, encoded; phase seconds).
#   [THREADS=N] [COMMAND=labels] bench/dist/strong_scaling.sh BUILD_DIR INPUT [ROUNDS=3] [RANKS="1 2"] [flags...]
# THREADS: --threads of every run (strata-mpi's default: the node's hardware threads / its ranks).
# COMMAND: compress (default) or labels (`labels encode`).
# Every output is checked on the way against the single-process file: byte identity (cmp) for
# compress; for labels the same sections and metadata by `strata info --json`, timing aside.
set -euo pipefail
build=$1 input=$2 rounds=${3:-3} ranks=${4:-"1 2"}
shift $(($# < 4 ? $# : 4))
threads=()
if [ -n "${THREADS:-}" ]; then threads=(--threads "$THREADS"); fi
command=(compress)
if [ "${COMMAND:-compress}" = labels ]; then command=(labels encode); fi
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
now() { date +%s.%N; }
summary() {
  "$build/strata" info --json "$1" |
    grep -v -e '"file":' -e '"factor_seconds":' -e '"metadata_bytes":' -e '"file_bytes":' -e '"bits_per_voxel":'
}
same_file() {
  if [ "${command[0]}" = compress ]; then
    cmp "$out/single.strata" "$out/dist.strata"
  else
    diff <(summary "$out/single.strata") <(summary "$out/dist.strata")
  fi
}
for round in $(seq "$rounds"); do
  load=$(cut -d' ' -f1 /proc/loadavg)
  t0=$(now)
  "$build/strata" "${threads[@]}" --progress none "${command[@]}" "$input" -o "$out/single.strata" "$@" >/dev/null
  echo "round $round strata ${command[*]}: $(echo "$(now) - $t0" | bc) s (load $load)"
  for np in $ranks; do
    load=$(cut -d' ' -f1 /proc/loadavg)
    t0=$(now)
    mpirun -np "$np" --oversubscribe "$build/strata-mpi" "${threads[@]}" "${command[@]}" "$input" -o "$out/dist.strata" \
      "$@" >"$out/log"
    echo "round $round strata-mpi -np $np: $(echo "$(now) - $t0" | bc) s (load $load)"
    grep '^rank\|ranks:' "$out/log" | sed 's/^/    /'
    same_file
  done
done
