"""A sweep's results file (Parquet) is read by pandas as written: the CSV's rows and columns,
typed, with the physics of each run in its row."""

import pandas as pd
import pyarrow  # noqa: F401  (pandas reads Parquet through it)

from conftest import ROOT, cli

PLAN = """name = "two-gradients"
scenario = "{scenario}"
seed = 5

[[axis]]
key = "duration_s"
values = [0.6]

[[axis]]
key = "feel.gradient_n_per_m"
values = [800.0, 1600.0]
"""


def test_pandas_reads_the_sweep_results_as_the_csv(tmp_path):
    plan = tmp_path / "plan.toml"
    plan.write_text(PLAN.format(scenario=ROOT / "scenarios" / "paper-feel-loop.toml"))
    out = tmp_path / "out"
    cli("sweep", plan, "--out", out, "--jobs", "1")
    arrow = pd.read_parquet(out / "results.parquet")
    csv = pd.read_csv(out / "results.csv")
    assert list(arrow.columns) == list(csv.columns)
    assert len(arrow) == len(csv) == 2
    assert str(arrow["index"].dtype) == "uint64"
    assert arrow["index"].tolist() == [0, 1]
    assert arrow["feel.gradient_n_per_m"].tolist() == [800.0, 1600.0]
    # Every number as the CSV prints it (shortest round trip), so equal exactly.
    for c in ("seed", "grip_force_peak_n", "force_tracking_rmse_n", "current_max_a"):
        assert arrow[c].tolist() == csv[c].tolist(), c
    assert arrow["far_temporary_ok"].dtype == bool
    # The rows are the runs they say: in 0.6 s the pilot takes the stick to about 10° (piston ~25 mm out),
    # where the doubled gradient asks the pilot to push harder.
    soft, stiff = arrow["grip_force_peak_n"]
    assert stiff > 1.4 * soft, (soft, stiff)
