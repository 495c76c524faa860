#!/usr/bin/env bash
# Install (or reuse) the environment, then run the main job: the demo (`lerobot-ivmc-demo`): the pick_place
# bvmc shipped with the package, on 20 held-out scenes without and with recovery, in a few minutes on a
# CPU; it prints the table and the path of a page with Fig. 3 and a recovery video. Flags pass through,
# e.g. `bash scripts/run.sh --n_episodes=100 --output_dir=outputs/demo100`. The whole study of a task is
# `lerobot-ivmc-pipeline --task=pick_place --preset=lite` (the smoke preset: minutes, untrained policies).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
venv=$(bash scripts/setup_env.sh)
export MUJOCO_GL=${MUJOCO_GL:-egl}
"$venv/bin/lerobot-ivmc-demo" "$@"
