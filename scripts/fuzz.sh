#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan + UBSan) in build/fuzz and runs each for SECONDS
# (default 20) over its seeds (fuzz/corpus/<target>) and saved reproducers
# (fuzz/regressions/<target>); fails when any target finds a crash. docs/reliability.md.
#   scripts/fuzz.sh [SECONDS] [TARGET...]     TARGET: nrrd, container, ... (default: all)
# Environment: FUZZ_JOBS (targets run at once, default: nproc), FUZZ_WORK (where new corpus
# entries and crash files go, default build/fuzz/work; the committed corpus is not touched).
set -euo pipefail
cd "$(dirname "$0")/.."

seconds=20
if [[ $# -gt 0 && "$1" =~ ^[0-9]+$ ]]; then seconds=$1; shift; fi
all=()
for f in fuzz/fuzz_*.cpp; do t=${f#fuzz/fuzz_}; all+=("${t%.cpp}"); done
targets=("$@")
if ((${#targets[@]} == 0)); then targets=("${all[@]}"); fi
for t in "${targets[@]}"; do
  [[ -f fuzz/fuzz_$t.cpp ]] || { echo "fuzz: unknown target '$t' (have: ${all[*]})" >&2; exit 2; }
done

if ! command -v clang++ >/dev/null; then
  echo "fuzz: clang++ not found; install the fuzzing packages with ./setup.sh --fuzz" >&2
  exit 1
fi
if [ ! -f build/fuzz/build.ninja ]; then
  CC=clang CXX=clang++ cmake -S . -B build/fuzz -G Ninja -DCMAKE_BUILD_TYPE=Release -DSTRATA_FUZZ=ON \
    -DSTRATA_BUILD_TESTS=OFF -DSTRATA_BUILD_BENCH=OFF >/dev/null
fi
cmake --build build/fuzz --target "${targets[@]/#/fuzz_}"

root=$PWD
work=$(realpath -m "${FUZZ_WORK:-build/fuzz/work}")
jobs=${FUZZ_JOBS:-$(nproc)}
mkdir -p "$work"
# Reproducers whose fix has not landed yet are kept as fuzz/regressions/<target>/pending-* for
# the record and not replayed (rename them when the fix lands; fuzz/regressions/README.md).
run_one() {
  local t=$1 dir="$work/$1"
  rm -rf "$dir" && mkdir -p "$dir/corpus" "$dir/crashes" "$dir/regressions"
  if [ -d "$root/fuzz/regressions/$t" ]; then
    find "$root/fuzz/regressions/$t" -maxdepth 1 -type f ! -name 'pending-*' -exec cp {} "$dir/regressions/" \;
  fi
  local status=0
  # The targets write each input to a file under TMPDIR: memory, not disk, where there is /dev/shm.
  local tmp=${TMPDIR:-/tmp}
  if [ -z "${TMPDIR:-}" ] && [ -d /dev/shm ] && [ -w /dev/shm ]; then tmp=/dev/shm; fi
  TMPDIR=$tmp ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1} UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1} OMP_NUM_THREADS=1 \
    "$root/build/fuzz/fuzz/fuzz_$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -artifact_prefix="$dir/crashes/" -print_final_stats=1 \
    "$dir/corpus" "$dir/regressions" $([ -d "$root/fuzz/corpus/$t" ] && echo "$root/fuzz/corpus/$t") \
    >"$dir/log" 2>&1 || status=$?
  echo "$status" >"$dir/status"
}
export -f run_one
export root work seconds

start=$(date +%s)
printf '%s\n' "${targets[@]}" | xargs -P "$jobs" -I{} bash -c 'run_one {}'

failed=0
printf '%-18s %12s %10s %8s %8s  %s\n' target executions exec/s cov ft result
for t in "${targets[@]}"; do
  dir="$work/$t"
  status=$(cat "$dir/status")
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$dir/log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$dir/log" | tail -1)
  cov=$(grep -oE 'cov: [0-9]+' "$dir/log" | tail -1 | cut -d' ' -f2)
  ft=$(grep -oE 'ft: [0-9]+' "$dir/log" | tail -1 | cut -d' ' -f2)
  result=ok
  # slow-unit-* files are libFuzzer's report of its slowest inputs (exit 0), not findings: listed, not failed.
  slow=$(ls "$dir"/crashes/ 2>/dev/null | grep '^slow-unit-' | head -3 | tr '\n' ' ' || true)
  [ -n "$slow" ] && result="ok (slow units kept: $slow)"
  if [ "$status" != 0 ] || ls "$dir"/crashes/ 2>/dev/null | grep -qv '^slow-unit-'; then
    result="FAILED (exit $status): $(ls "$dir"/crashes/ 2>/dev/null | head -3 | tr '\n' ' ')see $dir/log"
    failed=1
  fi
  printf '%-18s %12s %10s %8s %8s  %s\n' "$t" "${execs:-?}" "${rate:-?}" "${cov:-?}" "${ft:-?}" "$result"
done
echo "fuzz: ${#targets[@]} targets, ${seconds} s each, $(( $(date +%s) - start )) s wall"
if ((failed)); then
  echo "fuzz: a target failed; the log names the input (crashes/...) and the sanitizer's report" >&2
  for t in "${targets[@]}"; do
    if [ "$(cat "$work/$t/status")" != 0 ]; then
      echo "--- $t ---" >&2
      grep -E 'ERROR: |SUMMARY: |runtime error|strata fuzz:|Test unit written' "$work/$t/log" | head -8 >&2
    fi
  done
  exit 1
fi
