#!/usr/bin/env python3
"""Live JSBSim bridge for mrfeel: steps one JSBSim aircraft in lock-step with the Rust stick rig.

Protocol (one request line -> one reply line, ASCII, space separated, on stdin/stdout):

    (on start)                                  -> "ready <jsbsim version>"   or "error <message>" and exit 2
    init <aircraft> <airspeed_m_s> <altitude_m> <dt_s>
                                                -> "ok <STATE>"   (full trim in level flight, time 0)
    step <elevator_rad> <throttle_ratio>        -> "ok <STATE>"   (one JSBSim frame of dt_s)
    cmd <command> <throttle_ratio>              -> "ok <STATE>"   (one frame; fly-by-wire: the stick's
                                                   normalised pitch command to the FCS, pull +)
    quit                                        -> (exits 0)
    anything wrong                              -> "error <message>" (the bridge keeps running)

STATE is the fields of STATE_FIELDS in that order (SI, Python repr, round-trip exact). The elevator is
given in radians (positive trailing edge down, JSBSim's convention) and turned into
`fcs/elevator-cmd-norm` through the aircraft's own "elevator-pos-rad" aerosurface_scale (read from its
XML), with the pitch trim folded in; `throttle_ratio` scales the trim throttle of every engine. A
fly-by-wire aircraft (FLY_BY_WIRE) is commanded through its flight control system instead: `cmd` writes
`fcs/elevator-cmd-norm` (JSBSim's sign: negative = aft stick), the trim the FCS found stays in
`fcs/pitch-trim-cmd-norm`.

JSBSim writes its banner and reports to the C-level stdout; this script moves fd 1 to stderr before
importing jsbsim and keeps a private duplicate of the original stdout for the protocol. The aircraft is
loaded from a copy of its XML without network <input port=...> elements (the bundled 737 opens sockets
otherwise), shared with python/jsbsim_reference.py.

    "$(scripts/python-env.sh)" python/jsbsim_bridge.py      # then type: init c172p 50 1000 0.008333333333333333
"""
from __future__ import annotations

import os
import sys
import traceback
import xml.etree.ElementTree as ET
from pathlib import Path

STATE_FIELDS = [
    "t_s", "u_m_s", "w_m_s", "q_rad_s", "theta_rad", "altitude_m", "airspeed_m_s", "alpha_rad",
    "alphadot_rad_s", "qbar_pa", "qbar_elevator_pa", "mach", "nz_g", "elevator_rad", "throttle",
    "thrust_n",
]


def main() -> int:
    # Protocol channel: a duplicate of the original stdout; fd 1 (C and Python) now goes to stderr.
    sys.stdout.flush()
    proto = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr

    def reply(line: str):
        proto.write(line.replace("\n", " ") + "\n")
        proto.flush()

    try:
        import jsbsim  # noqa: F401  (imported after the redirection: its banner goes to stderr)
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        import jsbsim_reference as ref
    except Exception as e:  # ImportError and anything the wheel raises
        reply(f"error cannot import jsbsim ({type(e).__name__}: {e}); install it with: bash scripts/python-env.sh")
        return 2
    reply(f"ready {jsbsim.__version__}")

    fl = None
    for line in sys.stdin:
        words = line.split()
        if not words:
            continue
        try:
            if words[0] == "quit":
                return 0
            elif words[0] == "init" and len(words) == 5:
                fl = Live(jsbsim, ref, words[1], float(words[2]), float(words[3]), float(words[4]))
                reply("ok " + fl.state())
            elif words[0] in ("step", "cmd") and len(words) == 3:
                if fl is None:
                    reply(f"error {words[0]} before init")
                    continue
                if words[0] == "step":
                    fl.step(float(words[1]), float(words[2]))
                else:
                    fl.command(float(words[1]), float(words[2]))
                reply("ok " + fl.state())
            else:
                reply(f"error unknown request: {line.strip()!r} (expected init/step/cmd/quit)")
        except Exception as e:
            traceback.print_exc(file=sys.stderr)
            reply(f"error {type(e).__name__}: {e}")
    return 0


def elevator_scale(xml_path: Path) -> tuple[float, float]:
    """(min_rad, max_rad) of the aerosurface_scale writing fcs/elevator-pos-rad (zero-centred, domain -1..1)."""
    root = ET.parse(xml_path).getroot()
    for el in root.iter("aerosurface_scale"):
        out = el.find("output")
        if out is not None and out.text and out.text.strip() == "fcs/elevator-pos-rad":
            gain = float(el.findtext("gain", "1"))
            lo = float(el.find("range").findtext("min")) * gain
            hi = float(el.find("range").findtext("max")) * gain
            return lo, hi
    raise ValueError(f"{xml_path}: no aerosurface_scale with output fcs/elevator-pos-rad")


# Fly-by-wire aircraft of JSBSim's package flown through their FCS (`cmd`); loaded from the package's
# own folder (their XML opens no network port).
FLY_BY_WIRE = {"f16"}


