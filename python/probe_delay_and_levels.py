#!/usr/bin/env python3
"""Two hypotheses for the UTFSM damper's held-out gap (dev tool).

1. Channel delay: does the measured force lead or lag the motion channels? Force compared at t + tau with the
   model at t; tau chosen on the two training groups of each leave-one-group-out fold (grid -10..0 ms, 0.5 ms),
   then the third group predicted.
2. Ceiling of any current law: every current level gets its own yield force, damping, x_y and v_y (shared by
   the groups), leaving one group out. No law of the current can do better held out than free values per level.

Model: Bingham + the reduced Spencer hysteresis of `src/device/effects/hysteresis.rs` (Dahl in series with a
viscous pre-yield dashpot), parameters linear in the constant current; 200 Hz; each test weighted equally;
pooled NRMSE = RMS(residual) / RMS(force) over the held-out samples. Its own figures differ slightly from
`mrfeel diagnose`'s (0.104 vs 0.0999 for the same model held out): another fitter and weighting.

Run:  python3 -m venv probe-env && probe-env/bin/pip install numpy scipy numba
      probe-env/bin/python python/probe_delay_and_levels.py       (a few minutes)
"""
import os, sys
import numpy as np, numba
from scipy.optimize import least_squares

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import prototype_hysteresis as P

GROUPS = P.GROUPS


def load_raw():
    """Every test at its full rate, the columns under their file names."""
    return [dict(name=d["name"], group=d["group"], t_s=d["t"], x_m=d["x"], v_m_s=d["v"], i_a=d["i"], f_n=d["f"])
            for d in P.load(P.DATA)]

def prep(raw, tau=0.0, dec=0.005, trim=0.012):
    """Force shifted: compare model(t) with f(t + tau) (tau > 0: force channel lags motion).
    Shift done by linear interpolation at full rate, then decimate to ~dec. Same trimmed samples for every tau."""
    tests = []
    for r in raw:
        t = r["t_s"]
        fs = np.interp(t + tau, t, r["f_n"])
        step = max(1, int(round(dec / np.median(np.diff(t))))) if dec > 0 else 1
        keep = np.arange(len(t))[::step]
        d = dict(name=r["name"], group=r["group"], t=t[keep], x=r["x_m"][keep], v=r["v_m_s"][keep],
                 i=float(np.abs(r["i_a"]).mean()), f=fs[keep])
        d["ev"] = (d["t"] >= t[0] + trim) & (d["t"] <= t[-1] - trim)   # evaluated samples
        tests.append(d)
    return tests

@numba.njit(cache=True)
def zstates(x, t, v0, xy, vy):
    n = x.shape[0]
    z = np.zeros(n)
    if vy > 0:
        zk = min(1.0, max(-1.0, v0 / vy))
    else:
        zk = 1.0 if v0 > 0 else -1.0
    for k in range(n):
        z[k] = zk
        if k == n - 1:
            break
        dt = t[k + 1] - t[k]
        v = (x[k + 1] - x[k]) / dt
        w0 = v - vy * zk
        s = 1.0 if w0 > 0 else (-1.0 if w0 < 0 else 0.0)
        if s == 0.0:
            continue
        if s * v < vy:
            r = v / vy
        else:
            r = s
        e0 = abs(r - zk)
        cd = abs(v - s * vy) / xy
        c = vy / xy
        E = np.exp(-cd * dt)
        frac = (-np.expm1(-cd * dt) / cd) if cd * dt > 1e-12 else dt
        e = e0 * E / (1 + c * e0 * frac)
        zk = min(1.0, max(-1.0, r - s * e))
    return z

def model(d, p):
    """p = fy, c, xy, vy for this test (already evaluated at its current)."""
    fy, c, xy, vy = p
    z = zstates(d["x"], d["t"], d["v"][0], xy, vy)
    return fy * z + c * d["v"]

def lin_params(q, i):
    # q: fc0, k, c0, c1, xy0, xy1, vy0, vy1  (linear in current)
    return (q[0] + q[1] * i, q[2] + q[3] * i, max(q[4] + q[5] * i, 1e-7), max(q[6] + q[7] * i, 0.0))

def nrmse_pooled(tests, preds):
    r = np.concatenate([(pf - d["f"])[d["ev"]] for d, pf in zip(tests, preds)])
    f = np.concatenate([d["f"][d["ev"]] for d in tests])
    return np.sqrt(np.mean(r ** 2)) / np.sqrt(np.mean(f ** 2))

