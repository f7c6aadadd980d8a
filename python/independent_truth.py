#!/usr/bin/env python3
"""Independent-truth data for `mrfeel diagnose` (dev tool; the kept checks are tests/independent_truth.rs).

The effects written from the physics in other forms than mrfeel's effect library (Bouc-Wen n = 2, tanh
saturation, +15 %/-10 % yield, damping quadratic in current, preload + linear + cubic spring, 3 kg, heating of
yield and viscosity), on the paper's device: 3 sine groups x 5 constant currents, 4 cycles at 1 kHz, noise.
The protocol options below make data like an outside checker's (other rates, waveforms, no velocity
channel).

Effects outside mrfeel's vocabulary (no finite list of named effects covers them; `mrfeel diagnose` must
find a term for them or say that structure is left, tests/discovery.rs):
  drag         turbulent orifice flow: F += CD v|v|
  gas_spring   an accumulator's gas compressed adiabatically: F += P0A ((L / (L - x))^1.4 - 1)
  yield_lag    the yield force builds up after each reversal with a time constant: the direction function
               sgn v through a first-order lag of TAU_Y
  stribeck     seal friction that falls from its static to its kinetic level with speed:
               F += FST sgn v exp(-(v / VST)^2) (the excess of static over kinetic friction)
  backlash     free play of half-width BL in the linkage: the piston stops while the rod crosses the gap
               (the gap g = x - x_piston stays in [-BL, BL]) and no damper force is carried inside it
  end_friction a seal rubbing harder near the stroke ends: F += FE sgn v (x / XE)^4
  lugre        LuGre seal friction with bristle stiffness S0 and damping S1 and a Stribeck curve from FLS
               (static) to FLC (kinetic) over VLS: dz/dt = v - S0 |v| z / g(v), F += S0 z + S1 dz/dt
  ripple       a force ripple periodic in position (a ball screw's lead or a detent): F += FR sin(2 pi x / PR)
  compress     fluid compressibility: a spring KF in series between the rod and a Bingham piston; the
               force F_d obeys dF_d/dt = KF (v - v_p), v_p = 0 while |F_d| <= f_y, else (F_d - f_y sgn F_d) / c
  cavitation   on extension (F > 0) the rebound chamber's pressure cannot fall below the vapour pressure,
               so the positive force is capped softly: F <- F / (1 + (F / FCAV)^4)^(1/4)
  shear_thin   a shear-thinning fluid (Herschel-Bulkley): the viscous force c v becomes
               c V0 sgn v (|v| / V0)^HB_N, equal to it at V0 = 0.05 m/s (HB_N default 0.5)
  slow_field   a coil field whose time constant grows with the current (eddy currents and the iron's
               rising reluctance): di_f/dt = (i - i_f) / (TAUF (1 + 4 (i_f / IMAX)^2)), the yield force made
               by i_f; with constant currents the field is settled, so it shows under STEPS=1 only

A second device of another make (BROADBAND below), the way MR dampers are characterised in the field:
  broadband    `independent_truth.py broadband OUTDIR [SEED]` writes RECORDS files OUTDIR/recordR.csv (seeds
               SEED, SEED+1, ...): a modified Bouc-Wen damper (Spencer, Dyke, Sain & Carlson, J. Eng. Mech.
               123(3), 1997, Eq. 9-12 and Table 1) at another force scale and stroke than the paper's, driven
               by band-limited random displacement and a current command switched between random levels for
               the first half of each record and varying continuously for the second, at 3 kHz, without a
               velocity channel. Environment: DUR (s, default 20), FS (default 3000), RECORDS (default 2),
               NOISE (N, default 4), CLIP (N: a load cell of that range, the force stuck at +-CLIP past it),
               SAT=1 (the yield force's rise with current saturating, tanh, as a real fluid's does: the
               published form no longer exact), SUB (RK4 substeps per sample, default 8).

Run:  python3 -m venv probe-env && probe-env/bin/pip install numpy
      probe-env/bin/python python/independent_truth.py EFFECTS OUTDIR [SEED]     (EFFECTS: comma-separated)
      target/release/mrfeel diagnose OUTDIR --json
Environment (all optional):
  SCALE=real       a device like the real damper in data/ (80 N + 900 N/A, 2000 N s/m, 0-1 A,
                   groups 10 mm 1 Hz, 2 mm 5 Hz, 20 mm 0.3 Hz, effects scaled to it)
  K3=<N/m^3>       cubic spring term (K3=0: a linear spring)
  NOISE=<N>        load-cell noise (standard deviation)
  FS=<Hz>          sample rate (default 1000)
  CYCLES=<n>       cycles of each group's base frequency (default 4)
  WAVE=sine|triangle|multisine|mix
                   triangle: constant-speed strokes whose corners are rounded over 5 % of the period each
                   (velocity turns as a half sine, so acceleration stays finite and continuous);
                   multisine: 2 (1st, 3rd group) or 3 (2nd) sines at 1, 2.3 and 3.9 x the group's frequency,
                   weighted for about equal velocity, scaled so the peak displacement is the group's amplitude;
                   mix: group 1 sine, group 2 triangle, group 3 multisine. x, v and a are analytic in all.
  NOVEL=1          files without the v_m_s column (velocity left to mrfeel's differentiator)
  CURRENTS=a,b,..  the constant currents in A (default 0, 3.5, 7, 10.5, 14; real scale 0 .. 1 in 0.25)
  GROUPS=A:f,..    amplitude (m) : frequency (Hz) groups in place of the default three
  T0=<s>           time of the first sample (default 0)
  STEPS=1          one file per group, the current stepping at once through CURRENTS (CYCLES cycles at each)
  LAG=<s>          a coil lag of this time constant between the logged current and the force (default none:
                   the force at a sample is made by that sample's current)
  LAGAFTER=1       with LAG: the current logged at a sample acts after it (a DAQ that reads, then writes);
                   default: it acts over the interval before its sample (already in force at it)
  SUB=<n>          integration substeps per sample (default 20; 5 at FS=4000 is the same step as 20 at
                   1000, for files that python/resample_uneven.py thins to an uneven 1 kHz clock)
  (bash keeps its own GROUPS array: pass it as `env GROUPS=0.015:1.5,0.008:3 python3 ...`)
The force at t[k] is formed from the states (Bouc-Wen z, heat) at t[k], and they are then integrated over the
sample. Integrating first would make the force use z(t[k] + 1/FS), one sample ahead, which on triangle tests at
500 Hz without a velocity channel draws a false `inertia` beside hysteresis and stiffness (mrfeel's
acceleration term takes up the offset).
"""
import math
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
    CD, P0A, LGAS, TAU_Y = 8e4, 150.0, 0.04, 0.01
