#!/usr/bin/env bash
# Submits a sahbench sweep to Slurm as a job array, one shard of the plan per task
# (`sahbench run CONFIG --shard K/N`, K = SLURM_ARRAY_TASK_ID), and a merge job that runs once every task
# has succeeded (--dependency=afterok): `sahbench merge`, then `sahbench report`. Prints the job ids and
# where the merged CSV and the report will be.
#
#   scripts/slurm/submit.sh CONFIG [--shards N] [--cpus-per-task C] [--exclusive] [--partition P]
#                           [--time T] [--out DIR] [--sahbench PATH] [-- SBATCH_OPTION...]
#   scripts/slurm/submit.sh --resubmit DIR K [K...]
#
# Every task runs with --resume, so a failed task (a node lost, a time limit) resubmitted alone with
# --resubmit continues its shard where its CSV stops; the merge job is then submitted again, after the
# resubmitted tasks succeed and the rest of the first array has ended. Options after `--` go to every
# sbatch call (an account, a QoS, --constraint to keep the sweep on one CPU model: the shards must share
# one run fingerprint, which names the CPU).
set -euo pipefail

usage() { sed -n '7,9p' "$0" | sed 's/^#   //' >&2; exit 2; }
die() { echo "submit.sh: $*" >&2; exit 2; }

# The sbatch script of one shard: its own CSV under DIR, --resume so that a rerun continues it.
task_script() {
  cat <<SCRIPT
#!/usr/bin/env bash
set -euo pipefail
cd $(printf %q "$workdir")
k=\$SLURM_ARRAY_TASK_ID
exec $(printf %q "$sahbench") run $(printf %q "$config") --shard "\$k/$shards" --resume \\
  --output $(printf %q "$out")/shard-\$k.csv
SCRIPT
}

# The sbatch script of the merge: every shard's CSV, then the report of the merged run.
merge_script() {
  local files=()
  for ((k = 0; k < shards; k++)); do files+=("$out/shard-$k.csv"); done
  cat <<SCRIPT
#!/usr/bin/env bash
set -euo pipefail
cd $(printf %q "$workdir")
$(printf %q "$sahbench") merge $(printf %q "$out/merged.csv") $(printf '%q ' "${files[@]}")--config $(printf %q "$config")
$(printf %q "$sahbench") report $(printf %q "$out/merged.csv") --output $(printf %q "$out/report.md")
SCRIPT
}

submit_merge() {  # $1: dependency
  merge_script >"$out/merge.sbatch"
  sbatch --parsable --job-name="sahbench-merge-$name" --output="$out/logs/merge-%j.log" \
    --dependency="$1" --kill-on-invalid-dep=yes "${array_options[@]}" "${extra[@]}" "$out/merge.sbatch" |
    cut -d';' -f1
}

if [[ ${1:-} == --resubmit ]]; then
  [[ $# -ge 3 ]] || usage
  out=$(cd "$2" && pwd)
  shift 2
  [[ -f $out/submission.env ]] || die "$out/submission.env: not a directory written by submit.sh"
  # shellcheck source=/dev/null
  source "$out/submission.env"
  tasks=$(IFS=,; echo "$*")
  for k in "$@"; do
    [[ $k =~ ^[0-9]+$ && $k -lt $shards ]] || die "shard '$k': expected 0..$((shards - 1))"
  done
  # The old merge job waits on the failed array and can never run: replace it.
  scancel "$merge_job" 2>/dev/null || true
  array_job=$(sbatch --parsable --job-name="sahbench-$name" --array="$tasks" \
    --output="$out/logs/shard-%a-%j.log" "${array_options[@]}" "${extra[@]}" "$out/task.sbatch" | cut -d';' -f1)
  merge_job=$(submit_merge "afterany:$first_array_job,afterok:$array_job")
  sed -i "s/^merge_job=.*/merge_job=$merge_job/" "$out/submission.env"
  echo "resubmitted shards $tasks of $shards as array job $array_job; merge job $merge_job"
  echo "merged CSV: $out/merged.csv"
  echo "report:     $out/report.md"
  exit 0
fi

[[ $# -ge 1 && $1 != -* ]] || usage
config=$1
shift
shards=4
sahbench=build/release/sahbench
out=
array_options=()
extra=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --shards) shards=$2; shift 2 ;;
    --cpus-per-task) array_options+=("--cpus-per-task=$2"); shift 2 ;;
    --exclusive) array_options+=(--exclusive); shift ;;
    --partition) array_options+=("--partition=$2"); shift 2 ;;
    --time) array_options+=("--time=$2"); shift 2 ;;
    --out) out=$2; shift 2 ;;
    --sahbench) sahbench=$2; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    *) usage ;;
  esac
done
[[ $shards =~ ^[1-9][0-9]*$ ]] || die "--shards '$shards': expected a positive whole number"
[[ -f $config ]] || die "$config: no such config"
[[ -x $sahbench ]] || die "$sahbench: not an executable (build with scripts/setup.sh, or give --sahbench)"
workdir=$PWD
sahbench=$(cd "$(dirname "$sahbench")" && pwd)/$(basename "$sahbench")
name=$(basename "$config" .toml)
out=${out:-results/slurm/$name-$(date -u +%Y%m%d-%H%M%S)}
mkdir -p "$out/logs"
out=$(cd "$out" && pwd)

# The plan, with its estimates, beside the results; it also checks the config before anything queues.
"$sahbench" plan "$config" --shards "$shards" >"$out/plan.md"
task_script >"$out/task.sbatch"
array_job=$(sbatch --parsable --job-name="sahbench-$name" --array="0-$((shards - 1))" \
  --output="$out/logs/shard-%a-%j.log" "${array_options[@]}" "${extra[@]}" "$out/task.sbatch" | cut -d';' -f1)
merge_job=$(submit_merge "afterok:$array_job")
{
  printf 'config=%q\nshards=%q\nsahbench=%q\nworkdir=%q\nname=%q\n' "$config" "$shards" "$sahbench" "$workdir" "$name"
  printf 'first_array_job=%q\nmerge_job=%q\n' "$array_job" "$merge_job"
  declare -p array_options extra
} >"$out/submission.env"
echo "array job $array_job: $shards shards of $config (logs in $out/logs)"
echo "merge job $merge_job: after every shard succeeds"
echo "merged CSV: $out/merged.csv"
echo "report:     $out/report.md"
echo "plan:       $out/plan.md"
echo "a failed shard K: scripts/slurm/submit.sh --resubmit $out K"