def fit_lin(tests, q0=None, vary_hyst=True):
    """Fit linear-in-current params; each test weighted equally. vary_hyst=False: xy, vy constant."""
    if q0 is None:
        q0 = np.array([80., 900., 2000., 7000., 2e-4, 0.0, 0.01, 0.0])
    q0 = np.array(q0, float).copy()
    free = np.array([0, 1, 2, 3, 4, 5, 6, 7]) if vary_hyst else np.array([0, 1, 2, 3, 4, 6])
    if not vary_hyst: q0[5] = 0; q0[7] = 0
    scale = np.array([100., 1000., 2000., 5000., 2e-4, 2e-4, 0.01, 0.01])[free]
    lo = np.array([0, 0, 0, -np.inf, 1e-6, -1e-3, 0, -0.05])[free]
    hi = np.array([np.inf] * 4 + [0.01, 1e-3, 0.2, 0.2])[free]
    w = [1 / np.sqrt(d["ev"].sum()) for d in tests]
    def full(u):
        q = q0.copy(); q[free] = u * scale; return q
    def res(u):
        q = full(u)
        return np.concatenate([((model(d, lin_params(q, d["i"])) - d["f"]) * wi)[d["ev"]] for d, wi in zip(tests, w)])
    u0 = np.clip(q0[free] / scale, lo / scale + 1e-9, hi / scale - 1e-9)
    r = least_squares(res, u0, bounds=(lo / scale, hi / scale), x_scale="jac", max_nfev=300)
    return full(r.x)

def pred_lin(tests, q):
    return [model(d, lin_params(q, d["i"])) for d in tests]

def fit_level(tests, p0=None):
    """Free fy, c, xy, vy for tests all at one current level."""
    p0 = np.array([300., 3000., 2e-4, 0.01]) if p0 is None else p0
    scale = np.array([300., 3000., 2e-4, 0.01])
    lo = np.array([0, 0, 1e-6, 0]); hi = np.array([np.inf, np.inf, 0.01, 0.2])
    w = [1 / np.sqrt(d["ev"].sum()) for d in tests]
    def res(u):
        p = u * scale
        return np.concatenate([((model(d, p) - d["f"]) * wi)[d["ev"]] for d, wi in zip(tests, w)])
    best = None
    for s in (1.0, 0.3, 3.0):
        u0 = p0 / scale; u0[2:] *= s
        r = least_squares(res, np.clip(u0, lo / scale + 1e-9, hi / scale - 1e-9), bounds=(lo / scale, hi / scale), x_scale="jac", max_nfev=300)
        if best is None or r.cost < best.cost: best = r
    return best.x * scale


def heldout(T, fit_predict):
    """Pooled held-out NRMSE and per group, leaving one group out at a time."""
    ht, hp, per = [], [], {}
    for g in GROUPS:
        tr = [d for d in T if d["group"] != g]
        te = [d for d in T if d["group"] == g]
        pp = fit_predict(tr, te)
        per[g] = nrmse_pooled(te, pp)
        ht += te
        hp += pp
    return nrmse_pooled(ht, hp), per


def show(label, res):
    pooled, per = res
    print(f"{label}: held out {pooled:.4f} (" + ", ".join(f"{g} {v:.4f}" for g, v in per.items()) + ")", flush=True)


def main():
    raw = load_raw()
    T0 = prep(raw, 0.0)
    q_init = fit_lin(T0)
    show("linear current law, no delay", heldout(T0, lambda tr, te: pred_lin(te, fit_lin(tr, q0=q_init))))

    taus = np.arange(-10, 0.01, 0.5) * 1e-3
    Ts = {tau: prep(raw, tau) for tau in taus}
    ht, hp, per = [], [], {}
    for g in GROUPS:
        best = None
        for tau in taus:
            tr = [d for d in Ts[tau] if d["group"] != g]
            q = fit_lin(tr, q0=q_init)
            e = nrmse_pooled(tr, pred_lin(tr, q))
            if best is None or e < best[0]:
                best = (e, tau, q)
        te = [d for d in Ts[best[1]] if d["group"] == g]
        pp = pred_lin(te, best[2])
        per[g] = nrmse_pooled(te, pp)
        print(f"  leaving out {g}: delay chosen on the other two groups {best[1] * 1e3:+.1f} ms", flush=True)
        ht += te
        hp += pp
    show("linear current law, delay fitted per fold", (nrmse_pooled(ht, hp), per))

    level = lambda d: int(round(d["i"] / 0.25))

    def per_level(tr, te):
        return [model(d, fit_level([e for e in tr if level(e) == level(d)])) for d in te]

    show("free parameters per current level (ceiling of any current law), no delay", heldout(T0, per_level))


if __name__ == "__main__":
    main()