else:
    FC0, K, C0 = 2.0, 4.83, 60.0
    GROUPS = [("s20mm1Hz", 0.02, 1.0), ("s10mm2p5Hz", 0.01, 2.5), ("s30mm0p4Hz", 0.03, 0.4)]
    CURRENTS = [0.0, 3.5, 7.0, 10.5, 14.0]
    SAT, IMAX, PRE, KS, K3, M, THY, THC, NOISE0 = 80.0, 14.0, 2.0, 250.0, 3e5, 3.0, 420.0, 800.0, 0.15
    CD, P0A, LGAS, TAU_Y = 1000.0, 15.0, 0.05, 0.01
K3 = float(os.environ.get("K3", K3))
FS, SUB = float(os.environ.get("FS", "1000")), int(os.environ.get("SUB", "20"))
CYCLES = float(os.environ.get("CYCLES", "4"))
WAVE = os.environ.get("WAVE", "sine")
NOVEL = os.environ.get("NOVEL", "0") == "1"
T0 = float(os.environ.get("T0", "0"))
if "CURRENTS" in os.environ:
    CURRENTS = [float(c) for c in os.environ["CURRENTS"].split(",")]
if "GROUPS" in os.environ:
    GROUPS = [(f"g{float(A) * 1000:g}mm{float(f):g}Hz".replace(".", "p"), float(A), float(f))
              for A, f in (g.split(":") for g in os.environ["GROUPS"].split(","))]
