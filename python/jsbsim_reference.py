#!/usr/bin/env python3
"""JSBSim reference flights for mrfeel's aircraft models.

Flies the aircraft bundled in the pinned JSBSim wheel (jsbsim==1.3.3) through trims over a speed
range and three manoeuvres (elevator doublet, pull-up to a load factor, decelerating approach) and
writes one CSV per aircraft and run under scenarios/jsbsim/. All columns are SI with the unit in the
name. The Rust longitudinal models (src/aero/) are validated against these tables.

    "$(scripts/python-env.sh)" python/jsbsim_reference.py            # regenerate scenarios/jsbsim
    "$(scripts/python-env.sh)" python/jsbsim_reference.py --check    # compare byte-for-byte

JSBSim is deterministic: the same wheel gives the same bytes. JSBSim's console output (banner,
trim reports) goes to stderr; only the summary of this script goes to stdout.
"""
from __future__ import annotations

import argparse
import atexit
import difflib
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

# Unit conversions (exact or standard definitions), applied once at the edge.
FT_TO_M = 0.3048
SLUG_TO_KG = 14.593902937206364
LBF_TO_N = 4.4482216152605
PSF_TO_PA = LBF_TO_N / FT_TO_M**2
SLUGFT3_TO_KGM3 = SLUG_TO_KG / FT_TO_M**3
SLUGFT2_TO_KGM2 = SLUG_TO_KG * FT_TO_M**2
IN_TO_M = 0.0254
KT_TO_M_S = 1852.0 / 3600.0

REPO = Path(__file__).resolve().parent.parent
DEFAULT_OUT = REPO / "scenarios" / "jsbsim"
COMMAND = '"$(scripts/python-env.sh)" python/jsbsim_reference.py'
DT_S = 1.0 / 120.0
# Latitude 45 deg: local gravity there is within 0.05 % of standard gravity, which the Rust model uses.
LATITUDE_DEG = 45.0

COLUMNS = [
    "t_s", "qbar_pa", "alpha_rad", "elevator_rad", "q_rad_s", "theta_rad", "nz_g", "airspeed_m_s",
    "altitude_m", "mach", "rho_kg_m3", "throttle", "thrust_n", "alphadot_rad_s", "elevator_cmd_norm",
]

# Per-aircraft flight conditions. Speeds are true airspeeds. Clean configuration (flaps 0, gear up).
AIRCRAFT = {
    "c172p": {
        "altitude_m": 1000.0,
        "trim_speeds_m_s": [30.0, 35.0, 40.0, 45.0, 50.0, 55.0, 60.0],
        "cruise_m_s": 50.0,
        "doublet_cmd": 0.08,
        "pullup_nz_g": 2.0,
        "pullup_gains": (0.1, 1.2),
        "approach_m_s": (50.0, 33.0),
        "approach_throttle_factor": 0.6,
        "speed_gains": (0.02, 0.004),
        # steady pull-ups (JSBSim's own trim, do_trim(3)) at equivalent airspeeds x altitudes
        "per_g_eas_m_s": [40.0, 44.0, 48.0, 52.0, 56.0],
        "per_g_altitudes_m": [300.0, 900.0, 1500.0, 2100.0],
        "per_g_nz_g": 1.5,
    },
    "737": {
        "altitude_m": 3000.0,
        "trim_speeds_m_s": [120.0, 130.0, 150.0, 170.0, 190.0, 210.0, 230.0],
        "cruise_m_s": 170.0,
        "doublet_cmd": 0.04,
        "pullup_nz_g": 1.5,
        "pullup_gains": (0.06, 0.3),
        "approach_m_s": (160.0, 120.0),
        "approach_throttle_factor": 0.6,
        "speed_gains": (0.004, 0.0004),
        "per_g_eas_m_s": [125.0, 140.0, 155.0, 170.0, 185.0],
        "per_g_altitudes_m": [1000.0, 2500.0, 4000.0, 5500.0],
        "per_g_nz_g": 1.5,
    },
    "T37": {
        "altitude_m": 3000.0,
        "trim_speeds_m_s": [80.0, 100.0, 120.0, 140.0, 160.0, 180.0],
        "cruise_m_s": 140.0,
        "doublet_cmd": 0.05,
        "pullup_nz_g": 2.5,
        "pullup_gains": (0.1, 0.5),
        "approach_m_s": (140.0, 90.0),
        "approach_throttle_factor": 0.6,
        "speed_gains": (0.01, 0.001),
        "per_g_eas_m_s": [75.0, 85.0, 95.0, 105.0, 115.0],
        "per_g_altitudes_m": [500.0, 1500.0, 2500.0, 3500.0],
        "per_g_nz_g": 1.5,
    },
}


