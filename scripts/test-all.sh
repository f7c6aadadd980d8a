#!/usr/bin/env bash
# Every test of mrfeel, on a fresh machine. Installs what it needs: a Python virtual environment in .venv
# with the pinned JSBSim, rerun-sdk, Ray, maturin, NumPy, pandas and pytest (python/requirements.txt), then runs:
#   1. the JSBSim reference check: the committed tables in scenarios/jsbsim/ regenerate bit for bit;
#   2. cargo test: unit, integration (CLI) and doc tests, including the Rerun read-back through rerun-sdk;
#   3. the Python package: its wheel built by maturin (dev profile, in the target directory cargo test
#      filled, so no dependency is built twice), installed in .venv, and pytest on python/tests/;
#   4. a sweep on a real local Ray cluster against the same sweep in one process, byte for byte.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
# The Python environment downloads while cargo compiles: one waits on the network, the other on the CPU.
echo "== Python environment (.venv) in the background; cargo builds the tests"
env_out="$(mktemp)"
env_err="$(mktemp)"
bash scripts/python-env.sh >"$env_out" 2>"$env_err" &
env_pid=$!
cargo test --locked --no-run
if ! wait "$env_pid"; then
    cat "$env_err" >&2
    exit 1
fi
cat "$env_err" >&2
py="$(cat "$env_out")"
echo "== JSBSim reference tables regenerate bit for bit"
"$py" python/jsbsim_reference.py --check
echo "== cargo test"
cargo test --locked --no-fail-fast
echo "== Python package: build the wheel, install it, pytest python/tests/"
"$py" -m maturin build --quiet --locked --profile dev --features cargo-test-features --out target/wheels-test
"$py" -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps \
    "$(ls -t target/wheels-test/mrfeel-*.whl | head -1)"
# pytest exits 5 when it collects no test: under `set -e` that fails the run, as any non-zero exit does.
MRFEEL_BIN="$PWD/target/debug/mrfeel" "$py" -m pytest -q python/tests/
echo "== A sweep on a local Ray cluster equals one process (scripts/test-ray.sh)"
MRFEEL_BIN="$PWD/target/debug/mrfeel" bash scripts/test-ray.sh