ROUND = 0.05  # triangle: share of the period over which each corner is rounded
MULTI = [(1.0, 1.0, 0.0), (2.3, 0.45, 1.1), (3.9, 0.25, 2.3)]  # multisine: frequency ratio, weight, phase

def motion(wave, A, f, gi):
    """Analytic displacement, velocity and acceleration of group gi, as a function of time (scalar or array)."""
    w = 2 * np.pi * f
    if wave == "mix":
        wave = ["sine", "triangle", "multisine"][gi % 3]
    if wave == "sine":  # the expressions of the original script, so that the default output keeps its bits
        return lambda tt: (A * np.sin(w * tt), A * w * np.cos(w * tt), -A * w * w * np.sin(w * tt))
    if wave == "triangle":
        r = ROUND
        v0 = A * f / (0.25 - r / 2 + r / np.pi)  # stroke speed for a peak of A after the rounded corner
        def tri(tt):
            ph = np.mod(np.asarray(tt, dtype=float) * f, 1.0)
            sg = np.where(ph < 0.5, 1.0, -1.0); p = np.mod(ph, 0.5)  # half-wave symmetry
            u = (p - 0.25) / (r / 2)                                   # -1..1 across the corner
            xc = A + v0 * (r / 2) / f * (2 / np.pi) * (np.cos(np.pi * u / 2) - 1)
            x = np.where(p < 0.25 - r / 2, v0 * p / f, np.where(p > 0.25 + r / 2, v0 * (0.5 - p) / f, xc))
            v = np.where(np.abs(u) >= 1, np.where(u < 0, v0, -v0), -v0 * np.sin(np.pi * np.clip(u, -1, 1) / 2))
            a = np.where(np.abs(u) >= 1, 0.0, -v0 * np.pi * f / r * np.cos(np.pi * np.clip(u, -1, 1) / 2))
            return sg * x, sg * v, sg * a
        return tri
    if wave == "multisine":
        comps = MULTI[:3 if gi % 2 else 2]
        def raw(tt):
            tt = np.asarray(tt, dtype=float)
            x = sum(c * np.sin(w * k * tt + p) for k, c, p in comps)
            v = sum(c * w * k * np.cos(w * k * tt + p) for k, c, p in comps)
            a = sum(-c * (w * k) ** 2 * np.sin(w * k * tt + p) for k, c, p in comps)
            return x, v, a
        s = A / np.max(np.abs(raw(np.linspace(0.0, CYCLES / f, 200001))[0]))
        return lambda tt: tuple(s * q for q in raw(tt))
    sys.exit(f"WAVE={wave}: not one of sine, triangle, multisine, mix")

