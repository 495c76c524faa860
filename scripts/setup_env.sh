#!/usr/bin/env bash
# Create (or reuse) the project's virtual environment and print its path.
#
# The environment lives outside the clone, keyed on a hash of the dependency spec in pyproject.toml, so
# a second clone or CI run with the same dependencies reuses it (the first install downloads ~8.5 GB of
# CUDA-enabled torch wheels, which run fine on a CPU, and takes a few minutes). The project itself is
# (re)installed editable from this clone every time, which takes seconds.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
python=${PYTHON:-python3.11}
command -v "$python" >/dev/null || python=python3
key=$("$python" - "$root/pyproject.toml" <<'PY'
import hashlib, json, sys, tomllib
project = tomllib.load(open(sys.argv[1], "rb"))["project"]
spec = {"deps": project["dependencies"], "extras": project.get("optional-dependencies", {}), "python": sys.version[:4]}
print(hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:16])
PY
)
venv="${IVMC_VENV_ROOT:-$HOME/.cache/lerobot-ivmc}/venv-$key"
if [ ! -f "$venv/.complete" ]; then
    echo "Creating $venv (first install takes a few minutes)..." >&2
    rm -rf "$venv"
    "$python" -m venv "$venv"
    "$venv/bin/python" -m pip install --quiet --upgrade pip >&2
    "$venv/bin/python" -m pip install --quiet -e "$root[test]" >&2
    touch "$venv/.complete"
else
    "$venv/bin/python" -m pip install --quiet --no-deps -e "$root" >&2
fi
echo "$venv"
