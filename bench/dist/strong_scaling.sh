#!/usr/bin/env bash
# Strong scaling of `strata-mpi compress` (docs/distributed.md): one input, `strata compress` and
# strata-mpi on 1 and 2 ranks, alternated round by round, wall time per run, the load average
# before each run, and each rank's report line (bytes read, exchanged, encoded; phase seconds).
#   [THREADS=N] bench/dist/strong_scaling.sh BUILD_DIR INPUT [ROUNDS=3] [RANKS="1 2"] [compress flags...]
# THREADS: --threads of every run (strata-mpi's default: the node's hardware threads / its ranks).
# Byte identity of every output with the single-process file is checked (cmp) on the way.
set -euo pipefail
build=$1 input=$2 rounds=${3:-3} ranks=${4:-"1 2"}
shift $(($# < 4 ? $# : 4))
threads=()
if [ -n "${THREADS:-}" ]; then threads=(--threads "$THREADS"); fi
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
now() { date +%s.%N; }
for round in $(seq "$rounds"); do
  load=$(cut -d' ' -f1 /proc/loadavg)
  t0=$(now)
  "$build/strata" "${threads[@]}" --progress none compress "$input" -o "$out/single.strata" "$@" >/dev/null
  echo "round $round strata compress: $(echo "$(now) - $t0" | bc) s (load $load)"
  for np in $ranks; do
    load=$(cut -d' ' -f1 /proc/loadavg)
    t0=$(now)
    mpirun -np "$np" --oversubscribe "$build/strata-mpi" "${threads[@]}" compress "$input" -o "$out/dist.strata" "$@" >"$out/log"
    echo "round $round strata-mpi -np $np: $(echo "$(now) - $t0" | bc) s (load $load)"
    grep '^rank\|ranks:' "$out/log" | sed 's/^/    /'
    cmp "$out/single.strata" "$out/dist.strata"
  done
done