def simulate(effect, A, f, i, rng, gi=0, cycles=CYCLES):
    """One test; i is the constant current, or a list of levels stepped through, `cycles` cycles at each."""
    levels = None if np.isscalar(i) else list(i)
    if levels is not None:
        cycles = cycles * len(levels)
    n = int(cycles / f * FS)
    t = np.arange(n) / FS
    kin = motion(WAVE, A, f, gi)
    h = 1 / FS / SUB
    z = (1.0 if kin(0.0)[1] >= 0 else -1.0) if "hysteresis" in effect.split(",") else 0.0
    y = np.sign(kin(0.0)[1])  # yield_lag's lagged direction, settled at the start
    stateful = any(e in effect.split(",") for e in ("hysteresis", "thermal_drift", "yield_lag"))
    nov = novel_init(effect, kin, i if levels is None else levels[0]); stateful = stateful or nov["stateful"]
    T = 0.0
    out = np.zeros(n)
    lag = float(os.environ.get("LAG", "0")); after = os.environ.get("LAGAFTER") == "1"
    def level(k): return i if levels is None else levels[min(int(k * len(levels) / n), len(levels) - 1)]
    ic = level(0)  # coil current, settled on the first command
    if WAVE != "sine":  # whole arrays at once (the other waves' formulas are slow per scalar)
        VS = kin(t[:, None] + np.arange(SUB) * h)[1]; XVA = kin(t)
    for k in range(n):
        if levels is not None:
            i = levels[min(int(k * len(levels) / n), len(levels) - 1)]
        cmd = level(k) if after else level(min(k + 1, n - 1))  # in force over (t[k], t[k+1]]
        if lag > 0: i = ic
        x, v, a = kin(t[k]) if WAVE == "sine" else (XVA[0][k], XVA[1][k], XVA[2][k])
        fy = FC0 + K * i; c = C0; d = np.sign(v); extra = 0.0
        if "hysteresis" in effect.split(","): d = z
        if "yield_lag" in effect.split(","): d = y
        if "drag" in effect.split(","): extra += CD * v * abs(v)
        if "gas_spring" in effect.split(","): extra += P0A * ((LGAS / (LGAS - x)) ** 1.4 - 1.0)
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
        if nov["on"]: out[k] = novel_force(nov, out[k], fy, c, d, extra, x, v, i)
        if lag > 0: ic = cmd + (ic - cmd) * np.exp(-1 / FS / lag)
        for s in range(SUB if stateful else 0):
            tt = t[k] + s * h
            v = kin(tt)[1] if WAVE == "sine" else VS[k, s]
            if "hysteresis" in effect.split(","):  # Bouc-Wen n = 2, beta = 1, gamma = 0, A = 1 (no viscous knee)
                x0 = 4e-4
                def r(zz): return (v - abs(v) * zz * abs(zz)) / x0
                k1 = r(z); k2 = r(z + h/2*k1); k3 = r(z + h/2*k2); k4 = r(z + h*k3)
                z = float(np.clip(z + h/6*(k1 + 2*k2 + 2*k3 + k4), -1, 1))
            if "yield_lag" in effect.split(","):
                y += (1 - np.exp(-h / TAU_Y)) * (np.sign(v) - y)
            if "thermal_drift" in effect.split(","):
                fy = (FC0 + K * i) * (1 - T / THY)
                P = max((fy * np.sign(v) + C0 * (1 - T / THC) * v) * v, 0.0)
                T += h * (P - T / 60.0)
            if nov["stateful"]: novel_step(nov, v, i, h)
    x, v, _ = kin(t)
    if levels is not None:
        i = np.array([levels[min(int(k * len(levels) / n), len(levels) - 1)] for k in range(n)])
    return i, t, x + rng.normal(0, 2e-6, n), v + rng.normal(0, 2e-4, n), out + rng.normal(0, float(os.environ.get("NOISE", str(NOISE0))), n)

def main():
    effect, outdir, seed = sys.argv[1], sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 1
    rng = np.random.default_rng(seed)
    shutil.rmtree(outdir, ignore_errors=True); os.makedirs(outdir)
    for gi, (g, A, f) in enumerate(GROUPS):
        for i in ([CURRENTS] if os.environ.get("STEPS") == "1" else CURRENTS):
            I, t, x, v, F = simulate(effect, A, f, i, rng, gi)
            I = np.full_like(t, i) if np.isscalar(I) else I
            t = t + T0 if T0 else t
            cols = [t, x, I, F] if NOVEL else [t, x, v, I, F]
            name = f"{g}_steps.csv" if not np.isscalar(i) else f"{g}_{int(i*10):03d}dA.csv"
            with open(os.path.join(outdir, name), "w") as o:
                o.write(f"# source: independent synthetic truth ({effect})\n# sample_rate_hz: {FS:g}\n"
                        + ("t_s,x_m,i_a,f_n\n" if NOVEL else "t_s,x_m,v_m_s,i_a,f_n\n"))
                for r in zip(*cols):
                    o.write(",".join(repr(float(q)) for q in r) + "\n")

