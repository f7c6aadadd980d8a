#!/usr/bin/env bash
# The main job of mrfeel: every result into OUT (default out/): CSV, PNG/SVG plots, Rerun recordings.
# Needs no Python. Open a recording with the Rerun viewer: `rerun out/paper-feel-loop.rrd`.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out="${1:-out}"
data="data/utfsm-mr-damper"
mkdir -p "$out"/{mts,diagnose,fit,daq-sweep,compare,flight}
cargo build --locked --quiet
mrfeel=target/debug/mrfeel

step() { printf '\n== %s\n' "$*"; }

step "1. The paper's MTS test (Section 4): steady force at 2.2, 5 and 14 A, force-displacement and force-velocity plots"
"$mrfeel" mts --current 2.2,5,14 --protocol sine --amplitude-m 0.0254 --frequency-hz 0.5 \
    --out "$out/mts/paper-mts.csv" --plot "$out/mts"

step "2. The paper's feel loop (Section 6): pilot moves the stick, PID asks the MR damper for a force law up to 70 N"
"$mrfeel" run scenarios/paper-feel-loop.toml --out "$out/paper-feel-loop.csv" --rerun "$out/paper-feel-loop.rrd"

step "3. Force response time against the DAQ sample rate (100 Hz to 5 kHz)"
"$mrfeel" daq-sweep scenarios/response-time.toml --plot "$out/daq-sweep"

step "4. Model discovery on the real MR damper: where Bingham fails, the missing effect, the error falling"
"$mrfeel" diagnose "$data" --plot "$out/diagnose" --rerun "$out/diagnose.rrd"
"$mrfeel" fit "$data" --model bingham+hysteresis+current_viscosity --heldout \
    --save "$out/utfsm-bingham+hysteresis+current_viscosity.json" --plot "$out/fit"

step "5. Pilot-in-the-loop flight: c172p pitch tracking, the hinge moment chooses the feel force"
"$mrfeel" run scenarios/c172p-pitch-tracking.toml --out "$out/c172p-pitch-tracking.csv" --rerun "$out/c172p-pitch-tracking.rrd"

step "5b. A pull-up in each aircraft: stick force against load factor, flown and steady, against its basis's band"
for scn in c172p-pullup T37-pullup 737-approach; do
    "$mrfeel" run "scenarios/$scn.toml" --out "$out/flight/$scn.csv" --plot "$out/flight"
done

step "6. Feel systems compared (springs, MR, hybrid) and under faults"
"$mrfeel" compare scenarios/compare-feel.toml --plot "$out/compare" --rerun "$out/compare.rrd" --faults

printf '\nAll results are in %s/\n' "$out"