# Fly-by-wire aircraft, flown through their own flight control system: `elevator-cmd-norm` is the stick's
# command (JSBSim's sign: negative = aft stick), the trims hold the FCS's pitch trim. Each doublet is
# (true airspeed m/s, altitude m, command amplitude, file suffix).
FLY_BY_WIRE = {
    "f16": {
        "altitude_m": 3000.0,
        "trim_speeds_m_s": [140.0, 160.0, 180.0, 200.0, 220.0, 240.0, 260.0],
        "doublets": [(200.0, 3000.0, 0.1, "doublet"), (110.0, 1000.0, 0.1, "doublet_slow")],
    },
}


_OFFLINE_DIR: Path | None = None
NETWORK_INPUT = re.compile(r"<input\b[^>]*\bport=[^>]*?(/>|>.*?</input>)", re.S)


def offline_aircraft_dir(jsbsim, aircraft: str) -> Path:
    """A copy of the wheel's aircraft file without its network <input port=...> elements.

    The bundled 737 opens a telnet and a UDP listening socket on load; the copy does not. Everything
    else (aerodynamics, mass, FCS, engines and systems from the wheel's folders) is unchanged.
    """
    global _OFFLINE_DIR
    if aircraft in FLY_BY_WIRE:
        # the package's own folder: its XML opens no network port and its systems are found beside it
        return Path(jsbsim.get_default_root_dir()) / "aircraft"
    if _OFFLINE_DIR is None:
        _OFFLINE_DIR = Path(tempfile.mkdtemp(prefix="mrfeel-jsbsim-"))
        atexit.register(shutil.rmtree, _OFFLINE_DIR, True)
    src = Path(jsbsim.get_default_root_dir()) / "aircraft" / aircraft / f"{aircraft}.xml"
    dst = _OFFLINE_DIR / aircraft / f"{aircraft}.xml"
    if not dst.exists():
        dst.parent.mkdir(parents=True, exist_ok=True)
        dst.write_text(NETWORK_INPUT.sub("", src.read_text()))
    return _OFFLINE_DIR


