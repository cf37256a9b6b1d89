#!/usr/bin/env bash
# A real Slurm test on a one-node cluster started on localhost (Slurm and
# munge from Debian; scripts/setup.sh installs them): a small bundle rendered
# as a 4-task job array plus a finalize job (afterok, deploy/slurm/render.sh)
# must equal one render process's byte for byte; then one task is cancelled
# while it runs: finalize must fail naming its shard's assets, and
# resubmitting that task alone must complete the bundle. Prints the wall times
# of the array and of one process. The cluster is stopped at the end.
#   scripts/slurm-test.sh [EXPLOREMAPS]     (default: target/debug/exploremaps)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
exe="$(realpath "${1:-$root/target/debug/exploremaps}")"
for tool in slurmctld slurmd munged sbatch squeue scancel; do
  command -v "$tool" >/dev/null || { echo "SKIPPED: $tool is not installed (scripts/setup.sh installs Slurm)"; exit 0; }
done
[ "$(id -u)" -eq 0 ] || { echo "SKIPPED: a local Slurm node needs root"; exit 0; }

work="$(mktemp -d)"
chmod 755 "$work" # munged wants its socket's folders open to all
cleanup() {
  scontrol shutdown >/dev/null 2>&1 || true
  [ -f "$work/munge/munged.pid" ] && kill "$(cat "$work/munge/munged.pid")" 2>/dev/null || true
  sleep 1
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "slurm-test: FAILED: $*" >&2; exit 1; }

# The cluster: munge with its own key and socket, one node with every CPU.
mkdir -p "$work"/{munge,state,spool,log}
head -c 1024 /dev/urandom >"$work/munge/munge.key" && chmod 600 "$work/munge/munge.key"
munged --key-file="$work/munge/munge.key" --socket="$work/munge/munge.sock" --pid-file="$work/munge/munged.pid" \
  --log-file="$work/munge/munged.log" --seed-file="$work/munge/seed"
port() { python3 -c 'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])'; }
host="$(hostname -s)"
export SLURM_CONF="$work/slurm.conf"
cat >"$SLURM_CONF" <<CONF
ClusterName=exploremaps-test
SlurmctldHost=$host
SlurmUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge/munge.sock
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
SlurmctldPort=$(port)
SlurmdPort=$(port)
ReturnToService=2
MpiDefault=none
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
NodeName=$host CPUs=$(nproc) State=UNKNOWN
PartitionName=main Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 60); do sinfo -h -o %T 2>/dev/null | grep -q idle && break; sleep 0.5; done
sinfo -h -o %T | grep -q idle || fail "the local node did not come up ($(tail -3 "$work/log/slurmd.log"))"

# Waits until a job (or array) has left the queue.
wait_job() {
  for _ in $(seq 1200); do [ -z "$(squeue -h -j "$1" 2>/dev/null)" ] && return 0; sleep 0.5; done
  fail "job $1 still queued after 10 minutes"
}
same() { diff -r -q --exclude=timings.json --exclude=shards "$work/single" "$1" >/dev/null || fail "$1 differs from the single render: $(diff -r -q --exclude=timings.json --exclude=shards "$work/single" "$1" | head -5)"; }

args=(--quality preview --face 64 --video-width 128 --transitions video)
"$exe" -q plan maze:3 -o "$work/planned" --samples 5000 >/dev/null
cp -r "$work/planned" "$work/single"
started=$(date +%s.%N)
"$exe" -q render "$work/single" "${args[@]}" >/dev/null
single=$(echo "$(date +%s.%N) - $started" | bc)

# 1. Four tasks and finalize.
cp -r "$work/planned" "$work/array"
started=$(date +%s.%N)
out=$(EXPLOREMAPS="$exe" "$root/deploy/slurm/render.sh" "$work/array" 4 "${args[@]}")
final=$(sed -n 's/.*finalize \([0-9]*\);.*/\1/p' <<<"$out")
wait_job "$final"
array=$(echo "$(date +%s.%N) - $started" | bc)
grep -q "complete" "$work/array.logs/finalize-$final.log" || fail "finalize did not complete: $(cat "$work/array.logs/finalize-$final.log")"
same "$work/array"

# 2. Task 2 cancelled while it runs: finalize refuses, naming shard 2; task 2 alone completes it.
# A task takes a few seconds; under load the cancel can land after it ended (its
# manifest written): then the premise did not hold, and the case runs again.
for attempt in 1 2 3; do
    rm -rf "$work/killed"
    cp -r "$work/planned" "$work/killed"
    out=$(EXPLOREMAPS="$exe" "$root/deploy/slurm/render.sh" "$work/killed" 4 "${args[@]}")
    job=$(sed -n 's/render array \([0-9]*\) .*/\1/p' <<<"$out")
    for _ in $(seq 600); do [ "$(squeue -h -j "${job}_2" -o %T 2>/dev/null)" = RUNNING ] && break; sleep 0.05; done
    scancel "${job}_2"
    wait_job "$job"
    # The queue can empty before the signalled process is gone; wait for it.
    for _ in $(seq 200); do pgrep -f "render $work/killed " >/dev/null || break; sleep 0.1; done
    [ -e "$work/killed/shards/2-of-4.json" ] || break
    [ "$attempt" -lt 3 ] || fail "task 2 finished before each of three cancels"
    echo "slurm-test: task 2 finished before its cancel (attempt $attempt); again"
done
if "$exe" render "$work/killed" --finalize 2>"$work/finalize.err"; then fail "finalize passed with task 2 cancelled"; fi
grep -q "(shard 2/4): missing" "$work/finalize.err" || fail "finalize did not name shard 2's assets: $(head -5 "$work/finalize.err")"
[ ! -e "$work/killed/shards/2-of-4.json" ] || fail "cancelled task 2 left its manifest"
out=$(EXPLOREMAPS="$exe" "$root/deploy/slurm/render.sh" "$work/killed" 4 --tasks 2 "${args[@]}")
wait_job "$(sed -n 's/.*finalize \([0-9]*\);.*/\1/p' <<<"$out")"
same "$work/killed"
printf 'slurm-test: passed; 4-task array with finalize %.1f s, one render process %.1f s (maze:3, preview)\n' "$array" "$single"
