#!/usr/bin/env bash
# Install (or reuse) the environment, then run the lint and the test suite.
#
# The suite runs in IVMC_TEST_WORKERS pytest-xdist workers (default: one per core, each test file's tests
# spread over them), each worker's torch given its share of the cores (tests/conftest.py); the slowest tests
# are listed at the end. IVMC_TEST_WORKERS=0 runs it in one process.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
venv=$(bash scripts/setup_env.sh)
export MUJOCO_GL=${MUJOCO_GL:-egl}
workers=${IVMC_TEST_WORKERS:-$(nproc)}
"$venv/bin/ruff" check lerobot_ivmc lerobot_policy_ivmc tests benchmarks diagnostics
"$venv/bin/python" -m pytest -q -n "$workers" --dist worksteal --durations=15 "$@"
