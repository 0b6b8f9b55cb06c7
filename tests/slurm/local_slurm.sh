#!/usr/bin/env bash
# scripts/slurm/submit.sh against a real Slurm: munged, slurmctld and slurmd started on this machine with
# a generated slurm.conf (one node with its cores and memory; state, spool, logs and the munge socket
# under WORK; free ports), configs/ci.toml submitted as a 4-task array, the merge job waited for, and the
# merged CSV compared with a single-process run of the same config in every deterministic metric, both
# ways (so that neither has a cell the other lacks). Installs Debian's slurm-wlm and munge when they are
# missing (as root). Stops only the daemons it started, by their pids.
#
#   tests/slurm/local_slurm.sh SAHBENCH SOURCE_DIR WORK
#
# Exit 0 pass, 1 fail (with the daemons' logs), 77 skip: only outside CI, where Slurm is missing and
# cannot be installed (not root). In CI (CI set) a Slurm that cannot start is a failure.
set -euo pipefail
sahbench=$1
source_dir=$2
work=$3
# Defaults are the ctest's; the overrides are for measuring a larger sweep the same way:
#   SAHBENCH_SLURM_SHARDS (4), SAHBENCH_SLURM_CONFIG (configs/ci.toml), SAHBENCH_SLURM_WAIT_S (600, per
#   job), SAHBENCH_SLURM_SUBMIT_ARGS (extra submit.sh options, e.g. "--cpus-per-task 2"),
#   SAHBENCH_SLURM_SINGLE (an earlier single-process CSV of the config, compared instead of a new run) and
#   SAHBENCH_SLURM_RESUBMIT (1: also check that a cut shard resubmitted alone continues).
shards=${SAHBENCH_SLURM_SHARDS:-4}
config=${SAHBENCH_SLURM_CONFIG:-configs/ci.toml}
wait_s=${SAHBENCH_SLURM_WAIT_S:-600}
read -r -a submit_args <<<"${SAHBENCH_SLURM_SUBMIT_ARGS:-}"
single_csv=${SAHBENCH_SLURM_SINGLE:-}
resubmit=${SAHBENCH_SLURM_RESUBMIT:-1}

fail() {
  echo "local_slurm: FAIL: $*" >&2
  for log in "$work"/logs/*.log "$work"/run/logs/*.log; do
    [[ -f $log ]] && { echo "----- $log" >&2; tail -n 60 "$log" >&2; }
  done
  exit 1
}

# Slurm and munge, installed where missing.
need=()
for tool in munged slurmctld slurmd sbatch; do command -v "$tool" >/dev/null || need+=("$tool"); done
if ((${#need[@]})); then
  if [[ $(id -u) -ne 0 ]]; then
    msg="missing ${need[*]} and not root to install slurm-wlm and munge"
    [[ -n ${CI:-} ]] && fail "$msg"
    echo "local_slurm: SKIP: $msg" >&2
    exit 77
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq || fail "apt-get update failed"
  apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null || fail "apt-get install failed"
fi
if [[ $(id -u) -ne 0 ]]; then
  # slurmd runs jobs as their users, which takes root.
  [[ -n ${CI:-} ]] && fail "slurmd needs root"
  echo "local_slurm: SKIP: slurmd needs root" >&2
  exit 77
fi

rm -rf "$work"
mkdir -p "$work"/{state,spool,logs,munge}
chmod 700 "$work/munge"
work=$(cd "$work" && pwd)
pids=()
stop() {
  # Ours only, by pid: slurmd first (it ends its job steps), then slurmctld, then munged.
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do kill "${pids[i]}" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2>/dev/null || true
  done
}
trap stop EXIT

# Two free TCP ports, from the kernel (bind to port 0).
read -r ctld_port slurmd_port < <(/usr/bin/python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])')

# munged with a key of its own, listening on a socket in WORK.
dd if=/dev/urandom of="$work/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$work/munge/munge.key"
munged --force --foreground --socket="$work/munge/munge.socket" --key-file="$work/munge/munge.key" \
  --log-file="$work/logs/munged.log" --pid-file="$work/munge/munged.pid" --seed-file="$work/munge/seed" &
pids+=($!)
for _ in $(seq 50); do [[ -S $work/munge/munge.socket ]] && break; sleep 0.1; done
[[ -S $work/munge/munge.socket ]] || fail "munged did not start"

host=$(hostname -s)
cpus=$(nproc)
mem_mb=$(($(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 * 9 / 10))
cat >"$work/slurm.conf" <<CONF
ClusterName=sahbench
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/logs/slurmctld.log
SlurmdLogFile=$work/logs/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
# Finished jobs stay visible to scontrol until the per-shard times are read.
MinJobAge=$((wait_s + 600))
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF=$work/slurm.conf
slurmctld -D -i -f "$SLURM_CONF" >>"$work/logs/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" -N "$host" >>"$work/logs/slurmd.out" 2>&1 &
pids+=($!)
state=
for _ in $(seq 120); do
  state=$(sinfo -h -N -o %t 2>/dev/null | head -n1 || true)
  [[ $state == idle ]] && break
  sleep 0.5
done
[[ $state == idle ]] || fail "the node is '$state', not idle, after 60 s"
echo "local_slurm: Slurm up: node $host, $cpus CPUs, ${mem_mb} MB, ports $ctld_port and $slurmd_port" >&2

# The sweep through submit.sh, from the source folder (the config's paths are relative to it).
cd "$source_dir"
start=$(date +%s.%N)
submitted=$(bash scripts/slurm/submit.sh "$config" --shards "$shards" --out "$work/run" --sahbench "$sahbench" \
  "${submit_args[@]}") ||
  fail "submit.sh failed"
echo "$submitted"
merge_job=$(sed -n 's/^merge job \([0-9]*\):.*/\1/p' <<<"$submitted")
[[ -n $merge_job ]] || fail "submit.sh printed no merge job id"
wait_for_job() {  # $1: job id; fails unless it completes within wait_s seconds
  local job_state=
  for _ in $(seq $((wait_s * 2))); do
    job_state=$(scontrol show job "$1" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p')
    case $job_state in
      COMPLETED) return 0 ;;
      PENDING | RUNNING | CONFIGURING | COMPLETING | "") sleep 0.5 ;;
      *) fail "job $1 ended $job_state" ;;
    esac
  done
  fail "job $1 not done after $wait_s s ($job_state)"
}
wait_for_job "$merge_job"
end=$(date +%s.%N)
echo "local_slurm: submission to merged report: $(/usr/bin/python3 -c "print(f'{$end - $start:.1f}')") s" >&2
# Each task's measured time, to set beside the plan's estimates (plan.md); informative only, so a job
# record that is gone or unparsable does not fail the test.
array_job=$(sed -n 's/^array job \([0-9]*\):.*/\1/p' <<<"$submitted")
scontrol -o show job "$array_job" 2>/dev/null | while read -r line; do
  task=$(sed -n 's/.*ArrayTaskId=\([0-9]*\).*/\1/p' <<<"$line")
  t0=$(date -d "$(sed -n 's/.*StartTime=\([^ ]*\).*/\1/p' <<<"$line")" +%s)
  t1=$(date -d "$(sed -n 's/.*EndTime=\([^ ]*\).*/\1/p' <<<"$line")" +%s)
  echo "local_slurm: shard $task ran $((t1 - t0)) s" >&2
