#!/usr/bin/env bash
# Installs, builds and runs the whole test suite (GoogleTest through ctest). Shared scenes are used
# when ../shared/scenes (or SAHBENCH_SCENE_PATH) has them; tests that need one skip with a message. The
# local Slurm test (label slurm: installs packages, starts daemons) runs from .ci/run instead.
set -euo pipefail
cd "$(dirname "$0")/.."
SAHBENCH_PRESET=${SAHBENCH_PRESET:-release} bash scripts/setup.sh
ctest --preset "${SAHBENCH_PRESET:-release}" -j "$(nproc)" -LE slurm
