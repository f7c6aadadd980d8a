#!/usr/bin/env python3
"""Prototype of pre-yield hysteresis forms for the `hysteresis` effect (dev tool, not part of the tests).

Fits the paper's base model (Eq. 2, F = (fc0 + k|i|)·d + C0·v, the currents are constant within a file so the
lags of Eq. 3-4 do not act) with several direction functions d (literature forms of MR-damper hysteresis) to
the UTFSM MR damper tests, and reports leave-one-group-out NRMSE (fit on two amplitude/frequency groups,
evaluate rmse/rms(f) pooled over the five files of the third) and the fit-on-all NRMSE.

Each model is simulated as the Rust crate does: at sample k the force uses the states at k and the present
velocity; the states then advance with the measured step (dx = x[k+1]-x[k], dt) by an exact update.

Run:  python3 -m venv probe-env && probe-env/bin/pip install numpy scipy
      probe-env/bin/python python/prototype_hysteresis.py [--forms a,b,...] [--data DIR]
"""

import argparse
import glob
import os
import sys
import time

import numpy as np
from scipy.optimize import least_squares

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "utfsm-mr-damper")
GROUPS = ["10mm1Hz", "25mm0p25Hz", "2mm5Hz"]


def load(data_dir, decimate_to_s=0.0):
    """Tests of a directory; with decimate_to_s > 0, faster-sampled tests keep every k-th sample so their
    interval is about decimate_to_s (prototype speed only: the models step exactly on the measured dx)."""
    tests = []
    for path in sorted(glob.glob(os.path.join(data_dir, "*.csv"))):
        with open(path) as fh:
            lines = [ln for ln in fh if ln.strip() and not ln.startswith("#")]
        cols = lines[0].strip().split(",")
        a = np.loadtxt(lines[1:], delimiter=",")
        c = {n: a[:, cols.index(n)] for n in ("t_s", "x_m", "v_m_s", "i_a", "f_n")}
        name = os.path.basename(path)[:-4]
        step = max(1, int(round(decimate_to_s / np.median(np.diff(c["t_s"]))))) if decimate_to_s > 0 else 1
        c = {n: col[::step] for n, col in c.items()}
        tests.append(dict(name=name, group=name.split("_")[0], t=c["t_s"], x=c["x_m"], v=c["v_m_s"], i=c["i_a"],
                          f=c["f_n"]))
    return tests


class Batch:
    """All tests padded to one length so the time loop runs once, vectorised over tests."""

    def __init__(self, tests):
        n = max(len(t["t"]) for t in tests)
        m = len(tests)
        self.n, self.m = n, m
        self.mask = np.zeros((n, m), bool)
        self.x, self.v, self.i, self.f = (np.zeros((n, m)) for _ in range(4))
        self.dx, self.dt = np.zeros((n, m)), np.zeros((n, m))
        for j, t in enumerate(tests):
            k = len(t["t"])
            self.mask[:k, j] = True
            self.x[:k, j], self.v[:k, j], self.i[:k, j], self.f[:k, j] = t["x"], t["v"], t["i"], t["f"]
            self.dx[: k - 1, j] = np.diff(t["x"])
            self.dt[: k - 1, j] = np.diff(t["t"])
        self.groups = [t["group"] for t in tests]
        self.names = [t["name"] for t in tests]


def sgn(v):
    return np.sign(v)


# ---------------------------------------------------------------------------------------------------------------
# Direction functions. Each returns d (n x m) in [-1, 1] for parameters q (beyond the base).
# ---------------------------------------------------------------------------------------------------------------


def d_bingham(b, q):
    return sgn(b.v)


def d_tanh(b, q):
    """Viscous pre-yield (bi-viscous / smooth Bingham): d = tanh(v/v_y), pre-yield damping Fy/v_y."""
    (vy,) = q
    return np.tanh(b.v / vy)


def dahl_states(b, xy):
    z = np.zeros((b.n, b.m))
    zk = sgn(b.v[0])
    for k in range(b.n):
        z[k] = zk
        dx = b.dx[k]
        zk = np.where(dx != 0, sgn(dx) - (sgn(dx) - zk) * np.exp(-np.abs(dx) / xy), zk)
    return z


def d_dahl(b, q):
    """Dahl 1968 / Bouc-Wen n=1: dz/dx = (sgn dx - z)/x_y (rate independent)."""
    (xy,) = q
    return dahl_states(b, xy)