done || echo "local_slurm: the shards' times are not available from scontrol" >&2
[[ -s $work/run/report.md ]] || fail "no report at $work/run/report.md"

# One process, the same config: every deterministic metric equal, and the same cells both ways.
if [[ -n $single_csv ]]; then
  cp "$single_csv" "$work/single.csv"
else
  start=$(date +%s.%N)
  "$sahbench" run "$config" --output "$work/single.csv" 2>"$work/logs/single.log" || fail "single run failed"
  end=$(date +%s.%N)
  echo "local_slurm: one process: $(/usr/bin/python3 -c "print(f'{$end - $start:.1f}')") s" >&2
fi
compare_with_single() {
  local pair out
  for pair in "$work/single.csv $work/run/merged.csv" "$work/run/merged.csv $work/single.csv"; do
    # shellcheck disable=SC2086
    out=$("$sahbench" compare $pair --deterministic-only) || fail "compare $pair: exit $?:
$out"
    grep -q " 0 missing (each a regression), 0 other regressions" <<<"$out" || fail "compare $pair:
$out"
  done
}
compare_with_single
echo "local_slurm: merged CSV of $shards shards equals the single run in every deterministic metric" >&2
[[ $resubmit == 1 ]] || exit 0

# A failed task resubmitted alone continues its shard: shard 1's CSV cut back to its first two rows (as
# a task killed mid-shard leaves it), task 1 resubmitted, and the new merge again equals the single run.
csv1=$work/run/shard-1.csv
head -n 3 "$csv1" >"$csv1.cut" && mv "$csv1.cut" "$csv1"
rm -f "$work/run/merged.csv" "$work/run/report.md"
resubmitted=$(bash scripts/slurm/submit.sh --resubmit "$work/run" 1) || fail "submit.sh --resubmit failed"
echo "$resubmitted"
merge_job=$(sed -n 's/.*; merge job \([0-9]*\)$/\1/p' <<<"$resubmitted")
[[ -n $merge_job ]] || fail "submit.sh --resubmit printed no merge job id"
wait_for_job "$merge_job"
grep -q "resume: run .*, 2 finished cells" "$work"/run/logs/shard-1-*.log ||
  fail "the resubmitted task did not continue shard 1 from its 2 finished cells"
compare_with_single
echo "local_slurm: shard 1 resubmitted alone continued its CSV; the merge equals the single run again" >&2
