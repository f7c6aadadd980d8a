#!/usr/bin/env python3
"""Read an mrfeel run recording (.rrd) back with the Rerun SDK and check it against the run's CSV.

Usage: rerun_readback.py RUN.rrd RUN.csv

Checks, for every time series logged by `mrfeel run --rerun` that has a CSV column, that the recording holds
one value per CSV row at the same times and that the values are the CSV's (to 1e-9 relative: the CSV prints
shortest round-trip decimals, the recording holds the f64s). Also checks that the rig's bodies were logged
with poses over time, that the view's up axis is +z, and that the force arrows (`/forces/hand` at the grip,
`/forces/damper` and `/forces/load_cell` at the piston, 1 mm per newton) have the CSV's forces at their times,
the hand's pointing aft (+x) on a pull. Exit status 0 on success; a message naming the entity and the first
mismatch otherwise.
"""

from __future__ import annotations

import csv
import math
import sys

import rerun as rr  # noqa: F401  (imported for its version check below)
from rerun.experimental import RrdReader

SERIES_TO_COLUMN = {
    "/signals/force/desired": "desired_force_n",
    "/signals/force/load_cell": "load_cell_n",
    "/signals/force/load_cell_true": "load_cell_true_n",
    "/signals/force/damper": "damper_force_n",
    "/signals/current/command": "current_a",
    "/signals/stroke/piston_x": "piston_x_m",
    "/signals/pilot/force": "pilot_force_n",
    "/signals/stick/angle": "stick_angle_rad",
    "/signals/energy/dissipated": "dissipated_j",
    "/signals/faults/mask": "fault_mask",
}

# Logged only when the run flies an aircraft (the CSV then has these columns too).
AIRCRAFT_SERIES_TO_COLUMN = {
    "/signals/aircraft/pitch": "pitch_rad",
    "/signals/aircraft/pitch_cmd": "pitch_cmd_rad",
    "/signals/aircraft/nz": "nz_g",
    "/signals/aircraft/nz_cmd": "nz_cmd_g",
    "/signals/aircraft/elevator": "elevator_rad",
    "/signals/aircraft/hinge_moment": "hinge_moment_nm",
    "/signals/aircraft/qbar": "qbar_pa",
    "/signals/aircraft/stick_force": "stick_force_n",
    "/signals/aircraft/stick_cmd": "stick_cmd_rad",
}


def read_csv(path: str) -> dict[str, list[float]]:
    with open(path, newline="") as f:
        lines = [line for line in f if not line.startswith("#")]
    rows = list(csv.DictReader(lines))
    return {k: [float(r[k]) for r in rows] for k in rows[0]}


# The force arrows and the CSV column each one draws: (column, sign of the arrow against the column).
ARROWS = {
    "/forces/hand": ("pilot_force_n", 1.0),
    "/forces/damper": ("damper_force_n", -1.0),
    "/forces/load_cell": ("load_cell_true_n", 1.0),
}
ARROW_M_PER_N = 1e-3


def read_rrd(path: str):
    """Series samples as (time ns, value) per entity; arrows as (time ns, vector, origin) per entity; the
    number of temporal rows per other entity (and the static view coordinates at `/`)."""
    series: dict[str, list[tuple[int, float]]] = {}
    arrows: dict[str, list] = {}
    others: dict = {}
    for chunk in RrdReader(path).stream():
        ent = chunk.entity_path
        batch = chunk.to_record_batch()
        names = batch.schema.names
        if chunk.is_static:
            if ent == "/":
                others["/ static view coordinates"] = [
                    batch.column(n).to_pylist()[-1] for n in names if n.endswith(":xyz")
                ]
            continue
        if ent in ARROWS:
            tcol = [n for n in names if n == "time"]
            vcol = [n for n in names if n.endswith(":vectors")]
            ocol = [n for n in names if n.endswith(":origins")]
            if not tcol or not vcol or not ocol:
                raise SystemExit(f"{ent}: unexpected columns {names}")
            times = batch.column(tcol[0]).cast("int64").to_pylist()
            for t, v, o in zip(times, batch.column(vcol[0]).to_pylist(), batch.column(ocol[0]).to_pylist()):
                arrows.setdefault(ent, []).append((t, v[0], o[0]))
            continue
        if ent in SERIES_TO_COLUMN or ent in AIRCRAFT_SERIES_TO_COLUMN:
            tcol = [n for n in names if n == "time"]
            vcol = [n for n in names if n.endswith("Scalars:scalars") or n.endswith(":scalars")]
            if not tcol or not vcol:
                raise SystemExit(f"{ent}: unexpected columns {names}")
            times = batch.column(tcol[0]).cast("int64").to_pylist()
            values = batch.column(vcol[0]).to_pylist()
            for t, v in zip(times, values):
                # A NaN (e.g. the command of the loop not flown) may come back as a null.
                series.setdefault(ent, []).append((t, math.nan if v is None else float(v[0])))
        else:
            others[ent] = others.get(ent, 0) + batch.num_rows
    return series, arrows, others


def read_blueprint(path: str) -> tuple[list[tuple[str, str, str, list[str]]], list[int]]:
    """The default blueprint's views as (class, name, origin, contents queries), and its containers' kinds."""
    reader = RrdReader(path)
    views: dict[str, dict] = {}
    kinds: list[int] = []
    for store in reader.blueprints():
        for chunk in reader.stream(store=store):
            batch = chunk.to_record_batch()
            ent = chunk.entity_path
            for n in batch.schema.names:
                if ":" not in n:
                    continue  # row ids and the blueprint's timelines
                values = batch.column(n).to_pylist()
                if not values or values[-1] is None:
                    continue
                last = values[-1]
                if n == "ContainerBlueprint:container_kind":
                    kinds.append(last[0])
                elif n.startswith("ViewBlueprint:"):
                    views.setdefault(ent, {})[n.split(":")[1]] = last[0]
                elif n == "ViewContents:query":
                    views.setdefault(ent.removesuffix("/ViewContents"), {})["query"] = last
    out = [
        (v.get("class_identifier"), v.get("display_name"), v.get("space_origin"), v.get("query") or [])
        for v in views.values()
        if "class_identifier" in v
    ]
    return out, kinds


