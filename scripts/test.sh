#!/usr/bin/env bash
# Install (or reuse) the environment, then run the lint and the test suite.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
venv=$(bash scripts/setup_env.sh)
export MUJOCO_GL=${MUJOCO_GL:-egl}
"$venv/bin/ruff" check lerobot_ivmc lerobot_policy_ivmc tests benchmarks
"$venv/bin/python" -m pytest -q "$@"
