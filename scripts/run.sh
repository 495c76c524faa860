#!/usr/bin/env bash
# Install (or reuse) the environment, then run the main job: the study pipeline on its embedded default
# (the `smoke` preset on the push task: every stage end to end in minutes on a CPU, local folders, no
# network). Any pipeline flag can be added, e.g. `bash scripts/run.sh --task=pick_place --preset=lite`.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
venv=$(bash scripts/setup_env.sh)
export MUJOCO_GL=${MUJOCO_GL:-egl}
"$venv/bin/lerobot-ivmc-pipeline" --task=push --preset=smoke "$@"