def check_blueprint(path: str) -> str | None:
    """None if the default blueprint shows the 3D rig with its forces beside the force and current plots."""
    views, kinds = read_blueprint(path)
    if not views:
        return "no blueprint in the recording"
    rig = [v for v in views if v[0] == "3D"]
    if len(rig) != 1 or not {"+ /rig/**", "+ /forces/**"} <= set(rig[0][3]):
        return f"no 3D view of /rig/** and /forces/** in the blueprint: {views}"
    origins = {v[2] for v in views if v[0] == "TimeSeries"}
    if not {"/signals/force", "/signals/current"} <= origins:
        return f"no force and current plots in the blueprint: {views}"
    # ContainerKind: 2 = horizontal (the rig beside the plots), 3 = vertical (the plots stacked).
    if 2 not in kinds:
        return f"the blueprint does not put the rig beside the plots (containers {kinds})"
    return None


def main() -> int:
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    rrd, csv_path = sys.argv[1], sys.argv[2]
    table = read_csv(csv_path)
    series, arrows, others = read_rrd(rrd)
    t_csv = [round(t * 1e9) for t in table["t_s"]]
    flight = "pitch_rad" in table
    wanted = dict(SERIES_TO_COLUMN)
    if flight:
        wanted.update(AIRCRAFT_SERIES_TO_COLUMN)
    for ent, col in wanted.items():
        got = sorted(series.get(ent, []))
        if len(got) != len(t_csv):
            print(f"FAIL {ent}: {len(got)} samples in the recording, {len(t_csv)} rows in the CSV")
            return 1
        for k, ((t, v), tc, vc) in enumerate(zip(got, t_csv, table[col])):
            if t != tc:
                print(f"FAIL {ent}: sample {k} at t = {t} ns, CSV row at {tc} ns")
                return 1
            if math.isnan(v) and math.isnan(vc):
                continue
            if not math.isclose(v, vc, rel_tol=1e-9, abs_tol=1e-12):
                print(f"FAIL {ent} vs column {col}: sample {k} (t = {tc * 1e-9} s): recording {v!r}, CSV {vc!r}")
                return 1
        print(f"ok {ent} == CSV {col} ({len(got)} samples)")
    why = check_blueprint(rrd)
    if why:
        print(f"FAIL blueprint: {why}")
        return 1
    print("ok blueprint: the 3D rig and its forces beside the force and current plots")
    up = others.pop("/ static view coordinates", None)
    # ViewCoordinates RIGHT_HAND_Z_UP: x right, y forward, z up (Rerun's ViewDir codes 3, 5, 1).
    if up is None or up[0] != [[3, 5, 1]]:
        print(f"FAIL: the recording's view coordinates at / are {up}, not right-handed z up")
        return 1
    print("ok view coordinates: right-handed, z up")
    # An arrow drawn at a frame's time shows the row nearest that time (the physics step of the frame).
    dt = table["t_s"][1] - table["t_s"][0] if len(t_csv) > 1 else 1.0

    def row_at(t_ns: int) -> int:
        return min(round(t_ns * 1e-9 / dt), len(t_csv) - 1)

    for ent, (col, sign) in ARROWS.items():
        got = arrows.get(ent, [])
        if len(got) < 2:
            print(f"FAIL {ent}: {len(got)} arrows logged over time")
            return 1
        for t, v, o in got:
            k = row_at(t)
            if abs(t_csv[k] - t) > dt * 1e9:
                print(f"FAIL {ent}: arrow at t = {t} ns, no CSV row near that time")
                return 1
            f = table[col][k]
            length = math.hypot(*v)
            if not math.isclose(length, abs(f) * ARROW_M_PER_N, rel_tol=1e-5, abs_tol=1e-7):
                print(f"FAIL {ent}: arrow at t = {t * 1e-9} s is {length} m long, CSV {col} = {f} N")
                return 1
            if ent == "/forces/hand":
                # A pull (+) points aft (+x) while the stick is within 57° of upright.
                if abs(f) > 1.0 and abs(table["stick_angle_rad"][k]) < 1.0 and (v[0] > 0) != (f > 0):
                    print(f"FAIL {ent}: at t = {t * 1e-9} s the hand force {f} N draws {v}")
                    return 1
            elif (v[1], v[2]) != (0.0, 0.0):
                print(f"FAIL {ent}: at t = {t * 1e-9} s the arrow {v} is not along the damper axis x")
                return 1
            elif abs(f) > 1e-3 and (v[0] > 0) != (sign * f > 0):
                print(f"FAIL {ent}: at t = {t * 1e-9} s, {col} = {f} N draws {v}")
                return 1
        print(f"ok {ent} == CSV {col} x {sign:+g} mm/N ({len(got)} arrows)")
    bodies = {e: n for e, n in others.items() if e.startswith("/rig/")}
    moving = [e for e, n in bodies.items() if n > 1]
    if not moving:
        print(f"FAIL: no rig body logged with poses over time (temporal entities: {sorted(others)})")
        return 1
    print(f"ok rig bodies with poses over time: {sorted(moving)}")
    if flight:
        if others.get("/aircraft", 0) < 2:
            print("FAIL: the aircraft's attitude was not logged over time")
            return 1
        print(f"ok aircraft attitude over time ({others['/aircraft']} poses)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