def d_nbw(b, q):
    """Normalised Bouc-Wen (Ikhouane & Rodellar): dz/dx = (1 - sigma |z|^{n-1} z sgn dx + (sigma-1)|z|^n)/x_y
    with sgn dx on the rate. Integrated by substeps (prototype only)."""
    xy, sigma, nexp = q
    z = np.zeros((b.n, b.m))
    zk = sgn(b.v[0]) * 0.999
    sub = 8
    for k in range(b.n):
        z[k] = zk
        h = b.dx[k] / sub
        for _ in range(sub):
            az = np.abs(zk)
            dz = (h - sigma * np.abs(h) * az ** (nexp - 1) * zk + (sigma - 1) * h * az**nexp) / xy
            zk = np.clip(zk + dz, -1, 1)
    return z


def d_mix(b, q):
    """Dahl plus viscous pre-yield, parallel: d = (1-beta) z + beta tanh(v/v_y)."""
    xy, vy, beta = q
    return (1 - beta) * dahl_states(b, xy) + beta * np.tanh(b.v / vy)


def d_hyst_tanh(b, q):
    """Hysteretic tanh (Kwok et al. 2006 form, with the displacement-sign switch replaced by the Dahl state):
    d = tanh((v + v_h z)/v_y)."""
    vy, vh, xy = q
    return np.tanh((b.v + vh * dahl_states(b, xy)) / vy)


def d_kwok(b, q):
    """Kwok et al. 2006 as published: d = tanh(v/v_y + delta sgn x)."""
    vy, delta = q
    return np.tanh(b.v / vy + delta * sgn(b.x))


def lag_states(b, vy, tau):
    """tau dw/dt = tanh(v/v_y) - w, the target held at tanh of the step's mean velocity dx/dt (exact)."""
    w = np.zeros((b.n, b.m))
    wk = np.tanh(b.v[0] / vy)
    for k in range(b.n):
        w[k] = wk
        dt = b.dt[k]
        vm = np.divide(b.dx[k], dt, out=np.zeros(b.m), where=dt > 0)
        g = np.tanh(vm / vy)
        e = np.exp(-dt / tau)
        wk = g + (wk - g) * e
    return w


def d_lag(b, q):
    """Visco-elasto-plastic (Maxwell) pre-yield: the yield-stage direction relaxes with time constant tau to
    the viscous pre-yield curve, tau dw/dt = tanh(v/v_y) - w (fluid compressibility in series with the
    valve's bi-viscous flow: tau = c_pre / k_fluid)."""
    vy, tau = q
    return lag_states(b, vy, tau)


def d_lag_out(b, q):
    """As d_lag, but the output at sample k includes the exact response to the present half step:
    d_k = g_k + (w_k - g_k) e^{-dt/(2 tau)}, g_k = tanh(v_k/v_y) (w_k lags by one step otherwise)."""
    vy, tau = q
    w = lag_states(b, vy, tau)
    g = np.tanh(b.v / vy)
    dt = np.where(b.dt > 0, b.dt, np.median(b.dt[b.dt > 0]))
    return g + (w - g) * np.exp(-dt / (2 * tau))


def maxwell_states(b, vy, xe):
    """Bingham flow (viscous pre-yield) in series with an elastic element of yield-force-relative compliance:
    the flow velocity u solves w = tanh(u/v_y); the element's stretch e = x - y obeys de/dt = v - u with
    w = e/x_e clipped to (-1, 1), i.e. dw/dt = (v - v_y artanh w)/x_e. Integrated implicitly (prototype)."""
    w = np.zeros((b.n, b.m))
    wk = np.tanh(b.v[0] / vy)
    sub = 4
    for k in range(b.n):
        w[k] = wk
        dt = b.dt[k] / sub
        vm = np.divide(b.dx[k], b.dt[k], out=np.zeros(b.m), where=b.dt[k] > 0)
        for _ in range(sub):
            # backward Euler, Newton on w: x_e (w - w0) = dt (v - v_y artanh w)
            wn = wk.copy()
            for _ in range(6):
                r = xe * (wn - wk) - dt * (vm - vy * np.arctanh(wn))
                dr = xe + dt * vy / (1 - wn**2)
                wn = np.clip(wn - r / dr, -0.999999, 0.999999)
            wk = wn
    return w


def d_maxwell(b, q):
    vy, xe = q
    return maxwell_states(b, vy, xe)


def d_lugre(b, q):
    """LuGre (Canudas de Wit et al. 1995) normalised, no Stribeck: dz/dt = (v - |v| z)/x_y,
    d = z + tau_mu dz/dt (micro-damping sigma1), clipped to [-1, 1]."""
    xy, tmu = q
    z = dahl_states(b, xy)
    return np.clip(z + tmu * (b.v - np.abs(b.v) * z) / xy, -1, 1)


