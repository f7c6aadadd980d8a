#!/usr/bin/env bash
# A sweep run on a Ray cluster equals the same sweep run in one process, byte for byte. First, without Ray
# (the project's Python with its site-packages cut off), `mrfeel sweep --ray` must refuse with a message
# naming how to install Ray. Then starts a real local Ray cluster (127.0.0.1 only, 2 CPUs, no dashboard,
# its own temporary directory), runs scenarios/sweeps/paper-feel-small.toml through
# `mrfeel sweep --ray` in 4 shards (the driver python/sweep_ray.py in the checkout's .venv), runs it in one
# process, compares results.parquet, results.csv, runs.jsonl and report.md, and stops the cluster (the
# `ray start --block` it started, by its process id), also on failure.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
py="$(bash scripts/python-env.sh)"
ray="$(dirname "$py")/ray"
mrfeel="${MRFEEL_BIN:-target/debug/mrfeel}"
[ -x "$mrfeel" ] || cargo build --locked --quiet
tmp="$(mktemp -d)"
head_pid=
stop() {
    if [ -n "$head_pid" ]; then
        kill -TERM "$head_pid" 2>/dev/null || true
        wait "$head_pid" 2>/dev/null || true
    fi
    rm -rf "$tmp"
}
trap stop EXIT
plan=scenarios/sweeps/paper-feel-small.toml

# No Ray: a Python that sees only its standard library (-I -S) must give the install hint, not a traceback.
printf '#!/bin/sh\nexec "%s" -I -S "$@"\n' "$py" >"$tmp/python-without-ray"
chmod +x "$tmp/python-without-ray"
if MRFEEL_PYTHON="$tmp/python-without-ray" "$mrfeel" sweep "$plan" --out "$tmp/no-ray" --ray auto \
    >/dev/null 2>"$tmp/no-ray.err"; then
    echo "mrfeel sweep --ray with no Ray succeeded" >&2
    exit 1
fi
if ! grep -q "pip install ray" "$tmp/no-ray.err" || grep -q Traceback "$tmp/no-ray.err"; then
    echo "mrfeel sweep --ray with no Ray: no install hint, or a traceback:" >&2
    cat "$tmp/no-ray.err" >&2
    exit 1
fi

port="$("$py" -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')"
# --block: the head stays in the foreground of this job and takes its Ray processes down when killed.
"$ray" start --head --block --node-ip-address 127.0.0.1 --port "$port" --num-cpus 2 \
    --include-dashboard false --disable-usage-stats --temp-dir "$tmp/ray" >"$tmp/ray-start.log" 2>&1 &
head_pid=$!
# The Python is the checkout's .venv (MRFEEL_PYTHON unset), as the JSBSim bridge finds it.
env -u MRFEEL_PYTHON "$mrfeel" sweep "$plan" --out "$tmp/ray-out" --ray "127.0.0.1:$port" --shards 4 \
    --ray-wait-s 120 >"$tmp/ray.out" 2>"$tmp/ray.err" || {
    cat "$tmp/ray.err" >&2
    exit 1
}
grep -q "the checkout's .venv" "$tmp/ray.err"
grep -q "12 runs in 4 shards on Ray" "$tmp/ray.out"
"$mrfeel" sweep "$plan" --out "$tmp/local" --jobs 2 >/dev/null
for f in results.parquet results.csv runs.jsonl report.md; do
    cmp "$tmp/local/$f" "$tmp/ray-out/$f"
done
echo "mrfeel sweep --ray (4 shards on a local Ray cluster) == one process: results.parquet, results.csv, runs.jsonl, report.md; no Ray: the install hint"
