#!/usr/bin/env python3
"""Resample measurement files onto an uneven clock (dev tool; the kept check is
`independent_effects_on_a_jittered_clock_are_fitted_to_the_noise` in tests/independent_truth.rs).

The measurement format asks only for strictly increasing times. This makes such files from files sampled four
times as fast (e.g. `python/independent_truth.py` with FS four times the wanted rate), keeping samples whose
force, displacement and velocity are exact for their own times:

  jitter  the 4th, 8th, ... sample or one of its two neighbours, at random: intervals 0.5-1.5 of the nominal
  drops   every 4th sample, 3 % of them lost at random: some intervals of 2 and 3
  even    every 4th sample (the control: an even grid from the same data)

Run:  env FS=4000 SUB=5 probe-env/bin/python python/independent_truth.py inertia RAW 2
      probe-env/bin/python python/resample_uneven.py RAW OUT 2 jitter
      target/release/mrfeel diagnose OUT --json
The `sample_rate_hz` metadata line is dropped (there is no one rate); other lines are kept.
"""
import os
import shutil
import sys

import numpy as np

def main():
    if len(sys.argv) != 5 or sys.argv[4] not in ("jitter", "drops", "even"):
        sys.exit("usage: resample_uneven.py IN_DIR OUT_DIR SEED jitter|drops|even")
    src, dst, seed, mode = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
    rng = np.random.default_rng(seed)
    shutil.rmtree(dst, ignore_errors=True)
    os.makedirs(dst)
    for name in sorted(os.listdir(src)):
        lines = open(os.path.join(src, name)).read().splitlines()
        meta = [l for l in lines if l.startswith("#")]
        header = lines[len(meta)]
        data = np.array([[float(q) for q in l.split(",")] for l in lines[len(meta) + 1:]])
        n = len(data)
        if mode == "jitter":
            base = np.arange(1, n // 4 - 1) * 4
            idx = np.concatenate([[0], base + rng.integers(-1, 2, base.size)])
        else:
            idx = np.arange(0, n, 4)
            if mode == "drops":
                keep = rng.random(idx.size) > 0.03
                keep[0] = True
                idx = idx[keep]
        meta = [m for m in meta if not m.startswith("# sample_rate_hz")]
        with open(os.path.join(dst, name), "w") as o:
            o.write("\n".join(meta + [header]) + "\n")
            for row in data[idx]:
                o.write(",".join(repr(float(q)) for q in row) + "\n")

main()