def spencer_step(z0, v, dt, xy, vy):
    """Exact step of dz/dt = (w - |w| z)/x_y, w = v - v_y z, for a velocity v held over dt.

    With s = sgn w (constant over the step: z never crosses a = v/v_y), dz/dt = (v_y/x_y) s (a - z)(s - z):
    z moves towards the nearer root r (a if s·a < 1, else s); with e = |r - z|, de/dt = -c e (d + e),
    c = v_y/x_y, c·d = |v - s v_y|/x_y, so e(t) = e0 E / (1 + c e0 (1 - E)/(c d)), E = exp(-c d t)."""
    w0 = v - vy * z0
    s = np.sign(w0)
    sv = s * v
    r = np.where(sv < vy, np.divide(v, vy, out=np.zeros_like(v), where=sv < vy), s)
    e0 = np.abs(r - z0)
    cd = np.abs(v - s * vy) / xy
    c = vy / xy
    E = np.exp(-cd * dt)
    frac = np.where(cd * dt > 1e-12, -np.expm1(-cd * dt) / np.where(cd > 0, cd, 1.0), dt)
    e = e0 * E / (1 + c * e0 * frac)
    return np.where(s == 0, z0, np.clip(r - s * e, -1, 1))


def spencer_states(b, xy, vy):
    z = np.zeros((b.n, b.m))
    zk = np.clip(b.v[0] / vy, -1, 1) if vy > 0 else sgn(b.v[0])
    for k in range(b.n):
        z[k] = zk
        dt = b.dt[k]
        vm = np.divide(b.dx[k], dt, out=np.zeros(b.m), where=dt > 0)
        zk = spencer_step(zk, vm, dt, xy, vy)
    return z


def d_spencer(b, q):
    """Spencer et al. 1997 phenomenological model reduced to its pre-yield core: the hysteretic (Dahl / Bouc-Wen
    n = 1, gamma = beta) element of yield force Fy and yield displacement x_y in series with the viscous
    pre-yield dashpot c1 = Fy/v_y (accumulator k1 and k0 left to the `stiffness` effect, c0 to the base C0).
    z obeys dz/dt = (w - |w| z)/x_y with the element's slip velocity w = v - v_y z; d = z."""
    xy, vy = q
    return spencer_states(b, xy, vy)


# name: (function, parameter names, initial guess from data scales, lower, upper)
def forms(stats):
    xm, vm = stats["x_max"], stats["v_max"]
    return {
        "bingham": (d_bingham, [], [], [], []),
        "dahl": (d_dahl, ["x_y"], [0.02 * xm], [1e-7], [0.01]),
        "tanh": (d_tanh, ["v_y"], [0.1 * vm], [1e-5], [1.0]),
        "kwok": (d_kwok, ["v_y", "delta"], [0.1 * vm, 0.3], [1e-5, 0.0], [1.0, 5.0]),
        "lag": (d_lag, ["v_y", "tau"], [0.1 * vm, 0.2 * xm / vm], [1e-5, 1e-5], [1.0, 1.0]),
        "lag_out": (d_lag_out, ["v_y", "tau"], [0.1 * vm, 0.2 * xm / vm], [1e-5, 1e-5], [1.0, 1.0]),
        "maxwell": (d_maxwell, ["v_y", "x_e"], [0.1 * vm, 0.02 * xm], [1e-5, 1e-7], [1.0, 0.01]),
        "lugre": (d_lugre, ["x_y", "tau_mu"], [0.02 * xm, 0.1 * xm / vm], [1e-7, 0.0], [0.01, 1.0]),
        "spencer": (d_spencer, ["x_y", "v_y"], [0.02 * xm, 0.1 * vm], [1e-7, 0.0], [0.01, 1.0]),
        "mix": (d_mix, ["x_y", "v_y", "beta"], [0.02 * xm, 0.1 * vm, 0.5], [1e-7, 1e-5, 0.0], [0.01, 1.0, 1.0]),
        "hyst_tanh": (d_hyst_tanh, ["v_y", "v_h", "x_y"], [0.1 * vm, 0.05 * vm, 0.02 * xm], [1e-5, 0.0, 1e-7], [1.0, 1.0, 0.01]),
        "nbw": (d_nbw, ["x_y", "sigma", "n"], [0.02 * xm, 1.0, 1.0], [1e-7, 0.0, 0.5], [0.01, 5.0, 4.0]),
    }


def data_stats(b, sel):
    """Linear least-squares Bingham estimate and scales, as DataStats::from_tests computes them."""
    mk = b.mask[:, sel]
    v, i, f, x = b.v[:, sel][mk], np.abs(b.i[:, sel][mk]), b.f[:, sel][mk], b.x[:, sel][mk]
    A = np.stack([sgn(v), sgn(v) * i, v], 1)
    coef = np.maximum(np.linalg.lstsq(A, f, rcond=None)[0], 0.0)
    return dict(fc0=coef[0], k=coef[1], c0=coef[2], x_max=np.abs(x).max(), v_max=np.abs(v).max(), i_max=i.max(),
                f_rms=np.sqrt(np.mean(f**2)))