# The effects stribeck .. slow_field of the docstring: their constants, state and force live in functions of
# their own, so that the output of the effects above stays bit for bit the same.
if os.environ.get("SCALE") == "real":
    FST, VST, BL, FE, XE, FR, PR = 60.0, 0.004, 3e-4, 80.0, 0.02, 25.0, 0.004
    S0, S1, FLS, FLC, VLS, KF, FCAV, TAUF = 1e6, 3000.0, 90.0, 50.0, 0.004, 2e6, 900.0, 0.01
else:
    FST, VST, BL, FE, XE, FR, PR = 4.0, 0.01, 3e-4, 6.0, 0.03, 1.0, 0.004
    S0, S1, FLS, FLC, VLS, KF, FCAV, TAUF = 1e5, 100.0, 5.0, 3.0, 0.005, 1e5, 60.0, 0.01
NOVEL_EFFECTS = ("stribeck", "backlash", "end_friction", "lugre", "ripple", "compress", "cavitation",
                 "slow_field", "shear_thin")
HB_N = float(os.environ.get("HB_N", "0.5"))

def novel_init(effect, kin, i0):
    """The state of the later effects at the first sample (settled as if the motion had run before)."""
    on = [e for e in effect.split(",") if e in NOVEL_EFFECTS]
    v0 = float(kin(0.0)[1])
    d0 = np.sign(v0) if v0 != 0 else 1.0
    return {"on": on, "stateful": any(e in on for e in ("backlash", "lugre", "compress", "slow_field")),
            "g": BL * d0,                                   # backlash: the rod leads the piston by the gap
            "z": d0 * (FLC + (FLS - FLC) * np.exp(-(v0 / VLS) ** 2)) / S0,  # lugre: bristles at steady state
            "fd": None,                                     # compress: set from the first sample's force
            "fy": FC0 + K * i0, "c": C0,                     # compress: the Bingham element's yield and c
            "if": i0}                                       # slow_field: the settled field's current

def novel_force(st, f, fy, c, d, extra, x, v, i):
    """The force at a sample with the later effects, from `f` (the force of the effects above)."""
    on = st["on"]
    if "slow_field" in on:
        f += K * (st["if"] - i) * d
        fy = fy + K * (st["if"] - i)
    if "backlash" in on:  # engaged only at a gap's end with the rod pushing outward
        g = st["g"]
        engaged = (g >= BL and v > 0) or (g <= -BL and v < 0)
        f = f if engaged else extra
    if "compress" in on:
        if st["fd"] is None:
            st["fd"] = fy * d + c * v
        st["fy"], st["c"] = fy, c
        f = st["fd"] + extra
    if "shear_thin" in on:
        f += c * 0.05 * np.sign(v) * (abs(v) / 0.05) ** HB_N - c * v
    if "stribeck" in on:
        f += FST * np.sign(v) * np.exp(-(v / VST) ** 2)
    if "end_friction" in on:
        f += FE * np.sign(v) * (x / XE) ** 4
    if "lugre" in on:
        z = st["z"]; gv = FLC + (FLS - FLC) * np.exp(-(v / VLS) ** 2)
        f += S0 * z + S1 * (v - S0 * abs(v) * z / gv)
    if "ripple" in on:
        f += FR * np.sin(2 * np.pi * x / PR)
    if "cavitation" in on and f > 0:
        f = f / (1 + (f / FCAV) ** 4) ** 0.25
    return f

