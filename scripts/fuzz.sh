#!/usr/bin/env bash
# Fuzzes the readers of user-supplied files (README, "Fuzzing"): installs clang and libFuzzer when
# missing, builds the 'fuzz' preset (clang, ASan + UBSan, build/fuzz) and runs each
# target for SECONDS (default 60) over a copy of its seed corpus in build/fuzz/runs/<target> (the
# repository's fuzz/corpus is never written). Exits 1, naming the target and the input that did it, when
# any target finds a crash, a sanitizer report, a leak, a timeout, an out-of-memory or an exception that
# is not sahbench::Error.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
[[ $seconds =~ ^[1-9][0-9]*$ ]] || { echo "usage: scripts/fuzz.sh [SECONDS]" >&2; exit 2; }

SAHBENCH_PRESET=fuzz bash scripts/setup.sh

targets=(obj ply gltf config stress_config rays tree_file)
# One target per core at a time: each libFuzzer process is single-threaded.
fuzz_one() {
  local target=$1 run=build/fuzz/runs/$1 start=$SECONDS status=0
  rm -rf "$run"
  mkdir -p "$run/corpus" "$run/artifacts"
  cp fuzz/corpus/"$target"/* "$run/corpus/"
  ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
    "build/fuzz/fuzz/${target}_fuzzer" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$run/artifacts/" "$run/corpus" >"$run/log" 2>&1 || status=$?
  echo "$status" >"$run/status"
  local execs
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$run/log" | tail -n 1)
  echo "fuzz: $target ran $((SECONDS - start)) s, ${execs:-?} execs, corpus $(ls "$run/corpus" | wc -l) inputs"
}
jobs_at_once=$(nproc)
for target in "${targets[@]}"; do
  while (($(jobs -rp | wc -l) >= jobs_at_once)); do wait -n || true; done
  fuzz_one "$target" &
done
wait
failed=()
for target in "${targets[@]}"; do
  run=build/fuzz/runs/$target
  status=$(cat "$run/status" 2>/dev/null || echo missing)
  if [[ $status != 0 ]]; then
    inputs=$(find "$run/artifacts" -type f | sort)
    echo "fuzz: $target FAILED (exit $status); input: ${inputs:-none saved}; log: $run/log" >&2
    grep -m 5 -E 'ERROR: |runtime error: |SUMMARY: |terminate called|what\(\)' "$run/log" >&2 || true
    failed+=("$target")
  fi
done
if ((${#failed[@]})); then
  echo "fuzz: findings in ${failed[*]}; add each input to fuzz/regressions/<target>/ with its fix" >&2
  exit 1
fi
echo "fuzz: ${#targets[@]} targets, ${seconds} s each, no findings"
