#!/usr/bin/env python3
"""Read an mrfeel run recording (.rrd) back with the Rerun SDK and check it against the run's CSV.

Usage: rerun_readback.py RUN.rrd RUN.csv

Checks, for every time series logged by `mrfeel run --rerun` that has a CSV column, that the recording holds
one value per CSV row at the same times and that the values are the CSV's (to 1e-9 relative: the CSV prints
shortest round-trip decimals, the recording holds the f64s). Also checks that the rig's bodies were logged
with poses over time. Exit status 0 on success; a message naming the series and the first mismatch otherwise.
"""

from __future__ import annotations

import csv
import math
import sys

import rerun as rr  # noqa: F401  (imported for its version check below)
from rerun.experimental import RrdReader

SERIES_TO_COLUMN = {
    "/series/force/desired": "desired_force_n",
    "/series/force/load_cell": "load_cell_n",
    "/series/force/load_cell_true": "load_cell_true_n",
    "/series/force/damper": "damper_force_n",
    "/series/current/command": "current_a",
    "/series/stroke/piston_x": "piston_x_m",
    "/series/pilot/force": "pilot_force_n",
    "/series/stick/angle": "stick_angle_rad",
    "/series/energy/dissipated": "dissipated_j",
    "/series/faults/mask": "fault_mask",
}

# Logged only when the run flies an aircraft (the CSV then has these columns too).
AIRCRAFT_SERIES_TO_COLUMN = {
    "/series/aircraft/pitch": "pitch_rad",
    "/series/aircraft/pitch_cmd": "pitch_cmd_rad",
    "/series/aircraft/nz": "nz_g",
    "/series/aircraft/nz_cmd": "nz_cmd_g",
    "/series/aircraft/elevator": "elevator_rad",
    "/series/aircraft/hinge_moment": "hinge_moment_nm",
    "/series/aircraft/qbar": "qbar_pa",
    "/series/aircraft/stick_force": "stick_force_n",
    "/series/aircraft/stick_cmd": "stick_cmd_rad",
}


def read_csv(path: str) -> dict[str, list[float]]:
    with open(path, newline="") as f:
        lines = [line for line in f if not line.startswith("#")]
    rows = list(csv.DictReader(lines))
    return {k: [float(r[k]) for r in rows] for k in rows[0]}


def read_rrd(path: str) -> tuple[dict[str, list[tuple[int, float]]], dict[str, int]]:
    """Series samples as (time ns, value) per entity, and the number of temporal rows per other entity."""
    series: dict[str, list[tuple[int, float]]] = {}
    others: dict[str, int] = {}
    for chunk in RrdReader(path).stream():
        ent = chunk.entity_path
        if chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        names = batch.schema.names
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
    return series, others


def main() -> int:
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    rrd, csv_path = sys.argv[1], sys.argv[2]
    table = read_csv(csv_path)
    series, others = read_rrd(rrd)
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