NB = 3  # base parameters: fc0, k, c0 (+ c1 with --cvisc)


def force(b, fn, p):
    fc0, kk, c0 = p[:3]
    c1 = p[3] if NB == 4 else 0.0
    d = fn(b, p[NB:])
    return (fc0 + kk * np.abs(b.i)) * d + (c0 + c1 * np.abs(b.i)) * b.v


def nrmse(b, fm, sel):
    mk = b.mask[:, sel]
    r = (fm[:, sel] - b.f[:, sel])[mk]
    return np.sqrt(np.mean(r**2)) / np.sqrt(np.mean(b.f[:, sel][mk] ** 2))


STARTS = [1.0, 0.3, 3.0]


def fit(b, name, sel, verbose=False):
    st = data_stats(b, sel)
    fn, pn, g, lo, hi = forms(st)[name]
    base = [st["fc0"], st["k"], st["c0"]] + ([0.5 * st["c0"] / max(st["i_max"], 1e-9)] if NB == 4 else [])
    p0 = np.array(base + g)
    lo = np.array([0] * NB + lo)
    hi = np.array([np.inf] * NB + hi)
    # Scales for the optimiser: the guess, or the data's force/velocity scales where the guess is 0.
    fs, vs, isc = st["f_rms"], st["v_max"], max(st["i_max"], 1e-9)
    floor = np.array([0.1 * fs, 0.5 * fs / isc, 0.5 * fs / vs] + ([0.5 * fs / vs / isc] if NB == 4 else [])
                     + [1e-12] * len(g))
    scale = np.maximum(np.abs(p0), floor)
    mk = b.mask[:, sel]
    # Each test weighted equally (per-sample weight 1/sqrt(n_test)), so the 1 kHz group does not dominate.
    w = 1 / np.sqrt(mk.sum(0))[None, :] * np.ones_like(b.f[:, sel])

    def res(u):
        return ((force(b, fn, u * scale)[:, sel] - b.f[:, sel]) * w)[mk]

    # Multi-start on the new parameters (the data-derived guess and two decades around it).
    best = None
    for s in STARTS if len(g) else [1.0]:
        u0 = p0 / scale
        u0[NB:] = u0[NB:] * np.where(np.array(pn) == "beta", 1.0, s) if len(g) else u0[NB:]
        u0 = np.clip(u0, lo / scale, hi / scale)
        r = least_squares(res, u0, bounds=(lo / scale, hi / scale), x_scale="jac", max_nfev=200)
        if best is None or r.cost < best.cost:
            best = r
    p = best.x * scale
    return p, pn


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default=DATA)
    ap.add_argument("--cvisc", action="store_true", help="base + current_viscosity: C = c0 + c1 |i|")
    ap.add_argument("--forms", default="bingham,dahl,tanh,kwok,lugre,lag,lag_out,mix,spencer")
    ap.add_argument("--decimate", type=float, default=0.005, help="resample faster tests to this interval, s (0: off)")
    ap.add_argument("--one-start", action="store_true", help="only the data-derived initial guess (faster)")
    a = ap.parse_args()
    global NB, STARTS
    if a.one_start:
        STARTS = [1.0]
    NB = 4 if a.cvisc else 3
    b = Batch(load(a.data, a.decimate))
    print(f"{len(b.names)} tests, groups {GROUPS}", file=sys.stderr)
    print("| form | extra params | held out 10mm1Hz | held out 25mm0p25Hz | held out 2mm5Hz | mean held out | fit on all | fitted on all |")
    print("|---|---|---|---|---|---|---|---|")
    for name in a.forms.split(","):
        t0 = time.time()
        held = []
        for g in GROUPS:
            test = np.array([x == g for x in b.groups])
            p, pn = fit(b, name, ~test)
            fm = force(b, forms(data_stats(b, ~test))[name][0], p)
            held.append(nrmse(b, fm, test))
        allsel = np.ones(b.m, bool)
        p, pn = fit(b, name, allsel)
        fn = forms(data_stats(b, allsel))[name][0]
        fa = nrmse(b, force(b, fn, p), allsel)
        desc = ", ".join(f"{n}={v:.4g}" for n, v in zip(["fc0", "k", "c0", "c1"][:NB] + pn, p))
        print(f"| {name} | {len(pn)} | " + " | ".join(f"{h:.3f}" for h in held)
              + f" | {np.mean(held):.3f} | {fa:.3f} | {desc} |", flush=True)
        print(f"  ({time.time() - t0:.0f} s)", file=sys.stderr)


if __name__ == "__main__":
    main()
