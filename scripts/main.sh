#!/usr/bin/env bash
# Installs, builds and runs the main job: every builder and Embree on procedural scenes and on the
# shared scenes that are present, at 1 and 2 threads, with validation. Output goes to stdout and to
# results/main-<date>.txt.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
mkdir -p results
out="results/main-$(date +%Y%m%d-%H%M%S).txt"

scenes=(proc:sphere:tris=200k proc:terrain:tris=200k proc:soup:tris=200k proc:needles:tris=100k
        proc:multiscale:tris=100k)
for name in cornell_box stanford_bunny stanford_dragon_res2 FlightHelmet 2CylinderEngine crytek_sponza; do
  if ./build/release/sahbench list-scenes 2>/dev/null | grep -qx "$name"; then scenes+=("$name"); fi
done

for scene in "${scenes[@]}"; do
  ./build/release/sahbench build --scene "$scene" --builder binned_sah --builder binned_sah:bins=8 \
    --builder sweep_sah --builder embree_medium --builder embree_high --threads 1,2 --reps 5 | tee -a "$out"
  echo | tee -a "$out"
done
echo "main: results written to $out" >&2
