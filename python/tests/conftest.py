"""Shared helpers of the Python package's tests: the repository, the `mrfeel` command line beside the
package (the same library code), and measurement CSVs read as plain NumPy arrays."""

import os
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "data" / "utfsm-mr-damper"


def mrfeel_bin():
    """The `mrfeel` binary: $MRFEEL_BIN, else the debug build of this checkout (built if missing)."""
    env = os.environ.get("MRFEEL_BIN")
    if env:
        return env
    exe = ROOT / "target" / "debug" / "mrfeel"
    if not exe.exists():
        subprocess.run(["cargo", "build", "--quiet", "--bin", "mrfeel"], cwd=ROOT, check=True)
    return str(exe)


def cli(*args, check=True):
    """Run `mrfeel ARGS...`; the completed process (stdout and stderr as text)."""
    p = subprocess.run([mrfeel_bin(), *map(str, args)], capture_output=True, text=True, cwd=ROOT)
    if check and p.returncode != 0:
        raise AssertionError(f"mrfeel {' '.join(map(str, args))} failed:\n{p.stderr}")
    return p


def read_columns(path):
    """A measurement CSV's columns by name, parsed by NumPy (not by mrfeel): `# ` metadata skipped."""
    with open(path) as fh:
        lines = [line for line in fh if line.strip() and not line.lstrip().startswith("#")]
    header = [h.strip() for h in lines[0].split(",")]
    rows = np.array([[float(x) for x in line.split(",")] for line in lines[1:]], dtype=np.float64)
    return {name: rows[:, k] for k, name in enumerate(header)}


def measurement_from_arrays(path):
    """`mrfeel.Measurement.from_arrays` of a CSV parsed by NumPy, named as the file."""
    import mrfeel

    c = read_columns(path)
    return mrfeel.Measurement.from_arrays(
        c["t_s"], c["x_m"], c["i_a"], c["f_n"], v=c.get("v_m_s"), name=pathlib.Path(path).name
    )


@pytest.fixture
def tmp(tmp_path):
    return tmp_path
