#!/usr/bin/env python3
"""mrfeel from Python, as a notebook would use it: the real MR damper's tests, the diagnosis of what the
plain Bingham model lacks, measured against modelled force, and the model's force on a new motion.

Run from a checkout after `pip install .` (or the test command's .venv):

    python examples/python/quickstart.py [--plot quickstart.png] [--quick]

`--quick` diagnoses one test per protocol (a few seconds) instead of all fifteen.
"""

import argparse
import pathlib

import numpy as np

import mrfeel

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "data" / "utfsm-mr-damper"

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--plot", type=pathlib.Path, help="write measured vs model force here (needs matplotlib)")
parser.add_argument("--quick", action="store_true", help="one test per protocol")
args = parser.parse_args()

# 1. The measured tests: three displacement protocols at five coil currents each (CSV files).
files = sorted(DATA.glob("*.csv"))
if args.quick:
    files = [f for f in files if f.stem.endswith("_1p00A")]
tests = [mrfeel.Measurement.from_csv(f) for f in files]
print(f"{len(tests)} tests, {sum(len(m) for m in tests)} samples; first: {tests[0]!r}")

# 2. What does the Bingham model miss? Each registered effect is tried by the held-out error it removes.
d = mrfeel.diagnose(tests, model="bingham")
print(d)
report = d.to_dict()
print("missing effects:", report["missing"], "-> final model", report["final"]["model"])

# 3. The final model, fitted on every test: its parameters with standard errors and units.
model = d.final_model
for name, p in model.params.items():
    print(f"  {name:24s} {p['value']:12.5g} {p['unit']}")
score = model.score(tests)
print(f"on the tests: NRMSE {score['nrmse']:.4f}, RMSE {score['rmse_n']:.2f} N")

# 4. Measured vs model force on one test, if matplotlib is installed.
if args.plot:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot (pip install matplotlib)")
    else:
        m = tests[-1]
        fig, ax = plt.subplots(1, 2, figsize=(11, 4))
        ax[0].plot(m.t, m.f, label="measured", lw=1)
        ax[0].plot(m.t, model.predict(m), label=model.spec, lw=1)
        ax[0].set(xlabel="time (s)", ylabel="force (N)", title=m.name.split("/")[-1])
        ax[0].legend()
        ax[1].plot(m.v, m.f, ".", ms=1, label="measured")
        ax[1].plot(m.v, model.predict(m), ".", ms=1, label="model")
        ax[1].set(xlabel="velocity (m/s)", ylabel="force (N)", title="force-velocity")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        print(f"wrote {args.plot}")

# 5. The model on a motion never measured: 8 mm at 1.5 Hz, the current stepping from 0.2 A to 0.8 A.
t = np.arange(0.0, 4.0, 1e-3)
x = 0.008 * np.sin(2 * np.pi * 1.5 * t)
i = np.where(t < 2.0, 0.2, 0.8)
f = model.predict(t, x, i)
for lo, hi in ((1.0, 2.0), (3.0, 4.0)):
    w = (t >= lo) & (t < hi)
    print(f"  {i[w][0]:.1f} A: peak force {np.abs(f[w]).max():6.1f} N, rms {np.sqrt(np.mean(f[w] ** 2)):6.1f} N")
