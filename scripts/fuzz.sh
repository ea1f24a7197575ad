#!/usr/bin/env bash
# `make fuzz` (docs/fuzzing.md): builds every harness in fuzz/ with clang, libFuzzer, ASan and
# UBSan in build-fuzz/, then fuzzes each for FUZZ_SECONDS (default 600, the goal), FUZZ_JOBS at a
# time (default: the cores), starting from its seeds in fuzz/corpus/NAME and the corpus it grew
# before (build-fuzz/corpus/NAME). Writes build-fuzz/fuzz-report.md (executions per second and
# edges covered per harness) and keeps each finding in build-fuzz/findings/; exits 1 if any.
#   scripts/fuzz.sh [HARNESS...]        all harnesses when none is named
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=${FUZZ_BUILD:-$root/build-fuzz}
seconds=${FUZZ_SECONDS:-600}
jobs=${FUZZ_JOBS:-$(nproc)}

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DSKYLIT_FUZZ=ON -DSKYLIT_BUILD_TESTS=OFF -DSKYLIT_BUILD_BENCH=OFF >/dev/null
cmake --build "$build" --target fuzzers -j "$(nproc)"

if [[ $# -gt 0 ]]; then
  harnesses=("$@")
else
  mapfile -t harnesses < <(cd "$build/bin" && ls fuzz_* | sed 's/^fuzz_//')
fi
for name in "${harnesses[@]}"; do
  [[ -x "$build/bin/fuzz_$name" ]] || { echo "fuzz: no harness '$name' (have: $(cd "$build/bin" && ls fuzz_* | sed 's/^fuzz_//' | tr '\n' ' '))" >&2; exit 2; }
done

mkdir -p "$build/logs" "$build/findings"
# Findings of this run are the files newer than this stamp; those of earlier runs stay for reference.
stamp="$build/findings/.run-start"
touch "$stamp"
echo "fuzz: ${#harnesses[@]} harnesses, ${seconds} s each, ${jobs} at a time (logs in $build/logs)"

fuzz_one() {
  local name=$1
  mkdir -p "$build/corpus/$name"
  # Leaks are checked at exit and after each input that grew memory; a timeout of 10 s per input
  # and 2 GiB of memory are findings, as is any allocation over 1 GiB (a size not checked first).
  "$build/bin/fuzz_$name" "$build/corpus/$name" "$root/fuzz/corpus/$name" \
    -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=1024 \
    -artifact_prefix="$build/findings/$name-" -print_final_stats=1 >"$build/logs/$name.log" 2>&1 || true
  local status="ok"
  [[ -n $(find "$build/findings" -name "$name-*" -newer "$stamp") ]] && status="FINDINGS"
  echo "fuzz: $name done ($status)"
}
export -f fuzz_one
export build root seconds stamp
printf '%s\n' "${harnesses[@]}" | xargs -P "$jobs" -I{} bash -c 'fuzz_one {}'

report=$build/fuzz-report.md
{
  echo "| harness | seconds | executions | exec/s | edges covered | of instrumented | corpus | findings |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|"
  for name in "${harnesses[@]}"; do
    log=$build/logs/$name.log
    runs=$(grep -a 'stat::number_of_executed_units' "$log" | awk '{print $2}' | tail -1)
    rate=$(grep -a 'stat::average_exec_per_sec' "$log" | awk '{print $2}' | tail -1)
    total=$(grep -a -o 'Loaded 1 modules *([0-9]* inline 8-bit counters)' "$log" | grep -o '[0-9]* inline' | awk '{print $1}' | head -1)
    cov=$(grep -a -o 'cov: [0-9]*' "$log" | tail -1 | awk '{print $2}')
    corpus=$(find "$build/corpus/$name" -type f | wc -l)
    findings=$(find "$build/findings" -name "$name-*" -newer "$stamp" | wc -l)
    echo "| $name | $seconds | ${runs:-?} | ${rate:-?} | ${cov:-?} | ${total:-?} | $corpus | $findings |"
  done
} >"$report"
cat "$report"
if [[ -n $(find "$build/findings" -type f -name '*-*' -newer "$stamp") ]]; then
  echo "fuzz: findings in $build/findings: reproduce one with $build/bin/fuzz_NAME FILE, fix it, and keep the"
  echo "      input as fuzz/corpus/NAME/crash-WHAT so that make test replays it" >&2
  exit 1
fi
echo "fuzz: no findings"
