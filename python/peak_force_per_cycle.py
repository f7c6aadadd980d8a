#!/usr/bin/env python3
"""Mean force at peak speed, per half cycle, for each test of a directory (dev tool; standard library only).

A damper that is the same device from cycle to cycle gives the same figure every half cycle of a
constant-current sine test. A drift in these figures is a change of the device during the test (temperature,
particle distribution, ...), which no model of the force as a function of the motion and the current can
follow, and which sets a floor under the error of any such model.

At the end, per amplitude/frequency group: the mean force at peak speed (both directions, every half cycle)
for each current, and its rise from one current to the next. A law of the current shared by the device's
tests would rise alike in every group at the same speed.

Run:  python3 python/peak_force_per_cycle.py data/utfsm-mr-damper
"""

import csv
import glob
import os
import sys


def runs(flags):
    """Index lists of consecutive True entries."""
    out, cur = [], []
    for k, f in enumerate(flags):
        if f:
            cur.append(k)
        elif cur:
            out.append(cur)
            cur = []
    if cur:
        out.append(cur)
    return out


def main():
    d = sys.argv[1] if len(sys.argv) > 1 else "data/utfsm-mr-damper"
    table = {}
    print(f"{'test':<24} mean |force| N at |v| > 0.9 max|v|, each half cycle: v > 0 | v < 0")
    for path in sorted(glob.glob(os.path.join(d, "*.csv"))):
        with open(path) as fh:
            rows = list(csv.DictReader(ln for ln in fh if not ln.startswith("#")))
        v = [float(r["v_m_s"]) for r in rows]
        f = [float(r["f_n"]) for r in rows]
        vmax = max(abs(x) for x in v)
        pos = [sum(f[k] for k in g) / len(g) for g in runs([x > 0.9 * vmax for x in v])]
        neg = [-sum(f[k] for k in g) / len(g) for g in runs([x < -0.9 * vmax for x in v])]
        name = os.path.basename(path)[:-4]
        group, _, current = name.rpartition("_")
        table.setdefault(group, []).append((current, sum(pos + neg) / len(pos + neg), vmax))
        print(f"{name:<24} " + " ".join(f"{p:5.0f}" for p in pos[:12]) + " | " + " ".join(f"{p:5.0f}" for p in neg[:12]))

    print("\nper group, mean |force| N at peak speed for each current, and its rise from one current to the next")
    for group, rows in table.items():
        forces = [f for _, f, _ in rows]
        rises = [b - a for a, b in zip(forces, forces[1:])]
        print(
            f"{group:<12} peak speed {max(v for _, _, v in rows):.3f} m/s  "
            + " ".join(f"{c}:{f:5.0f}" for c, f, _ in rows)
            + "  rises "
            + " ".join(f"{r:4.0f}" for r in rises)
        )


if __name__ == "__main__":
    main()
