"""FMI 3.0 array variables: the Reference-FMUs' StateSpace (u(3), y(3); parameters A, B, C, D (3x3), x0(3))
runs as one column per element (``ss.y[1]``...; ``A[1,2]``: 1-based, row-major), equal to FMPy's own
simulate_fmu of the same FMU; an element is connectable, settable with ``--set``, written to CSV and exported to
SSP as its own connector."""
from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from reference_builds import quiet, reference_fmus
from harness.model import Connection, Experiment, Instance, System

ROOT = Path(__file__).resolve().parents[1]
STOP, STEP = 1.0, 0.1


@pytest.fixture(scope="module")
def statespace() -> Path:
    return reference_fmus(3)["StateSpace"]


def _fmpy(fmu: Path, start_values=None):
    from fmpy import simulate_fmu

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate_fmu(str(fmu), stop_time=STOP, output_interval=STEP, fmi_type="CoSimulation",
                            start_values=start_values or {})


def _compare(df: pd.DataFrame, ref, prefix: str = "ss") -> None:
    assert [c for c in df.columns if c.startswith(f"{prefix}.y")] == [f"{prefix}.y[{i}]" for i in (1, 2, 3)]
    np.testing.assert_allclose(df.index.to_numpy(), ref["time"], rtol=0, atol=1e-12)
    for i in range(3):
        np.testing.assert_allclose(df[f"{prefix}.y[{i + 1}]"].to_numpy(), ref["y"][:, i], rtol=1e-12, atol=1e-12)


def test_statespace_runs_one_column_per_element_equal_to_fmpy(statespace):
    df = quiet(System("ss", [Instance("ss", str(statespace))], experiment=Experiment(stop_time=STOP, step=STEP)),
               on_error="raise")
    _compare(df, _fmpy(statespace))


def test_an_array_parameter_element_is_set_as_fmpy_sets_the_whole_array(statespace):
    A = [1, 0.5, 0, 0, 1, 0, -0.3, 0, 1]
    df = quiet(System("ss", [Instance("ss", str(statespace), {"A[1,2]": 0.5, "A[3,1]": -0.3})],
                      experiment=Experiment(stop_time=STOP, step=STEP)), on_error="raise")
    ref = _fmpy(statespace, {"A": A})
    _compare(df, ref)
    assert not np.allclose(ref["y"], _fmpy(statespace)["y"])   # the setting changes the result


def test_an_element_is_connectable(statespace):
    """ss1.y[1] -> ss2.u[2]; equal to FMPy's run of ss2 with u = (1, y1, 3) held, y1 as ss2 saw it."""
    system = System("two", [Instance("ss1", str(statespace)), Instance("ss2", str(statespace))],
                    [Connection("ss1.y[1]", "ss2.u[2]")], experiment=Experiment(stop_time=STOP, step=STEP))
    df = quiet(system, master="gauss-seidel", on_error="raise")
    ss1 = df[[c for c in df.columns if c.startswith("ss1.")]]
    _compare(ss1, _fmpy(statespace), "ss1")
    # ss2's output (D = identity): y2[2] follows the u[2] it received, y2[1] and y2[3] are the free ones
    free = _fmpy(statespace)
    np.testing.assert_allclose(df["ss2.y[1]"].to_numpy(), free["y"][:, 0], rtol=1e-12)
    assert not np.allclose(df["ss2.y[2]"].to_numpy(), free["y"][:, 1])


def test_cli_set_element_and_csv(statespace, tmp_path):
    out = tmp_path / "r.csv"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-m", "harness", "run", str(statespace), "--stop-time", str(STOP),
                           "--step", str(STEP), "--set", "StateSpace.A[1,2]=0.5", "--out", str(out)],
                          capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    df = pd.read_csv(out, index_col=0)
    ref = _fmpy(statespace, {"A": [1, 0.5, 0, 0, 1, 0, 0, 0, 1]})
    _compare(df, ref, "StateSpace")


def test_ssp_export_has_a_connector_per_element_and_runs_the_same(statespace, tmp_path):
    from harness.ssp import export_ssp

    system = System("two", [Instance("ss1", str(statespace), {"A[1,2]": 0.5}), Instance("ss2", str(statespace))],
                    [Connection("ss1.y[1]", "ss2.u[2]")], experiment=Experiment(stop_time=STOP, step=STEP))
    ssp = export_ssp(system, tmp_path / "two.ssp")
    import zipfile

    ssd = zipfile.ZipFile(ssp).read("SystemStructure.ssd").decode()
    assert 'name="y[1]"' in ssd and 'name="u[2]"' in ssd
    native = quiet(system, master="gauss-seidel", on_error="raise")
    from harness import load

    again = quiet(load(str(ssp)), master="gauss-seidel", on_error="raise")
    pd.testing.assert_frame_equal(native[again.columns.intersection(native.columns)],
                                  again[again.columns.intersection(native.columns)], check_exact=True)
