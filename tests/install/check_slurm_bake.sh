#!/usr/bin/env bash
# scripts/slurm-bake.sh on a real Slurm: a one-node cluster started here from Debian's slurm-wlm
# and munge (munged with a fresh key, slurmctld and slurmd on loopback ports picked free, every
# file in a throwaway folder), the sample site baked as a job array of 3 tasks and a merge job
# that depends on them, and the merged bake verified and equal, file for file and byte for
# byte, to a single-process bake. A bake whose tasks fail leaves the merge cancelled and the
# script's exit status 1. Slurm's daemons run as root here (they switch to the submitting user):
# without root the test is skipped (exit 77). Registered as the CTest Slurm.Bake.
#
#   bash tests/install/check_slurm_bake.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
source=$(cd "$2" && pwd)
say() { echo "check_slurm_bake: $*"; }
fail() { echo "check_slurm_bake: $*" >&2; exit 1; }
if [[ $(id -u) -ne 0 ]]; then
  say "skipped: slurmd runs jobs as their user, which needs root"
  exit 77
fi
for program in munged slurmctld slurmd sbatch sinfo scontrol; do
  command -v "$program" >/dev/null || fail "no $program: install slurm-wlm and munge (scripts/install-deps.sh)"
done

work=$(mktemp -d "${TMPDIR:-/tmp}/skylit_slurm_XXXXXX")
chmod 700 "$work"
export SLURM_CONF=$work/slurm.conf
stop() {
  local pids=()
  for pid_file in "$work/slurmd.pid" "$work/slurmctld.pid" "$work/munge/pid"; do
    [[ -f $pid_file ]] && pids+=("$(cat "$pid_file")")
  done
  scontrol shutdown >/dev/null 2>&1 || true
  [[ ${#pids[@]} -gt 0 ]] && kill "${pids[@]}" 2>/dev/null
  for pid in "${pids[@]}"; do
    timeout 10 tail --pid="$pid" -f /dev/null 2>/dev/null || kill -9 "$pid" 2>/dev/null || true
  done
  rm -rf "$work"
}
trap stop EXIT

# munge: the cluster's authentication, with a key of its own.
mkdir -m 700 "$work/munge"
head -c 1024 /dev/urandom > "$work/munge/munge.key"
chmod 400 "$work/munge/munge.key"
munged --force --socket="$work/munge/socket" --key-file="$work/munge/munge.key" --log-file="$work/munge/log" \
  --pid-file="$work/munge/pid" --seed-file="$work/munge/seed" || fail "munged did not start: $(cat "$work/munge/log")"

read -r controller_port node_port < <(/usr/bin/python3 -c '
import socket
sockets = [socket.socket() for _ in range(2)]
for s in sockets: s.bind(("127.0.0.1", 0))
print(*[s.getsockname()[1] for s in sockets])')
cpus=$(nproc)
mkdir -p "$work/state" "$work/spool"
cat > "$SLURM_CONF" <<EOF
ClusterName=skylittest
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$controller_port
SlurmdPort=$node_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge/socket
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
# Jobs start within a second of being possible (the defaults wait up to a minute between passes).
SchedulerParameters=sched_interval=1,sched_min_interval=100000
SchedulerType=sched/builtin
ReturnToService=2
MpiDefault=none
NodeName=bakenode NodeHostname=localhost NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=bake Nodes=bakenode Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -f "$SLURM_CONF" || fail "slurmctld did not start: $(tail -5 "$work/slurmctld.log")"
slurmd -f "$SLURM_CONF" -N bakenode || fail "slurmd did not start: $(tail -5 "$work/slurmd.log")"
# The node takes jobs once the controller has heard from it.
for ((tries = 0; tries < 300; ++tries)); do
  [[ $(sinfo --noheader --format=%T 2>/dev/null) == idle ]] && break
  sleep 0.1
done
[[ $(sinfo --noheader --format=%T) == idle ]] ||
  fail "the node is not idle: $(sinfo 2>&1); slurmctld: $(tail -3 "$work/slurmctld.log"); slurmd: $(tail -3 "$work/slurmd.log")"
say "a one-node Slurm cluster on 127.0.0.1:$controller_port ($cpus CPUs)"

export SKYLIT_BAKE=$build/bin/skylit-bake
site=$source/config/sample_site.yaml
options=(--samples 4 --method raytrace)
bash "$source/scripts/slurm-bake.sh" --wait "$site" "$work/cluster" 3 -- "${options[@]}" ||
  fail "the Slurm bake failed: $(tail -n 5 "$work"/cluster/logs/*.log)"
[[ $(ls "$work/cluster/shards") == $'0\n1\n2' ]] || fail "the shards are not 0, 1, 2: $(ls "$work/cluster/shards")"
grep -q "OK" "$work/cluster/logs/merge.log" || fail "the merge job did not verify the bake: $(cat "$work/cluster/logs/merge.log")"

# The same site in one process: every file the merged bake's manifest lists is the same, bytes
# and all (the bake is deterministic for a given plan, whichever process baked a face).
"$SKYLIT_BAKE" "$site" -o "$work/single" "${options[@]}" --quiet
files=$(/usr/bin/python3 -c 'import json, sys; print("\n".join(sorted(f["path"] for f in json.load(open(sys.argv[1]))["files"])))' "$work/cluster/bake/manifest.json")
[[ -n $files ]] || fail "the merged manifest lists no files"
for file in $files; do
  cmp -s "$work/cluster/bake/$file" "$work/single/$file" || fail "$file differs between the Slurm bake and the single-process bake"
done
say "the merged bake equals the single-process bake: $(echo "$files" | wc -l) files ($(echo $files | tr '\n' ' '))"

# Tasks that fail: the merge never runs (its dependency can no longer be met) and the script says so.
status=0
bash "$source/scripts/slurm-bake.sh" --wait "$site" "$work/failing" 2 -- --method nosuch > "$work/failing.log" 2>&1 || status=$?
[[ $status -eq 1 ]] || fail "a bake whose tasks fail exited $status, not 1: $(cat "$work/failing.log")"
[[ ! -e "$work/failing/bake" ]] || fail "a merge ran after its tasks failed"
grep -q "did not succeed" "$work/failing.log" || fail "no word of the failure: $(cat "$work/failing.log")"
say "failing tasks cancel the merge: $(tail -1 "$work/failing.log")"
