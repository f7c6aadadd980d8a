#!/usr/bin/env bash
# A sweep run on a Ray cluster equals the same sweep run in one process, byte for byte. Starts a real local
# Ray cluster (127.0.0.1 only, 2 CPUs, no dashboard, its own temporary directory), runs
# scenarios/sweeps/paper-feel-small.toml through python/sweep_ray.py in 4 shards, runs it in one process,
# compares results.parquet, results.csv and runs.jsonl, and stops the cluster (the `ray start --block` it
# started, by its process id), also on failure.
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
port="$("$py" -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')"
# --block: the head stays in the foreground of this job and takes its Ray processes down when killed.
"$ray" start --head --block --node-ip-address 127.0.0.1 --port "$port" --num-cpus 2 \
    --include-dashboard false --disable-usage-stats --temp-dir "$tmp/ray" >"$tmp/ray-start.log" 2>&1 &
head_pid=$!
plan=scenarios/sweeps/paper-feel-small.toml
"$py" python/sweep_ray.py "$plan" --out "$tmp/ray-out" --address "127.0.0.1:$port" --shards 4 \
    --mrfeel "$mrfeel" --connect-timeout-s 120 >/dev/null
"$mrfeel" sweep "$plan" --out "$tmp/local" --jobs 2 >/dev/null
for f in results.parquet results.csv runs.jsonl; do
    cmp "$tmp/local/$f" "$tmp/ray-out/$f"
done
echo "Ray sweep (4 shards on a local cluster) == one process: results.parquet, results.csv, runs.jsonl"
