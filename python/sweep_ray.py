"""Run a sweep plan on a Ray cluster: each shard of `mrfeel sweep` is one Ray task, and the shards are merged
with `mrfeel sweep merge` into the result one process would give, byte for byte.

    python python/sweep_ray.py PLAN --out DIR --address 127.0.0.1:6379 --shards 4 [--mrfeel target/debug/mrfeel]

The tasks run the `mrfeel` binary on the cluster's nodes and write their shards under DIR/shards/, so DIR and
the plan must be on a file system every node sees (a local cluster, or NFS). A shard that fails is retried
by Ray (`--retries`); the shard resumes from its journal, so no finished run is run twice.
"""

import argparse
import os
import subprocess
import sys
import time


def run_shard(mrfeel, plan, out, k, n):
    """Run shard k of n; its output directory, or an error naming the shard and what mrfeel said."""
    d = os.path.join(out, "shards", f"{k}-of-{n}")
    cmd = [mrfeel, "sweep", plan, "--out", d, "--shard", f"{k}/{n}", "--jobs", "1"]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"shard {k}/{n}: {' '.join(cmd)} exited {p.returncode}:\n{p.stderr}")
    return d


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("plan")
    ap.add_argument("--out", required=True, help="merged output directory (shards go to OUT/shards/)")
    ap.add_argument("--address", required=True, help="the Ray cluster (ray start --head prints it)")
    ap.add_argument("--shards", type=int, default=4, help="Ray tasks, one shard each (default 4)")
    ap.add_argument("--retries", type=int, default=2, help="retries of a failed shard task (default 2)")
    ap.add_argument("--mrfeel", default="mrfeel", help="path of the mrfeel binary on the nodes")
    ap.add_argument(
        "--connect-timeout-s", type=float, default=0.0, help="wait this long for a cluster still starting"
    )
    a = ap.parse_args()
    if a.shards < 1:
        sys.exit(f"--shards {a.shards}: give at least 1")
    import ray

    plan = os.path.abspath(a.plan)
    out = os.path.abspath(a.out)
    mrfeel = os.path.abspath(a.mrfeel) if os.sep in a.mrfeel else a.mrfeel
    deadline = time.monotonic() + a.connect_timeout_s
    while True:
        try:
            ray.init(address=a.address, logging_level="ERROR", log_to_driver=False)
            break
        except (ConnectionError, RuntimeError):
            if time.monotonic() > deadline:
                raise
            time.sleep(0.5)
    try:
        task = ray.remote(num_cpus=1, max_retries=a.retries)(run_shard)
        dirs = ray.get([task.remote(mrfeel, plan, out, k, a.shards) for k in range(a.shards)])
    finally:
        ray.shutdown()
    p = subprocess.run([mrfeel, "sweep", "merge", *dirs, "--out", out], capture_output=True, text=True)
    sys.stdout.write(p.stdout)
    if p.returncode != 0:
        sys.exit(f"merge: {p.stderr}")


if __name__ == "__main__":
    main()