def novel_step(st, v, i, h):
    """Integrate the later effects' states over one substep h at rod velocity v and logged current i."""
    on = st["on"]
    if "backlash" in on:
        st["g"] = float(np.clip(st["g"] + h * v, -BL, BL))
    if "lugre" in on:
        gv = FLC + (FLS - FLC) * np.exp(-(v / VLS) ** 2)
        a = S0 * abs(v) / gv  # exact for the linear ODE over the substep (stiff at S0 |v| / g ~ 1e4 1/s)
        zs = v / a if a > 0 else 0.0
        st["z"] = zs + (st["z"] - zs) * np.exp(-a * h) if a > 0 else st["z"] + h * v
    if "compress" in on and st["fd"] is not None:
        fd, fy, c = st["fd"], st["fy"], st["c"]
        vp = 0.0 if abs(fd) <= fy else (fd - fy * np.sign(fd)) / c
        st["fd"] = fd + h * KF * (v - vp)
    if "slow_field" in on:
        st["if"] += h * (i - st["if"]) / (TAUF * (1 + 4 * (st["if"] / IMAX) ** 2))

# The second device (`broadband`): Spencer et al. 1997's modified Bouc-Wen model, written from the paper's
# equations. The paper's Table 1 (cm, V) scaled to a damper of FSCALE times the force over LSCALE times the
# stroke: forces per length x FSCALE / LSCALE, lengths x LSCALE, Bouc-Wen beta and gamma / LSCALE^2; the command
# in A, 1 A standing for the paper's VPERA volts.
FSCALE, LSCALE, VPERA = 0.6, 0.4, 2.0
BW = dict(aa=140e2, ab=695e2, c0a=21.0e2, c0b=3.50e2, c1a=283e2, c1b=2950e2, k0=46.9e2, k1=5.00e2,
          x0=14.3e-2, beta=363e4, gamma=363e4, A=301.0, n=2.0, eta=190.0)

def bw_params():
    p = dict(BW)
    for k in ("aa", "c0a", "c1a", "k0", "k1"):
        p[k] *= FSCALE / LSCALE
    for k in ("ab", "c0b", "c1b"):
        p[k] *= FSCALE / LSCALE * VPERA
    p["x0"] *= LSCALE
    p["beta"] /= LSCALE ** 2
    p["gamma"] /= LSCALE ** 2
    return p

def band_limited(rng, dur, f_lo, f_hi, comps, slope):
    """A random multisine: `comps` components at frequencies uniform in [f_lo, f_hi], random phases, amplitude
    proportional to f^slope; returns the function t -> (s, ds/dt, d2s/dt2), normalised to a peak of 1."""
    f = np.sort(rng.uniform(f_lo, f_hi, comps)); ph = rng.uniform(0, 2 * np.pi, comps)
    a = f ** slope * rng.uniform(0.5, 1.5, comps)
    w = 2 * np.pi * f
    tt = np.linspace(0.0, dur, int(dur * 400) + 1)
    peak = np.max(np.abs(np.sin(np.outer(tt, w) + ph) @ a))
    a = a / peak
    def sig(t):
        arg = np.multiply.outer(np.asarray(t, dtype=float), w) + ph
        return np.sin(arg) @ a, np.cos(arg) @ (a * w), -(np.sin(arg) @ (a * w * w))
    return sig

