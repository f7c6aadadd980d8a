"""`mrfeel.diagnose` is `mrfeel diagnose --json`, and finds an effect hidden in synthetic tests; a scenario run
from Python is `mrfeel run`'s CSV and summary."""

import json

import numpy as np
import pytest

import mrfeel
from conftest import DATA, ROOT, cli, measurement_from_arrays, read_columns


@pytest.fixture(scope="module")
def hidden_inertia(tmp_path_factory):
    """Three tests of one device with a hidden mass (`mrfeel mts --effects inertia`, then the saved device
    again under another amplitude, frequency, seed and sample rate)."""
    d = tmp_path_factory.mktemp("mts")
    truth = d / "truth.json"
    runs = [
        ["--effects", "inertia", "--amplitude-m", "0.02", "--frequency-hz", "1", "--save-device", truth],
        ["--device", truth, "--amplitude-m", "0.01", "--frequency-hz", "2", "--seed", "2"],
        ["--device", truth, "--protocol", "multisine", "--amplitude-m", "0.02", "--frequency-hz", "0.5",
         "--seed", "3", "--sample-rate-hz", "500", "--no-velocity"],
    ]
    files = []
    for k, r in enumerate(runs):
        out = d / f"run{k}.csv"
        cli("mts", "--current", "0,7,14", "--cycles", "2", *r, "--out", out)
        files.append(out)
    return files


def test_diagnose_on_arrays_names_the_hidden_mass_and_is_the_cli_json(hidden_inertia):
    # The arrays as NumPy read them, named as the command line names the files.
    ms = [measurement_from_arrays(p) for p in hidden_inertia]
    for m, p in zip(ms, hidden_inertia):
        m2 = mrfeel.Measurement.from_arrays(m.t, m.x, m.i, m.f, v=m.v if m.velocity_measured else None, name=str(p))
        assert len(m2) == len(read_columns(p)["t_s"])
    named = [
        mrfeel.Measurement.from_arrays(m.t, m.x, m.i, m.f, v=m.v if m.velocity_measured else None, name=str(p))
        for m, p in zip(ms, hidden_inertia)
    ]
    d = mrfeel.diagnose(named)
    got = d.to_dict()
    assert got["missing"] == ["inertia"], got
    assert got["final"]["heldout_nrmse"] <= 0.5 * got["base"]["heldout_nrmse"]
    # The fitted final model carries the mass the data hide.
    truth = json.loads((hidden_inertia[0].parent / "truth.json").read_text())
    mass = truth["params"]["inertia_mass_kg"]["value"]
    fin = d.final_model
    assert fin.spec == "bingham+inertia"
    assert abs(fin.params["inertia_mass_kg"]["value"] / mass - 1) < 0.2
    # Exactly the command line's JSON on the same files.
    want = json.loads(cli("diagnose", *hidden_inertia, "--json").stdout)
    assert got == want
    # The mass explains the data and the verdict finds no structure left: the Spencer base is not fitted.
    assert "unexplained" not in got, got
    spencer = [b for b in got["bases_tried"] if b["model"] == "spencer"]
    assert len(spencer) == 1 and spencer[0]["heldout_nrmse"] is None and not spencer[0]["chosen"], got


def test_run_scenario_equals_mrfeel_run_csv(tmp_path):
    scn = ROOT / "scenarios" / "paper-feel-loop.toml"
    csv = tmp_path / "run.csv"
    summary_cli = json.loads(cli("run", scn, "--out", csv, "--json").stdout)
    cols, summary = mrfeel.run_scenario(scn)
    want = read_columns(csv)
    assert list(cols) == list(want)
    for name, values in want.items():
        assert np.array_equal(cols[name], values), name  # the CSV prints shortest round-trip numbers
    assert summary == summary_cli
    # The run is a physical one: the pilot did work on the stick and the energy balance closes.
    assert summary["pilot_work_j"] > 0
    assert abs(summary["energy_residual"]) < 0.02


def test_run_scenario_errors_name_the_file_and_line(tmp_path):
    scn = tmp_path / "bad.toml"
    text = (ROOT / "scenarios" / "paper-feel-loop.toml").read_text()
    scn.write_text(text.replace("duration_s = 12.0", "duration_s = -1.0", 1))
    # The CLI may print notes (a model file taken from the built-in set) before its error line.
    stderr = cli("run", scn, check=False).stderr.splitlines()
    want = next(l for l in stderr if l.startswith("error: ")).removeprefix("error: ")
    with pytest.raises(mrfeel.Error) as e:
        mrfeel.run_scenario(scn)
    assert str(e.value) == want
    assert f"{scn}:" in str(e.value)


def test_ctrl_c_stops_a_diagnosis_under_way():
    """SIGINT during a diagnosis (the GIL released, the work on another thread) raises KeyboardInterrupt
    promptly: the library's fits stop at their next evaluation instead of running the search to its end.
    The real damper's 15 files take tens of seconds to diagnose, so the signal lands well inside it."""
    import signal
    import subprocess
    import sys
    import time

    # Python's own Ctrl-C handler even when the test runs in a background job (whose SIGINT is ignored).
    code = (
        "import signal, sys, time, mrfeel\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "ms = [mrfeel.Measurement.from_csv(p) for p in sys.argv[1:]]\n"
        "print('ready', flush=True)\n"
        "try:\n"
        "    mrfeel.diagnose(ms)\n"
        "    print('finished')\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted', time.monotonic(), flush=True)\n"
    )
    files = sorted(DATA.glob("*.csv"))
    p = subprocess.Popen([sys.executable, "-c", code, *map(str, files)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "ready"
    time.sleep(1.0)  # into the search: the files are read
    sent = time.monotonic()
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=60)
    assert out.startswith("interrupted"), out
    assert float(out.split()[1]) - sent < 3.0, "stopped within a few evaluations"
