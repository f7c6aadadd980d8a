#!/usr/bin/env python3
"""Independent-truth data for `mrfeel diagnose` (dev tool; the kept checks are tests/independent_truth.rs).

The effects written from the physics in other forms than mrfeel's effect library (Bouc-Wen n = 2, tanh
saturation, +15 %/-10 % yield, damping quadratic in current, preload + linear + cubic spring, 3 kg, heating of
yield and viscosity), on the paper's device: 3 sine groups x 5 constant currents, 4 cycles at 1 kHz, noise.
Used in session 3 to probe the diagnosis before the Rust tests were written; the figures quoted in the
closing note come from it.

Run:  python3 -m venv /tmp/pyenv && /tmp/pyenv/bin/pip install numpy
      /tmp/pyenv/bin/python python/independent_truth.py EFFECTS OUTDIR [SEED]     (EFFECTS: comma-separated)
      target/release/mrfeel diagnose OUTDIR --json
Environment: SCALE=real for a device like the real damper in ../shared/data (80 N + 900 N/A, 2000 N s/m,
0-1 A, groups 10 mm 1 Hz, 2 mm 5 Hz, 20 mm 0.3 Hz, effects scaled to it); K3=0 for a linear spring;
NOISE=<N> for the load-cell noise.
"""
import os
import shutil
import sys

import numpy as np
if os.environ.get("SCALE") == "real":
    FC0, K, C0 = 80.0, 900.0, 2000.0
    GROUPS = [("r10mm1Hz", 0.01, 1.0), ("r2mm5Hz", 0.002, 5.0), ("r20mm0p3Hz", 0.02, 0.3)]
    CURRENTS = [0.0, 0.25, 0.5, 0.75, 1.0]
    # saturation force, current scale, spring preload / rate / cubic, mass, heat constants, noise
    SAT, IMAX, PRE, KS, K3, M, THY, THC, NOISE0 = 1100.0, 1.0, 60.0, 2e4, 2e7, 15.0, 3000.0, 6000.0, 5.0
else:
    FC0, K, C0 = 2.0, 4.83, 60.0
    GROUPS = [("s20mm1Hz", 0.02, 1.0), ("s10mm2p5Hz", 0.01, 2.5), ("s30mm0p4Hz", 0.03, 0.4)]
    CURRENTS = [0.0, 3.5, 7.0, 10.5, 14.0]
    SAT, IMAX, PRE, KS, K3, M, THY, THC, NOISE0 = 80.0, 14.0, 2.0, 250.0, 3e5, 3.0, 420.0, 800.0, 0.15
K3 = float(os.environ.get("K3", K3))
FS, SUB = 1000.0, 20

def simulate(effect, A, f, i, rng, cycles=4):
    n = int(cycles / f * FS)
    t = np.arange(n) / FS
    w = 2 * np.pi * f
    h = 1 / FS / SUB
    z = 1.0 if "hysteresis" in effect.split(",") else 0.0
    T = 0.0
    out = np.zeros(n)
    for k in range(n):
        for s in range(SUB):
            tt = t[k] + s * h
            x = A * np.sin(w * tt); v = A * w * np.cos(w * tt)
            if "hysteresis" in effect.split(","):  # Bouc-Wen n = 2, beta = 1, gamma = 0, A = 1 (no viscous knee)
                x0 = 4e-4
                def r(zz): return (v - abs(v) * zz * abs(zz)) / x0
                k1 = r(z); k2 = r(z + h/2*k1); k3 = r(z + h/2*k2); k4 = r(z + h*k3)
                z = float(np.clip(z + h/6*(k1 + 2*k2 + 2*k3 + k4), -1, 1))
            if "thermal_drift" in effect.split(","):
                fy = (FC0 + K * i) * (1 - T / THY)
                P = max((fy * np.sign(v) + C0 * (1 - T / THC) * v) * v, 0.0)
                T += h * (P - T / 60.0)
        x = A * np.sin(w * t[k]); v = A * w * np.cos(w * t[k]); a = -A * w * w * np.sin(w * t[k])
        fy = FC0 + K * i; c = C0; d = np.sign(v); extra = 0.0
        if "hysteresis" in effect.split(","): d = z
        if "magnetic_saturation" in effect.split(","): fy = FC0 + SAT * np.tanh(K * i / SAT)
        if "sat_exp" in effect.split(","): fy = FC0 + 95.0 * (1 - np.exp(-K * i / 95.0))
        # A constant extra 3 N one way: mathematically a 1.5 N preload plus 1.5 N of symmetric friction.
        if "asym_seal" in effect.split(","): fy = fy + (3.0 if v > 0 else 0.0)
        if "asymmetry" in effect.split(","): fy = fy * (1.15 if v > 0 else 0.9)
        if "current_viscosity" in effect.split(","): c = C0 * (1 + 2 * (i / IMAX) ** 2)
        if "stiffness" in effect.split(","): extra += PRE + KS * x + K3 * x ** 3
        if "inertia" in effect.split(","): extra += M * a
        if "thermal_drift" in effect.split(","): fy = fy * (1 - T / THY); c = c * (1 - T / THC)
        out[k] = fy * d + c * v + extra
    x = A * np.sin(w * t); v = A * w * np.cos(w * t)
    return t, x + rng.normal(0, 2e-6, n), v + rng.normal(0, 2e-4, n), out + rng.normal(0, float(os.environ.get("NOISE", str(NOISE0))), n)

def main():
    effect, outdir, seed = sys.argv[1], sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 1
    rng = np.random.default_rng(seed)
    shutil.rmtree(outdir, ignore_errors=True); os.makedirs(outdir)
    for g, A, f in GROUPS:
        for i in CURRENTS:
            t, x, v, F = simulate(effect, A, f, i, rng)
            with open(os.path.join(outdir, f"{g}_{i:g}A.csv".replace(".", "p", 1) if False else f"{g}_{int(i*10):03d}dA.csv"), "w") as o:
                o.write(f"# source: independent synthetic truth ({effect})\n# sample_rate_hz: {FS:g}\nt_s,x_m,v_m_s,i_a,f_n\n")
                for r in zip(t, x, v, np.full_like(t, i), F):
                    o.write(",".join(repr(float(q)) for q in r) + "\n")
main()
