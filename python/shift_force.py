#!/usr/bin/env python3
"""Copies of a directory of measurement CSVs with the force moved against the motion (dev tool; numpy).

`f_n` is compared `MS` milliseconds later than the motion (negative: earlier): each file's force column is
moved by round(MS * fs / 1000) samples of its own clock, the rows left without a partner trimmed, and the
time restarted at 0. Header lines are kept. Used to ask whether a delay between the channels is left
after the acquisition chain (docs/explanation/ident.md):

    for ms in -10 -5 0 5 10; do
        python python/shift_force.py data/utfsm-mr-damper $ms shift$ms
        target/release/mrfeel fit shift$ms --model bingham+hysteresis --heldout
    done
"""

import glob
import os
import sys

import numpy as np


def main():
    src, ms, out = sys.argv[1], float(sys.argv[2]), sys.argv[3]
    os.makedirs(out, exist_ok=True)
    for path in sorted(glob.glob(os.path.join(src, "*.csv"))):
        with open(path) as fh:
            lines = fh.read().splitlines()
        head = [ln for ln in lines if ln.startswith("#")]
        columns = lines[len(head)]
        d = np.loadtxt(path, delimiter=",", comments="#", skiprows=len(head) + 1)
        s = int(round(ms * 1e-3 / np.median(np.diff(d[:, 0]))))
        if s > 0:
            d = np.column_stack([d[:-s, :4], d[s:, 4]])
        elif s < 0:
            d = np.column_stack([d[-s:, :4], d[:s, 4]])
        d[:, 0] -= d[0, 0]
        with open(os.path.join(out, os.path.basename(path)), "w") as fh:
            fh.write("\n".join(head + [columns]) + "\n")
            for r in d:
                fh.write("%.6f,%.7g,%.7g,%.4g,%.6g\n" % tuple(r))


if __name__ == "__main__":
    main()
