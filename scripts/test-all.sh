#!/usr/bin/env bash
# Every test of mrfeel, on a fresh machine. Installs what it needs: a Python virtual environment in .venv
# with the pinned JSBSim and rerun-sdk (python/requirements.txt), then runs:
#   1. the JSBSim reference check: the committed tables in scenarios/jsbsim/ regenerate bit for bit;
#   2. cargo test: unit, integration (CLI) and doc tests, including the Rerun read-back through rerun-sdk.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
echo "== Python environment (.venv: jsbsim, rerun-sdk)"
py="$(bash scripts/python-env.sh)"
echo "== JSBSim reference tables regenerate bit for bit"
"$py" python/jsbsim_reference.py --check
echo "== cargo test"
cargo test --locked --no-fail-fast