def broadband_record(rng):
    dur, fs = float(os.environ.get("DUR", "20")), float(os.environ.get("FS", "3000"))
    sub = int(os.environ.get("SUB", "8"))
    n = int(dur * fs); t = np.arange(n) / fs
    # Displacement: 0.2-12 Hz, a roughly flat velocity spectrum, peak 10 mm (the paper tested at +-15 mm).
    xs = band_limited(rng, dur, 0.2, 12.0, 60, -1.0)
    stroke = 0.025 * LSCALE
    # Command: random levels in 0-1 A held 0.2-1.2 s for the first half, then a slow random 0-0.8 Hz signal.
    edges = [0.0]
    while edges[-1] < dur / 2:
        edges.append(edges[-1] + rng.uniform(0.2, 1.2))
    levels = rng.choice([0.0, 0.25, 0.5, 0.75, 1.0], len(edges))
    cs = band_limited(rng, dur, 0.05, 0.8, 12, 0.0)
    def command(tt):
        if tt < dur / 2:
            return float(levels[np.searchsorted(edges, tt, side="right") - 1])
        return float(np.clip(0.5 + 0.55 * cs(tt)[0], 0.0, 1.0))
    p = bw_params()
    sat = os.environ.get("SAT") == "1"
    def gains(u):
        ub = 0.6 * math.tanh(u / 0.6) if sat else u
        return p["aa"] + p["ab"] * ub, p["c0a"] + p["c0b"] * u, p["c1a"] + p["c1b"] * u
    pk0, pg, pb, pA, pn = p["k0"], p["gamma"], p["beta"], p["A"], p["n"]
    def rates(x, xd, u, y, z):
        al, c0, c1 = gains(u)
        yd = (al * z + c0 * xd + pk0 * (x - y)) / (c0 + c1)
        d = xd - yd
        zn = abs(z) ** pn
        return yd, -pg * abs(d) * (zn if z > 0 else -zn) - pb * d * zn + pA * d
    h = 1.0 / fs / sub
    half, full = math.exp(-p["eta"] * h / 2), math.exp(-p["eta"] * h)
    x0v = xs(0.0)
    u = command(0.0); y = stroke * float(x0v[0]); z = float(np.sign(x0v[1])) * (pA / (pb + pg)) ** (1 / pn)
    F = np.zeros(n); I = np.zeros(n)
    subt = t[:, None] + np.arange(sub + 1)[None, :] * h
    X, V, _ = xs(subt); X = (X * stroke).tolist(); V = (V * stroke).tolist()
    for k in range(n):
        cmd = command(t[k])
        I[k] = cmd
        Xk, Vk = X[k], V[k]
        al, c0, c1 = gains(u)
        yd = (al * z + c0 * Vk[0] + pk0 * (Xk[0] - y)) / (c0 + c1)
        F[k] = c1 * yd + p["k1"] * (Xk[0] - p["x0"])
        # The command held over the sample, the coil's filter exact over each substep; (y, z) by RK4.
        for s in range(sub):
            xa, xb, va, vb = Xk[s], Xk[s + 1], Vk[s], Vk[s + 1]
            xm, vm = 0.5 * (xa + xb), 0.5 * (va + vb)
            um = cmd + (u - cmd) * half; ub = cmd + (u - cmd) * full
            k1y, k1z = rates(xa, va, u, y, z)
            k2y, k2z = rates(xm, vm, um, y + h / 2 * k1y, z + h / 2 * k1z)
            k3y, k3z = rates(xm, vm, um, y + h / 2 * k2y, z + h / 2 * k2z)
            k4y, k4z = rates(xb, vb, ub, y + h * k3y, z + h * k3z)
            y += h / 6 * (k1y + 2 * k2y + 2 * k3y + k4y); z += h / 6 * (k1z + 2 * k2z + 2 * k3z + k4z)
            u = ub
    X = np.array([r[0] for r in X])
    x = X + rng.normal(0, 2e-6, n)
    F = F + rng.normal(0, float(os.environ.get("NOISE", "4")), n)
    if "CLIP" in os.environ:
        F = np.clip(F, -float(os.environ["CLIP"]), float(os.environ["CLIP"]))
    return t, x, I, F

def broadband_main(outdir, seed):
    shutil.rmtree(outdir, ignore_errors=True); os.makedirs(outdir)
    for r in range(int(os.environ.get("RECORDS", "2"))):
        t, x, I, F = broadband_record(np.random.default_rng(seed + r))
        with open(os.path.join(outdir, f"record{r + 1}.csv"), "w") as o:
            o.write(f"# source: independent synthetic truth (modified Bouc-Wen, Spencer et al. 1997, scaled; "
                    f"broadband, seed {seed + r})\n# sample_rate_hz: {float(os.environ.get('FS', '3000')):g}\n"
                    "t_s,x_m,i_a,f_n\n")
            for row in zip(t, x, I, F):
                o.write(",".join(repr(float(q)) for q in row) + "\n")

if sys.argv[1] == "broadband":
    broadband_main(sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 1)
else:
    main()
