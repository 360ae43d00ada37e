#!/usr/bin/env bash
# Builds and installs the Python package in a fresh virtual environment (target/python-venv)
# and runs its tests (python/tests), which compare it with the `rigid` binary built here.
# Extra arguments go to pytest, e.g. `python/test.sh -k sweep`.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet   # target/release/rigid, the binary the tests compare with
venv=target/python-venv
rm -rf "$venv"
python3 -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet ".[test]"
# From python/tests, so `import rigid_sandbox` finds the installed package, not python/rigid_sandbox.
cd python/tests
exec "../../$venv/bin/python" -m pytest -q "$@"