class Flight:
    """One JSBSim instance trimmed at a flight condition."""

    def __init__(self, jsbsim, aircraft: str, airspeed_m_s: float, altitude_m: float):
        self.fdm = jsbsim.FGFDMExec(root_dir=jsbsim.get_default_root_dir())
        self.fdm.set_debug_level(0)
        self.fdm.set_aircraft_path(str(offline_aircraft_dir(jsbsim, aircraft)))
        self.fdm.load_model(aircraft)
        self.fdm.set_dt(DT_S)
        f = self.fdm
        f["ic/lat-geod-deg"] = LATITUDE_DEG
        f["ic/long-gc-deg"] = 0.0
        f["ic/h-sl-ft"] = altitude_m / FT_TO_M
        f["ic/vt-fps"] = airspeed_m_s / FT_TO_M
        f["ic/gamma-deg"] = 0.0
        f["ic/psi-true-deg"] = 0.0
        f["propulsion/fuel_freeze"] = 1
        f["gear/gear-cmd-norm"] = 0.0
        f["fcs/flap-cmd-norm"] = 0.0
        f.run_ic()
        f["propulsion/set-running"] = -1
        f.do_trim(1)  # full trim: longitudinal and lateral
        self.t0 = f["simulation/sim-time-sec"]
        self.trim_pitch_cmd = f["fcs/pitch-trim-cmd-norm"]
        self.trim_throttle = f["fcs/throttle-cmd-norm[0]"]

    def mass_properties(self) -> dict:
        f = self.fdm
        return {
            "mass_kg": f["inertia/mass-slugs"] * SLUG_TO_KG,
            "iyy_kg_m2": f["inertia/iyy-slugs_ft2"] * SLUGFT2_TO_KGM2,
            "cg_x_m": f["inertia/cg-x-in"] * IN_TO_M,
            "cg_z_m": f["inertia/cg-z-in"] * IN_TO_M,
        }

    def set_elevator_cmd(self, cmd_norm: float):
        self.fdm["fcs/elevator-cmd-norm"] = cmd_norm

    def set_throttle(self, throttle: float):
        for k in range(self.engines()):
            self.fdm[f"fcs/throttle-cmd-norm[{k}]"] = throttle

    def row(self) -> list[float]:
        f = self.fdm
        thrust_lbf = sum(
            f[f"propulsion/engine[{k}]/thrust-lbs"] for k in range(self.engines())
        )
        return [
            f["simulation/sim-time-sec"] - self.t0,
            f["aero/qbar-psf"] * PSF_TO_PA,
            f["aero/alpha-rad"],
            f["fcs/elevator-pos-rad"],
            f["velocities/q-rad_sec"],
            f["attitude/theta-rad"],
            f["accelerations/Nz"],
            f["velocities/vt-fps"] * FT_TO_M,
            f["position/h-sl-ft"] * FT_TO_M,
            f["velocities/mach"],
            f["atmosphere/rho-slugs_ft3"] * SLUGFT3_TO_KGM3,
            f["fcs/throttle-pos-norm[0]"],
            thrust_lbf * LBF_TO_N,
            f["aero/alphadot-rad_sec"],
            f["fcs/elevator-cmd-norm"],
        ]

    def engines(self) -> int:
        return self.fdm.get_propulsion().get_num_engines()

    def step(self):
        self.fdm.run()


def fmt(x: float) -> str:
    s = f"{x:.9g}"
    return "0" if s == "-0" else s


def write_csv(path: Path, header: list[str], columns: list[str], rows: list[list[float]]):
    with open(path, "w", newline="\n") as fh:
        for line in header:
            fh.write(f"# {line}\n")
        fh.write(",".join(columns) + "\n")
        for r in rows:
            fh.write(",".join(fmt(x) for x in r) + "\n")


def common_header(jsbsim, aircraft: str, what: str, props: dict) -> list[str]:
    return [
        f"JSBSim {jsbsim.__version__} (Python package jsbsim=={jsbsim.__version__}), aircraft {aircraft} "
        f"(aircraft/{aircraft}/{aircraft}.xml shipped in the wheel"
        + (")" if aircraft in FLY_BY_WIRE else ", network <input port> elements removed)"),
        what,
        f"regenerate: {COMMAND}   (check: {COMMAND} --check)",
        "conditions: ISA, latitude 45 deg, wings level, clean (flaps 0, gear up), fuel frozen, dt 1/120 s",
        "mass properties at trim: " + ", ".join(f"{k}={fmt(v)}" for k, v in props.items())
        + " (cg in JSBSim's structural frame: x aft, z up)",
    ]


def run_doublet(jsbsim, ac: str, cfg: dict) -> tuple[list[str], list[list[float]]]:
    return doublet(jsbsim, ac, cfg["cruise_m_s"], cfg["altitude_m"], cfg["doublet_cmd"])


