#!/usr/bin/env bash
# A bake on a Slurm cluster (docs/baker.md, "Job arrays"): SITE's faces baked by a job array of N
# tasks, each into OUT/shards/K, then one merge job, started only once every task succeeded
# (--dependency=afterok), that joins them into OUT/bake and verifies it. The batch scripts it
# submits are kept in OUT/jobs (to read, or to submit again), each job's log in OUT/logs.
#
#   scripts/slurm-bake.sh [--wait] [--partition P] [--time T] [--cpus C] [--mem M]
#                         SITE.yaml OUT N [-- BAKE OPTIONS...]
#
# BAKE OPTIONS go to every task (e.g. --samples 64 --method raytrace), except --no-previews and
# --pca-* which finish the bake and so go to the merge; -q to both. OUT must be on storage every
# node of the partition shares. skylit-bake is $SKYLIT_BAKE, else the one on PATH.
# --wait: wait for the merge and exit with its status (0: the bake is in OUT/bake and verified).
set -euo pipefail

usage() { sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; }
die() { echo "slurm-bake: $*" >&2; exit 2; }
quoted() { for word in "$@"; do printf ' %q' "$word"; done; }

wait_merge=0
sbatch_options=()
while [[ $# -gt 0 && $1 == --* ]]; do
  case $1 in
    --wait) wait_merge=1; shift ;;
    --partition|--time|--cpus|--mem)
      [[ $# -ge 2 ]] || die "$1 needs a value"
      case $1 in
        --partition) sbatch_options+=(--partition="$2") ;;
        --time) sbatch_options+=(--time="$2") ;;
        --cpus) sbatch_options+=(--cpus-per-task="$2") ;;
        --mem) sbatch_options+=(--mem="$2") ;;
      esac
      shift 2 ;;
    --help) usage; exit 0 ;;
    --) break ;;
    *) die "unknown option '$1' (see --help)" ;;
  esac
done
[[ $# -ge 3 ]] || { usage >&2; exit 2; }
site=$1 out=$2 count=$3
shift 3
if [[ $# -gt 0 ]]; then
  [[ $1 == -- ]] || die "'$1': the bake's options come after -- (see --help)"
  shift
fi
[[ -f $site ]] || die "$site: no such site file. Fix: give the site's YAML (docs/site-format.md)"
[[ $count =~ ^[1-9][0-9]*$ ]] || die "N '$count' is not a positive count of tasks. Fix: e.g. 8"
command -v sbatch >/dev/null || die "no sbatch on PATH. Fix: run on a Slurm login node (Debian: slurm-client)"
bake=${SKYLIT_BAKE:-$(command -v skylit-bake || true)}
[[ -n $bake && -x $bake ]] || die "no skylit-bake (set SKYLIT_BAKE, or put it on PATH)"

# The options: a task's, the merge's (which finish the bake), and both's.
shard_options=()
merge_options=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --no-previews) merge_options+=("$1"); shift ;;
    --pca-*=*) merge_options+=("$1"); shift ;;
    --pca-*) [[ $# -ge 2 ]] || die "$1 needs a value"; merge_options+=("$1" "$2"); shift 2 ;;
    -q|--quiet) shard_options+=("$1"); merge_options+=("$1"); shift ;;
    --shard*|-o|--output|--resume) die "'$1' is the array's to set: leave it out" ;;
    *) shard_options+=("$1"); shift ;;
  esac
done

site=$(realpath "$site")
bake=$(realpath "$bake")
mkdir -p "$out"
out=$(realpath "$out")
[[ ! -e $out/bake ]] || die "$out/bake exists. Fix: remove it, or give another OUT"
mkdir -p "$out/jobs" "$out/logs" "$out/shards"

# Each task bakes its slice (skylit-bake reads SLURM_ARRAY_TASK_ID, _MIN and _COUNT) into a
# folder of its own; a task run again (a requeue) continues where it stopped.
{
  echo "#!/bin/bash"
  echo "#SBATCH --job-name=skylit-bake"
  echo "#SBATCH --output=$out/logs/shard-%a.log"
  echo "set -euo pipefail"
  echo "shard=$(printf %q "$out/shards")/\$SLURM_ARRAY_TASK_ID"
  printf 'if [[ -f $shard/manifest.json ]]; then resume=--resume; else resume=; fi\n'
  printf 'exec %q %q -o "$shard" $resume' "$bake" "$site"
  quoted "${shard_options[@]}"
  echo
} > "$out/jobs/shards.sbatch"
{
  echo "#!/bin/bash"
  echo "#SBATCH --job-name=skylit-merge"
  echo "#SBATCH --output=$out/logs/merge.log"
  echo "set -euo pipefail"
  printf '%q merge' "$bake"
  for ((k = 0; k < count; ++k)); do quoted "$out/shards/$k"; done
  quoted -o "$out/bake" "${merge_options[@]}"
  echo
  printf '%q verify %q\n' "$bake" "$out/bake"
} > "$out/jobs/merge.sbatch"

array=$(sbatch --parsable "${sbatch_options[@]}" --array=0-$((count - 1)) "$out/jobs/shards.sbatch")
array=${array%%;*}
echo "slurm-bake: job array $array: $count task(s) baking $site into $out/shards"
merge_args=(--parsable "${sbatch_options[@]}" --dependency=afterok:"$array" --kill-on-invalid-dep=yes)
if [[ $wait_merge -eq 0 ]]; then
  merge=$(sbatch "${merge_args[@]}" "$out/jobs/merge.sbatch")
  merge=${merge%%;*}
  echo "slurm-bake: merge job $merge: once every task succeeded, into $out/bake (squeue -j $array,$merge; logs in $out/logs)"
  exit 0
fi
echo "slurm-bake: waiting for the merge (squeue -j $array; logs in $out/logs)"
# sbatch --wait answers 0 for a merge cancelled because a task failed: the job's own state, and
# the bake it leaves, say whether it succeeded.
sbatch "${merge_args[@]}" --wait "$out/jobs/merge.sbatch" > "$out/jobs/merge.id" || true
merge=$(head -1 "$out/jobs/merge.id")
merge=${merge%%;*}
state=$(scontrol show job "$merge" --oneliner 2>/dev/null | grep -o 'JobState=[A-Z_]* Reason=[^ ]*' || echo "JobState=unknown")
if [[ $state != JobState=COMPLETED* || ! -f $out/bake/manifest.json ]]; then
  echo "slurm-bake: the merge job $merge did not succeed ($state): see $out/logs (a task that fails cancels it)" >&2
  exit 1
fi
echo "slurm-bake: $out/bake merged from $count task(s) and verified"