class Live:
    def __init__(self, jsbsim, ref, aircraft: str, airspeed_m_s: float, altitude_m: float, dt_s: float):
        """`aircraft`: a name of the JSBSim package's aircraft, or the path of an aircraft folder holding
        `<folder name>.xml` (engines and systems from the package's folders, as JSBSim finds them)."""
        if "/" in aircraft or os.sep in aircraft:
            folder = Path(aircraft)
            adir, name = folder.parent, folder.name
        elif aircraft in ref.AIRCRAFT:
            adir, name = ref.offline_aircraft_dir(jsbsim, aircraft), aircraft
        elif aircraft in FLY_BY_WIRE:
            adir, name = Path(jsbsim.get_default_root_dir()) / "aircraft", aircraft
        else:
            known = sorted(set(ref.AIRCRAFT) | FLY_BY_WIRE)
            raise ValueError(f"aircraft {aircraft!r} not supported (one of {known}, or a folder path)")
        self.fdm = jsbsim.FGFDMExec(root_dir=jsbsim.get_default_root_dir())
        f = self.fdm
        f.set_debug_level(0)
        f.set_aircraft_path(str(adir))
        f.load_model(name)
        f.set_dt(dt_s)
        self.lo, self.hi = elevator_scale(adir / name / f"{name}.xml")
        f["ic/lat-geod-deg"] = ref.LATITUDE_DEG
        f["ic/long-gc-deg"] = 0.0
        f["ic/h-sl-ft"] = altitude_m / ref.FT_TO_M
        f["ic/vt-fps"] = airspeed_m_s / ref.FT_TO_M
        f["ic/gamma-deg"] = 0.0
        f["ic/psi-true-deg"] = 0.0
        f["propulsion/fuel_freeze"] = 1
        f["gear/gear-cmd-norm"] = 0.0
        f["fcs/flap-cmd-norm"] = 0.0
        f.run_ic()
        f["propulsion/set-running"] = -1
        f.do_trim(1)
        self.t0 = f["simulation/sim-time-sec"]
        self.engines = f.get_propulsion().get_num_engines()
        self.trim_throttle = [f[f"fcs/throttle-cmd-norm[{k}]"] for k in range(self.engines)]
        self.pitch_trim = f["fcs/pitch-trim-cmd-norm"]
        # An aircraft whose elevator sees the propeller's slipstream (the c172p) has qbar-induced-psf.
        self.has_induced = f.get_property_manager().hasNode("aero/function/qbar-induced-psf")
        self.ref = ref

    def step(self, elevator_rad: float, throttle_ratio: float):
        f = self.fdm
        # Inverse of the zero-centred aerosurface_scale, then remove the pitch trim the summer adds.
        norm = elevator_rad / self.hi if elevator_rad >= 0.0 else elevator_rad / -self.lo
        norm = max(-1.0, min(1.0, norm))
        f["fcs/elevator-cmd-norm"] = norm - self.pitch_trim
        for k in range(self.engines):
            f[f"fcs/throttle-cmd-norm[{k}]"] = max(0.0, min(1.0, self.trim_throttle[k] * throttle_ratio))
        f.run()

    def command(self, command: float, throttle_ratio: float):
        """One frame with the fly-by-wire stick command `command` in [-1, 1], pull (aft stick) positive."""
        f = self.fdm
        f["fcs/elevator-cmd-norm"] = -max(-1.0, min(1.0, command))
        for k in range(self.engines):
            f[f"fcs/throttle-cmd-norm[{k}]"] = max(0.0, min(1.0, self.trim_throttle[k] * throttle_ratio))
        f.run()

    def state(self) -> str:
        f, r = self.fdm, self.ref
        qbar = f["aero/qbar-psf"] * r.PSF_TO_PA
        qbar_e = f["aero/function/qbar-induced-psf"] * r.PSF_TO_PA if self.has_induced else qbar
        thrust = sum(f[f"propulsion/engine[{k}]/thrust-lbs"] for k in range(self.engines)) * r.LBF_TO_N
        vals = [
            f["simulation/sim-time-sec"] - self.t0,
            f["velocities/u-fps"] * r.FT_TO_M,
            f["velocities/w-fps"] * r.FT_TO_M,
            f["velocities/q-rad_sec"],
            f["attitude/theta-rad"],
            f["position/h-sl-ft"] * r.FT_TO_M,
            f["velocities/vt-fps"] * r.FT_TO_M,
            f["aero/alpha-rad"],
            f["aero/alphadot-rad_sec"],
            qbar,
            qbar_e,
            f["velocities/mach"],
            f["accelerations/Nz"],
            f["fcs/elevator-pos-rad"],
            f["fcs/throttle-pos-norm[0]"],
            thrust,
        ]
        return " ".join(repr(float(v)) for v in vals)


if __name__ == "__main__":
    sys.exit(main())
