#!/usr/bin/env bash
# Bake-time benchmark on the sample site: median wall time and peak memory per configuration.
# Usage: bench/run_bake_bench.sh [REPEATS]   (run from the repository root after a build)
set -euo pipefail
cd "$(dirname "$0")/.."
repeats=${1:-3}
bake=build/bin/skylit-bake
site=config/sample_site.yaml
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

configs=(
  "raster ν=2 K=1|--method raster --frequency 2 --samples 1"
  "raster ν=2 K=16|--method raster --frequency 2 --samples 16"
  "raster ν=8 K=1|--method raster --frequency 8 --samples 1"
  "raytrace ν=2 K=16|--method raytrace --frequency 2 --samples 16"
)

echo "machine: $(nproc) cores, $(awk '/MemTotal/ {printf "%.0f GiB", $2/1048576}' /proc/meminfo), $(lscpu | sed -n 's/^Model name: *//p' | head -1)"
echo "program: $(${bake} --version)"
echo
echo "| configuration | median wall time (s) | runs (s) | peak memory (MiB) |"
echo "|---|---|---|---|"
for entry in "${configs[@]}"; do
  name=${entry%%|*}
  args=${entry#*|}
  times=()
  peak=0
  for ((r = 0; r < repeats; r++)); do
    start=$(date +%s.%N)
    log=$($bake "$site" -o "$out/bake" $args --force --no-previews 2>&1) || { echo "$log" >&2; exit 1; }
    end=$(date +%s.%N)
    times+=("$(awk -v a="$start" -v b="$end" 'BEGIN {print b - a}')")
    mem=$(echo "$log" | sed -n 's/.*peak memory \([0-9]*\) MiB.*/\1/p' | tail -1)
    (( mem > peak )) && peak=$mem
  done
  median=$(printf '%s\n' "${times[@]}" | sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}')
  runs=$(printf '%.2f ' "${times[@]}")
  printf '| %s | %.2f | %s| %s |\n' "$name" "$median" "$runs" "$peak"
done
