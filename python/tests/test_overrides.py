"""Scenario overrides from Python (`run_scenario(path, overrides=...)`) change the physics the way the key
says, and are refused with the key named; measurements reach pandas in SI units under their column names."""

import numpy as np
import pytest

import mrfeel
from conftest import DATA, ROOT, read_columns

SCN = ROOT / "scenarios" / "paper-feel-loop.toml"
# One 4 s stroke of the pilot's 0.25 Hz triangle: out to +16°, back through centre to -16°, back.
SHORT = {"duration_s": 4.0}


def stick_gradient(cols):
    """The force gradient the stick renders, N/m: the slope of |true load-cell force| over |piston
    position| where the feel resists the motion (the desired force along the velocity: the stick pushed
    out, where a damper can render a spring), between 5 and 20 mm out, below the feel's 70 N limit at
    either gradient below."""
    x, v, f = cols["piston_x_m"], cols["piston_v_m_s"], cols["load_cell_true_n"]
    m = (np.abs(x) > 0.005) & (np.abs(x) < 0.020) & (cols["desired_force_n"] * v > 0)
    assert m.sum() > 200, m.sum()
    slope, _ = np.polyfit(np.abs(x[m]), np.abs(f[m]), 1)
    return slope


def test_a_stiffer_feel_gradient_raises_the_stick_force_at_the_same_deflection():
    soft, _ = mrfeel.run_scenario(SCN, overrides={**SHORT, "feel.gradient_n_per_m": 700.0})
    stiff, summary = mrfeel.run_scenario(SCN, overrides={**SHORT, "feel.gradient_n_per_m": 1400})
    # The override of the duration took: 4 s at the scenario's 1 kHz.
    assert summary["duration_s"] == pytest.approx(4.0, abs=2e-3)
    assert len(stiff["t_s"]) == pytest.approx(4000, abs=2)
    g_soft, g_stiff = stick_gradient(soft), stick_gradient(stiff)
    # Each run renders its own gradient (the damper tracks the spring feel within 15 %), so doubling the
    # gradient doubles the force per metre of deflection.
    assert g_soft == pytest.approx(700.0, rel=0.15)
    assert g_stiff == pytest.approx(1400.0, rel=0.15)
    assert g_stiff / g_soft == pytest.approx(2.0, rel=0.15)


def test_an_unknown_override_key_is_refused_with_the_key_named():
    with pytest.raises(mrfeel.Error) as e:
        mrfeel.run_scenario(SCN, overrides={"feel.gradient_n_per_mm": 900.0})
    assert "feel.gradient_n_per_mm" in str(e.value)


def test_an_override_out_of_range_is_refused_with_the_key_and_range():
    with pytest.raises(mrfeel.Error) as e:
        mrfeel.run_scenario(SCN, overrides={"daq.sample_rate_hz": -5.0})
    msg = str(e.value)
    assert "daq.sample_rate_hz" in msg
    # The same refusal `mrfeel run --set` gives, but for where the override was written.
    assert "-5" in msg


def test_measurement_to_pandas_has_the_columns_in_si_units():
    pd = pytest.importorskip("pandas")
    path = DATA / "10mm1Hz_1p00A.csv"
    df = mrfeel.Measurement.from_csv(path).to_pandas()
    assert isinstance(df, pd.DataFrame)
    assert list(df.columns) == ["t_s", "x_m", "v_m_s", "i_a", "f_n"]
    raw = read_columns(path)
    assert len(df) == len(raw["t_s"])
    # Metres, amperes, newtons and seconds as the file has them: the 10 mm, 1 Hz test at 1 A.
    assert np.array_equal(df["x_m"].to_numpy(), raw["x_m"])
    assert 0.009 < df["x_m"].abs().max() < 0.011
    assert np.array_equal(df["i_a"].to_numpy(), raw["i_a"])
    assert df["t_s"].iloc[-1] - df["t_s"].iloc[0] > 1.0
    # The velocity is in m/s: a 10 mm, 1 Hz sine peaks near 2π·0.01 ≈ 0.063 m/s.
    assert 0.045 < df["v_m_s"].abs().max() < 0.085


def test_the_f16_flies_embedded_from_python_and_holds_the_commanded_load_factor():
    """`aircraft.model = "f16"` swaps live JSBSim for the embedded model and FCS (no JSBSim process): the
    pilot's pull holds the scenario's 3 g over the last 1.5 s within 0.15 g, and the hand's force there is
    the designed law's (6.67 N breakout + 22.24 N/g) within 15 %."""
    cols, summary = mrfeel.run_scenario(
        ROOT / "scenarios" / "f16-pullup.toml", overrides={"aircraft.model": "f16"}
    )
    hold = cols["t_s"] >= 4.5
    nz = cols["nz_g"][hold].mean()
    hand = cols["pilot_force_n"][hold].mean()
    assert abs(nz - 3.0) < 0.15, nz
    designed = 6.672 + 22.24 * (nz - 1.0)
    assert abs(hand / designed - 1.0) < 0.15, (hand, designed)
