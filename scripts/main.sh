#!/usr/bin/env bash
# Installs, builds and runs the main job: configs/default.toml (procedural scenes plus the shared scenes
# that are present, every builder against Embree, 1 and 2 threads), then prints its report.
# Rows go to results/default.csv as each cell finishes; the report also goes to results/default.md and,
# as LaTeX, results/default.tex; the plots (matplotlib) to results/plots/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
mkdir -p results
# A fresh file per run of the main job, so the report shows this run only; the previous one is kept.
[[ -s results/default.csv ]] && mv results/default.csv results/default.previous.csv
./build/release/sahbench run configs/default.toml
./build/release/sahbench report results/default.csv | tee results/default.md
./build/release/sahbench report results/default.csv --format latex --output results/default.tex
/usr/bin/python3 scripts/plots.py results/default.csv --out results/plots || echo "plots: see the message above"
