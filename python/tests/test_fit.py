"""Fits from Python are the command line's fits: the same parameters to the bit, the same PARAMS.json, the same
figures; predictions and scores follow the saved model."""

import json

import numpy as np
import pytest

import mrfeel
from conftest import DATA, cli, measurement_from_arrays, read_columns

# Two protocols of the real damper, each at two currents: enough to fit `bingham` jointly in seconds.
FILES = [DATA / n for n in ("10mm1Hz_0p00A.csv", "10mm1Hz_1p00A.csv", "2mm5Hz_0p00A.csv", "2mm5Hz_1p00A.csv")]


@pytest.fixture(scope="module")
def cli_fit(tmp_path_factory):
    saved = tmp_path_factory.mktemp("cli") / "PARAMS.json"
    out = cli("fit", *FILES, "--model", "bingham", "--json", "--save", saved)
    return json.loads(out.stdout), saved


def test_fit_on_numpy_arrays_gives_the_cli_parameters_to_the_bit(cli_fit, tmp_path):
    report, saved = cli_fit
    ms = [measurement_from_arrays(p) for p in FILES]
    model = mrfeel.Model("bingham").fit(ms)
    want = json.loads(saved.read_text())["params"]
    got = model.params
    assert set(got) == set(want)
    for name, p in want.items():
        assert got[name]["value"] == p["value"], name  # bit for bit: JSON numbers round-trip exactly
        assert got[name]["std_err"] == p["std_err"], name
        assert got[name]["unit"] == p["unit"], name
    # Saved from Python: the very bytes `mrfeel fit --save` wrote.
    model.save(tmp_path / "py.json")
    assert (tmp_path / "py.json").read_bytes() == saved.read_bytes()
    # And the fit's report is `fit --json`, paths aside (arrays are named by their file names).
    r = model.fit_report
    assert (r["nrmse"], r["rmse_n"], r["samples"]) == (report["nrmse"], report["rmse_n"], report["samples"])


def test_a_model_loaded_from_the_cli_scores_as_validate_reports(cli_fit):
    _, saved = cli_fit
    model = mrfeel.Model.load(saved)
    held = DATA / "25mm0p25Hz_0p50A.csv"
    want = json.loads(cli("validate", held, "--params", saved, "--json").stdout)
    got = model.score(mrfeel.Measurement.from_csv(held))
    assert got["nrmse"] == want["nrmse"] and got["rmse_n"] == want["rmse_n"]
    assert got["samples"] == want["samples"] == len(read_columns(held)["t_s"])
    # A fitted Bingham model of a real damper is no perfect model, and no useless one.
    assert 0.02 < got["nrmse"] < 0.5


def test_predict_on_new_motion_follows_the_bingham_law(cli_fit):
    """On a slow sine at a steady current the force is yield plus viscous: it changes sign with the velocity,
    its magnitude grows with the current, and at mid-stroke (largest speed) it is the largest."""
    _, saved = cli_fit
    model = mrfeel.Model.load(saved)
    t = np.arange(0, 4.0, 1e-3)
    x = 0.005 * np.sin(2 * np.pi * 0.5 * t)
    v = 0.005 * 2 * np.pi * 0.5 * np.cos(2 * np.pi * 0.5 * t)
    lo = model.predict(t, x, np.full_like(t, 0.0), v=v)
    hi = model.predict(t, x, np.full_like(t, 1.0), v=v)
    assert lo.shape == t.shape and lo.dtype == np.float64
    late = t > 2.0  # after the lags have settled
    fast = late & (np.abs(v) > 0.5 * np.abs(v).max())
    assert np.all(np.sign(hi[fast]) == np.sign(v[fast])), "a damper resists the motion"
    assert np.sqrt(np.mean(hi[late] ** 2)) > 1.5 * np.sqrt(np.mean(lo[late] ** 2)), "more current, more force"
    # The same motion as a Measurement (its force unused) predicts the same force.
    m = mrfeel.Measurement.from_arrays(t, x, np.full_like(t, 1.0), np.ones_like(t), v=v)
    assert np.array_equal(model.predict(m), hi)


def test_bad_arrays_raise_with_the_column_and_the_sample():
    t = np.arange(100) * 1e-3
    x = np.sin(t)
    i = np.zeros(100)
    f = np.ones(100)
    bad = x.copy()
    bad[17] = np.nan
    with pytest.raises(mrfeel.Error, match=r"column `x_m`, sample 17: NaN is not a measurement"):
        mrfeel.Measurement.from_arrays(t, bad, i, f)
    with pytest.raises(mrfeel.Error, match=r"column `f_n` has 99 samples, `t_s` has 100"):
        mrfeel.Measurement.from_arrays(t, x, i, f[:-1])
    back = t.copy()
    back[40] = back[39]
    with pytest.raises(mrfeel.Error, match=r"column `t_s`, sample 40: time 0.039 s is not after the previous"):
        mrfeel.Measurement.from_arrays(back, x, i, f, name="rig-7")
    with pytest.raises(mrfeel.Error, match=r"^rig-7: column `i_a`, sample 3: infinite value"):
        ii = i.copy()
        ii[3] = np.inf
        mrfeel.Measurement.from_arrays(t, x, ii, f, name="rig-7")
    with pytest.raises(mrfeel.Error, match=r"column `x_m`: expected a 1-D array"):
        mrfeel.Measurement.from_arrays(t, np.zeros((100, 2)), i, f)
    # A fit of a force never measured is refused with the command line's message.
    with pytest.raises(mrfeel.Error, match=r"column `f_n` is zero in every one of the 100 samples"):
        mrfeel.Model("bingham").fit(mrfeel.Measurement.from_arrays(t, x, i, np.zeros(100)))


def test_bad_files_and_options_raise_the_cli_messages(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("t_s,x_m,i_a,f_n\n0,0,0,1\n0.001,abc,0,1\n")
    want = cli("fit", bad, check=False).stderr.strip().removeprefix("error: ")
    with pytest.raises(mrfeel.Error) as e:
        mrfeel.Measurement.from_csv(bad)
    assert str(e.value) == want
    assert f"{bad}:3: column `x_m`: not a number (value `abc`)" in str(e.value)
    with pytest.raises(mrfeel.Error, match="unknown effect|no effect|not a known"):
        mrfeel.Model("bingham+no_such_effect")
    with pytest.raises(mrfeel.Error, match=r"weighting `files`: expected one of tests, samples"):
        mrfeel.Model().fit(FILES[0], weighting="files")
    with pytest.raises(mrfeel.Error, match=r"no parameters yet"):
        mrfeel.Model().predict(np.arange(3.0), np.zeros(3), np.zeros(3))
