#!/usr/bin/env bash
# The main job of mrfeel: every result into OUT (default out/): CSV, PNG/SVG plots, Rerun recordings.
# Needs no Python and nothing beside the repository. Open a recording with the Rerun viewer:
# `rerun out/paper-feel-loop.rrd`.
#   MRFEEL_BIN=path/to/mrfeel   run that binary instead of building one (`cargo build`)
#   MRFEEL_STEPS="1 4"          run only these steps (default: all, 1 to 8)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out="${1:-out}"
data="data/utfsm-mr-damper"
mkdir -p "$out"/{mts,diagnose,fit,daq-sweep,compare,flight}
mrfeel="${MRFEEL_BIN:-}"
if [ -z "$mrfeel" ]; then
    cargo build --locked --quiet
    mrfeel=target/debug/mrfeel
fi
steps=" ${MRFEEL_STEPS:-1 2 3 4 5 6 7 8} "

# step N TITLE: whether step N runs (printing its title if so).
step() {
    [[ "$steps" == *" $1 "* ]] || return 1
    printf '\n== %s\n' "$*"
}

if step 1 "The paper's MTS test (Section 4): steady force at 2.2, 5 and 14 A, force-displacement and force-velocity plots"; then
    "$mrfeel" mts --current 2.2,5,14 --protocol sine --amplitude-m 0.0254 --frequency-hz 0.5 \
        --out "$out/mts/paper-mts.csv" --plot "$out/mts"
fi

if step 2 "The paper's feel loop (Section 6): pilot moves the stick, PID asks the MR damper for a force law up to 70 N"; then
    "$mrfeel" run scenarios/paper-feel-loop.toml --out "$out/paper-feel-loop.csv" --rerun "$out/paper-feel-loop.rrd"
fi

if step 3 "Force response time against the DAQ sample rate (100 Hz to 5 kHz)"; then
    "$mrfeel" daq-sweep scenarios/response-time.toml --plot "$out/daq-sweep"
fi

if step 4 "Model discovery on the real MR damper: where Bingham fails, the missing effect, the error falling"; then
    "$mrfeel" diagnose "$data" --plot "$out/diagnose" --rerun "$out/diagnose.rrd"
    "$mrfeel" fit "$data" --model bingham+hysteresis+current_viscosity --heldout \
        --save "$out/utfsm-bingham+hysteresis+current_viscosity.json" --plot "$out/fit"
fi

if step 5 "Pilot-in-the-loop flight: c172p pitch tracking, the hinge moment chooses the feel force"; then
    "$mrfeel" run scenarios/c172p-pitch-tracking.toml --out "$out/c172p-pitch-tracking.csv" --rerun "$out/c172p-pitch-tracking.rrd"
fi

if step 6 "Feel systems compared (springs, MR, hybrid) and under faults"; then
    "$mrfeel" compare scenarios/compare-feel.toml --plot "$out/compare" --rerun "$out/compare.rrd" --faults
fi

if step 7 "Feel design across the envelope: the c172p's five feel systems x airspeed x altitude x two pilots (200 runs), the F-16's designed feel (12 runs); handling-qualities verdicts, maps by Level"; then
    # A fresh directory: a sweep resumes from what its output directory already holds.
    rm -rf "$out/sweep-c172p-envelope"
    "$mrfeel" sweep scenarios/sweeps/c172p-envelope.toml --out "$out/sweep-c172p-envelope"
    # The F-16's designed sidestick feel over its envelope, on the embedded model and FCS (12 runs).
    rm -rf "$out/sweep-f16-envelope"
    "$mrfeel" sweep scenarios/sweeps/f16-envelope.toml --out "$out/sweep-f16-envelope"
fi

if step 8 "A pull-up in each aircraft: stick force against load factor, flown and steady, against its basis's band"; then
    # f16-pullup flies JSBSim live through its own FCS: it needs .venv with jsbsim
    for scn in c172p-pullup T37-pullup 737-approach f16-pullup; do
        "$mrfeel" run "scenarios/$scn.toml" --out "$out/flight/$scn.csv" --plot "$out/flight/$scn"
    done
fi

printf '\nAll results are in %s/\n' "$out"