def doublet(jsbsim, ac: str, airspeed_m_s: float, altitude_m: float, a: float):
    """Doublet on elevator-cmd-norm (positive = push: the elevator of a reversible aircraft, the stick
    command of a fly-by-wire one) from trim: +a for 1 s, then -a for 1 s, throttle held."""
    fl = Flight(jsbsim, ac, airspeed_m_s, altitude_m)
    rows = []
    n = int(round(12.0 / DT_S))
    for k in range(n + 1):
        t = k * DT_S
        cmd = a if 1.0 <= t < 2.0 else (-a if 2.0 <= t < 3.0 else 0.0)
        fl.set_elevator_cmd(cmd)
        rows.append(fl.row())
        fl.step()
    what = (f"run: elevator doublet from trim at {fmt(airspeed_m_s)} m/s TAS, {fmt(altitude_m)} m: "
            f"elevator-cmd-norm +{a} for t in [1,2) s, -{a} for [2,3) s, throttle held at trim; rows at 120 Hz (every step)")
    if ac in FLY_BY_WIRE:
        what += "; flown through the aircraft's FCS (elevator-cmd-norm is the stick's command, the FCS's pitch trim held)"
    return [what, fl], rows


def run_pullup(jsbsim, ac: str, cfg: dict):
    fl = Flight(jsbsim, ac, cfg["cruise_m_s"], cfg["altitude_m"])
    target = cfg["pullup_nz_g"]
    kp, ki = cfg["pullup_gains"]
    integ = 0.0
    rows = []
    n = int(round(8.0 / DT_S))
    for k in range(n + 1):
        t = k * DT_S
        if t < 1.0:
            cmd = 0.0
        elif t < 5.0:
            nz_ref = 1.0 + (target - 1.0) * min((t - 1.0) / 1.0, 1.0)
            err = nz_ref - fl.fdm["accelerations/Nz"]
            integ += err * DT_S
            cmd = max(-1.0, min(1.0, -(kp * err + ki * integ)))
        else:
            cmd = 0.0
        fl.set_elevator_cmd(cmd)
        if k % 2 == 0:  # 60 Hz
            rows.append(fl.row())
        fl.step()
    what = (f"run: pull-up from trim at {fmt(cfg['cruise_m_s'])} m/s TAS, {fmt(cfg['altitude_m'])} m: PI loop on Nz "
            f"(kp {kp}, ki {ki} per g on elevator-cmd-norm) tracks a 1 s ramp to {fmt(target)} g from t=1 s, "
            "held to t=5 s, then elevator released to trim; rows at 60 Hz")
    return [what, fl], rows


def run_approach(jsbsim, ac: str, cfg: dict):
    v0, v1 = cfg["approach_m_s"]
    fl = Flight(jsbsim, ac, v0, cfg["altitude_m"])
    kp, ki = cfg["speed_gains"]
    thr = fl.trim_throttle * cfg["approach_throttle_factor"]
    integ = 0.0
    rows = []
    n = int(round(40.0 / DT_S))
    for k in range(n + 1):
        t = k * DT_S
        if t >= 1.0:
            fl.set_throttle(thr)
            v_ref = v0 + (v1 - v0) * min((t - 1.0) / 25.0, 1.0)
            err = v_ref - fl.fdm["velocities/vt-fps"] * FT_TO_M
            integ += err * DT_S
            # too slow (err > 0) -> push (positive cmd, trailing edge down) to lower the nose
            cmd = max(-1.0, min(1.0, kp * err + ki * integ))
            fl.set_elevator_cmd(cmd)
        if k % 12 == 0:  # 10 Hz
            rows.append(fl.row())
        fl.step()
    what = (f"run: decelerating approach at {fmt(cfg['altitude_m'])} m: from trim at {fmt(v0)} m/s, throttle cut to "
            f"{cfg['approach_throttle_factor']} x trim at t=1 s, PI airspeed hold on elevator-cmd-norm (kp {kp}, ki {ki} "
            f"per m/s) tracks a 25 s ramp down to {fmt(v1)} m/s; rows at 10 Hz")
    return [what, fl], rows


