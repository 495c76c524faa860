#!/usr/bin/env bash
# Install (or reuse) the environment, then run the main job on its embedded default configuration.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
venv=$(bash scripts/setup_env.sh)
export MUJOCO_GL=${MUJOCO_GL:-egl}
"$venv/bin/lerobot-ivmc-experts" --config_path=configs/experts.yaml "$@"
