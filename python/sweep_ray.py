"""Run a sweep plan on a Ray cluster: each shard of `mrfeel sweep` is one Ray task, and the shards are merged
with `mrfeel sweep merge` into the result one process would give, byte for byte.

    mrfeel sweep PLAN --out DIR --ray ADDRESS [--shards N]      (drives this script; the usual way)
    python python/sweep_ray.py PLAN --out DIR --address 127.0.0.1:6379 [--shards 4] [--mrfeel target/debug/mrfeel]

ADDRESS is `auto` (the cluster `ray start` runs on this machine), `HOST:PORT` (`ray start --head` prints it)
or `ray://HOST:10001` (Ray Client). The tasks run the `mrfeel` binary on the cluster's nodes and write their
shards under DIR/shards/K-of-N/, so DIR, the plan and the binary must be where every node sees them (a local
cluster, or a shared file system). A shard that fails is retried by Ray (`--retries`); it resumes from its
journal, so no finished run is run twice.

On stdout, one line per event, for `mrfeel sweep --ray` to follow: `shards N` once the cluster is reached,
then `done K` as each shard finishes (with `--no-merge`, the caller merges the shards itself).
"""

import argparse
import os
import socket
import subprocess
import sys
import time

# How to get Ray, quoted when it is missing.
INSTALL_HINT = (
    "in an mrfeel checkout, `bash scripts/python-env.sh` creates .venv with the pinned ray "
    "(python/requirements.txt); elsewhere, `python3 -m pip install ray==2.60.0` into a Python named by "
    "MRFEEL_PYTHON"
)
# Exit status when Ray cannot be imported.
NO_RAY = 3


def shard_dir(out, k, n):
    """The output directory of shard k of n."""
    return os.path.join(out, "shards", f"{k}-of-{n}")


def run_shard(mrfeel, plan, out, k, n):
    """Run shard k of n; its output directory, or an error naming the shard and what mrfeel said."""
    d = shard_dir(out, k, n)
    cmd = [mrfeel, "sweep", plan, "--out", d, "--shard", f"{k}/{n}", "--jobs", "1"]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"shard {k}/{n}: {' '.join(cmd)} exited {p.returncode}:\n{p.stderr}")
    return d


def listening(address):
    """Whether something listens at a HOST:PORT address (Ray checks `auto` and `ray://` addresses itself,
    but waits minutes on a HOST:PORT where nothing listens)."""
    if address == "auto" or "://" in address:
        return True
    host, _, port = address.rpartition(":")
    try:
        with socket.create_connection((host, int(port)), timeout=5):
            return True
    except (OSError, ValueError):
        return False


def say(line):
    print(line, flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("plan")
    ap.add_argument("--out", required=True, help="merged output directory (shards go to OUT/shards/)")
    ap.add_argument("--address", required=True, help="the Ray cluster: auto, HOST:PORT or ray://HOST:PORT")
    ap.add_argument(
        "--shards", type=int, default=0, help="Ray tasks, one shard each (default: the cluster's CPUs)"
    )
    ap.add_argument("--max-shards", type=int, default=0, help="at most this many shards (the plan's runs)")
    ap.add_argument("--retries", type=int, default=2, help="retries of a failed shard task (default 2)")
    ap.add_argument("--mrfeel", default="mrfeel", help="path of the mrfeel binary on the nodes")
    ap.add_argument(
        "--connect-timeout-s", type=float, default=0.0, help="wait this long for a cluster still starting"
    )
    ap.add_argument("--no-merge", action="store_true", help="leave the shards for the caller to merge")
    a = ap.parse_args()
    if a.shards < 0:
        sys.exit(f"--shards {a.shards}: give at least 1")
    try:
        import ray
    except ImportError as e:
        sys.stderr.write(f"no Ray in the Python {sys.executable} ({e}): {INSTALL_HINT}\n")
        sys.exit(NO_RAY)

    plan = os.path.abspath(a.plan)
    out = os.path.abspath(a.out)
    mrfeel = os.path.abspath(a.mrfeel) if os.sep in a.mrfeel else a.mrfeel
    deadline = time.monotonic() + a.connect_timeout_s
    while True:
        try:
            if not listening(a.address):
                raise ConnectionError("nothing listens there")
            ray.init(address=a.address, logging_level="ERROR", log_to_driver=False)
            break
        except (ConnectionError, RuntimeError) as e:
            if time.monotonic() > deadline:
                sys.stderr.write(f"no Ray cluster at {a.address}: {e} (`ray start --head` starts one)\n")
                sys.exit(1)
            time.sleep(0.5)
    try:
        n = a.shards or max(1, int(ray.cluster_resources().get("CPU", 1)))
        if a.max_shards > 0:
            n = min(n, a.max_shards)
        say(f"shards {n}")
        task = ray.remote(num_cpus=1, max_retries=a.retries, retry_exceptions=True)(run_shard)
        refs = {task.remote(mrfeel, plan, out, k, n): k for k in range(n)}
        pending = list(refs)
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            for r in ready:
                try:
                    ray.get(r)
                except Exception as e:  # the task's error, after its retries: name it and stop
                    sys.stderr.write(f"{e}\n")
                    sys.exit(1)
                say(f"done {refs[r]}")
    finally:
        ray.shutdown()
    if a.no_merge:
        return
    dirs = [shard_dir(out, k, n) for k in range(n)]
    p = subprocess.run([mrfeel, "sweep", "merge", *dirs, "--out", out], capture_output=True, text=True)
    sys.stdout.write(p.stdout)
    if p.returncode != 0:
        sys.exit(f"merge: {p.stderr}")


if __name__ == "__main__":
    main()