def run_trims(jsbsim, ac: str, cfg: dict):
    cols = ["airspeed_m_s", "altitude_m", "qbar_pa", "alpha_rad", "elevator_rad", "theta_rad", "throttle",
            "thrust_n", "nz_g", "mach", "rho_kg_m3"]
    rows = []
    props = None
    for v in cfg["trim_speeds_m_s"]:
        fl = Flight(jsbsim, ac, v, cfg["altitude_m"])
        r = dict(zip(COLUMNS, fl.row()))
        props = props or fl.mass_properties()
        rows.append([r["airspeed_m_s"], r["altitude_m"], r["qbar_pa"], r["alpha_rad"], r["elevator_rad"],
                     r["theta_rad"], r["throttle"], r["thrust_n"], r["nz_g"], r["mach"], r["rho_kg_m3"]])
    what = f"run: full trims in level flight at {fmt(cfg['altitude_m'])} m over true airspeeds {cfg['trim_speeds_m_s']} m/s"
    return what, props, cols, rows


def isa_density_ratio(altitude_m: float) -> float:
    """ISA troposphere density over sea-level density (the grid's equivalent airspeeds become true ones)."""
    t = 288.15 - 0.0065 * altitude_m
    return (t / 288.15) ** (9.80665 / (0.0065 * 287.05287) - 1.0)


def trim_state(jsbsim, ac: str, eas_m_s: float, altitude_m: float, nz_g: float) -> list[float]:
    """JSBSim's own trim at an equivalent airspeed and altitude: level flight (full trim) for 1 g, the
    bottom of a steady pull-up (do_trim(3), ic/targetNlf) otherwise; throttle trimmed in both."""
    f = jsbsim.FGFDMExec(root_dir=jsbsim.get_default_root_dir())
    f.set_debug_level(0)
    f.set_aircraft_path(str(offline_aircraft_dir(jsbsim, ac)))
    f.load_model(ac)
    f.set_dt(DT_S)
    f["ic/lat-geod-deg"] = LATITUDE_DEG
    f["ic/long-gc-deg"] = 0.0
    f["ic/h-sl-ft"] = altitude_m / FT_TO_M
    f["ic/vt-fps"] = eas_m_s / isa_density_ratio(altitude_m) ** 0.5 / FT_TO_M
    f["ic/gamma-deg"] = 0.0
    f["ic/psi-true-deg"] = 0.0
    f["ic/targetNlf"] = nz_g
    f["propulsion/fuel_freeze"] = 1
    f["gear/gear-cmd-norm"] = 0.0
    f["fcs/flap-cmd-norm"] = 0.0
    f.run_ic()
    f["propulsion/set-running"] = -1
    f.do_trim(1 if nz_g == 1.0 else 3)
    return [f["velocities/vt-fps"] * FT_TO_M, f["accelerations/Nz"], f["fcs/elevator-pos-rad"], f["aero/alpha-rad"],
            f["velocities/q-rad_sec"], f["fcs/throttle-cmd-norm[0]"], f["velocities/mach"]]


def run_per_g(jsbsim, ac: str, cfg: dict):
    """Elevator per g: JSBSim's level trim and steady pull-up trim at each flight condition."""
    n = cfg["per_g_nz_g"]
    cols = ["eas_m_s", "airspeed_m_s", "altitude_m", "mach", "nz1_g", "elevator1_rad", "alpha1_rad", "throttle1",
            "nz_g", "elevator_rad", "alpha_rad", "q_rad_s", "throttle"]
    rows = []
    for h in cfg["per_g_altitudes_m"]:
        for ve in cfg["per_g_eas_m_s"]:
            v1, nz1, de1, a1, _, thr1, mach = trim_state(jsbsim, ac, ve, h, 1.0)
            _, nzn, den, an, qn, thrn, _ = trim_state(jsbsim, ac, ve, h, n)
            rows.append([ve, v1, h, mach, nz1, de1, a1, thr1, nzn, den, an, qn, thrn])
    what = (f"run: JSBSim trims, level (do_trim(1)) and steady pull-up at {fmt(n)} g (do_trim(3), ic/targetNlf), "
            f"throttle trimmed, at equivalent airspeeds {cfg['per_g_eas_m_s']} m/s x altitudes "
            f"{cfg['per_g_altitudes_m']} m; columns 1 = level trim, the others = pull-up")
    return what, cols, rows


def generate(out: Path) -> list[Path]:
    import jsbsim  # imported after stdout is redirected: the banner goes to stderr

    out.mkdir(parents=True, exist_ok=True)
    written = []
    for ac, cfg in AIRCRAFT.items():
        what, props, cols, rows = run_trims(jsbsim, ac, cfg)
        p = out / f"{ac}_trim.csv"
        write_csv(p, common_header(jsbsim, ac, what, props), cols, rows)
        written.append(p)
        what, cols, rows = run_per_g(jsbsim, ac, cfg)
        p = out / f"{ac}_per_g.csv"
        write_csv(p, common_header(jsbsim, ac, what, props), cols, rows)
        written.append(p)
        for name, fn in (("doublet", run_doublet), ("pullup", run_pullup), ("approach", run_approach)):
            (what, fl), rows = fn(jsbsim, ac, cfg)
            p = out / f"{ac}_{name}.csv"
            write_csv(p, common_header(jsbsim, ac, what, fl.mass_properties()), COLUMNS, rows)
            written.append(p)
    for ac, cfg in FLY_BY_WIRE.items():
        what, props, cols, rows = run_trims(jsbsim, ac, cfg)
        p = out / f"{ac}_trim.csv"
        write_csv(p, common_header(jsbsim, ac, what, props), cols, rows)
        written.append(p)
        for v, h, a, suffix in cfg["doublets"]:
            (what, fl), rows = doublet(jsbsim, ac, v, h, a)
            p = out / f"{ac}_{suffix}.csv"
            write_csv(p, common_header(jsbsim, ac, what, fl.mass_properties()), COLUMNS, rows)
            written.append(p)
    return written


def check(committed: Path) -> int:
    with tempfile.TemporaryDirectory() as tmp:
        fresh = generate(Path(tmp))
        bad = 0
        for f in fresh:
            old = committed / f.name
            if not old.exists():
                print(f"MISSING {old} (regenerate with: {COMMAND})", file=sys.stderr)
                bad += 1
                continue
            a, b = old.read_bytes(), f.read_bytes()
            if a != b:
                bad += 1
                la, lb = a.decode().splitlines(), b.decode().splitlines()
                diff = list(difflib.unified_diff(la, lb, str(old), "regenerated", n=0, lineterm=""))
                changed = sum(1 for d in diff if d.startswith(("+", "-")) and not d.startswith(("+++", "---")))
                print(f"DIFFERS {old}: {changed} changed lines; first:", file=sys.stderr)
                for d in diff[:8]:
                    print("   " + d[:200], file=sys.stderr)
        extra = sorted(set(p.name for p in committed.glob("*.csv")) - set(f.name for f in fresh))
        for e in extra:
            print(f"EXTRA {committed / e} is not produced by the generator", file=sys.stderr)
            bad += 1
        return bad


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output directory (default scenarios/jsbsim)")
    ap.add_argument("--check", action="store_true",
                    help="regenerate into a temporary directory and compare byte-for-byte with --out")
    args = ap.parse_args()
    # JSBSim writes its banner and reports to the C stdout: send fd 1 to stderr, keep ours.
    sys.stdout.flush()
    real_stdout = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)
    if args.check:
        bad = check(args.out)
        if bad:
            print(f"jsbsim reference check FAILED: {bad} file(s) differ from {args.out}", file=real_stdout)
            return 1
        print(f"jsbsim reference check ok: {args.out} matches a fresh regeneration", file=real_stdout)
        return 0
    for p in generate(args.out):
        print(p.relative_to(REPO) if p.is_relative_to(REPO) else p, file=real_stdout)
    return 0


if __name__ == "__main__":
    sys.exit(main())
