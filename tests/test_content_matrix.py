"""benchmarks/content_matrix.py (issue 33's table): a cell is judged from a run, never written in.

The cheap kind is the vendored FMI 1.0 identity FMU (nothing to build); FMPy is a dependency of the toolkit.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from benchmarks import content_matrix as cm


def test_fmi1_kind_runs_in_ours_and_fmpy_and_the_cell_is_measured(tmp_path):
    rows = cm.matrix(["fmi1-cs"], ["ours", "fmpy"], tmp_path, timeout=120)
    assert len(rows) == 1
    row = rows[0]
    assert row["ours"] == "runs (10 steps)"
    assert row["fmpy"].startswith("runs, agrees with ours to "), row["fmpy"]
    # the cell comes from the two result files the subprocesses wrote
    ours = pd.read_csv(tmp_path / "fmi1-cs.ours.csv", index_col=0)
    fmpy = pd.read_csv(tmp_path / "fmi1-cs.fmpy.csv", index_col=0)
    assert (ours["realOut"] == 2.5).all() and len(fmpy) == len(ours)
    assert cm.judge(fmpy, ours)[0] == row["fmpy"]


def test_a_tool_that_fails_is_reported_with_its_own_message(tmp_path):
    """A content file that is not there: the harness's own one-line refusal reaches the cell."""
    c = cm.build("fmi1-cs", tmp_path)
    c.path = str(tmp_path / "missing.fmu")
    status, df = cm.run_cell("ours", c, tmp_path, timeout=120)
    assert df is None
    assert status.startswith(("cannot load: ", "refused: ")) and "missing.fmu" in status, status


def _frame(t, x):
    return pd.DataFrame({"a.x": x}, index=pd.Index(t, name="time"))


def test_judge_measures_difference_time_points_and_a_late_labelling():
    t = np.round(np.arange(11) * 0.1, 12)
    ours = _frame(t, np.exp(-t))
    assert cm.judge(_frame(t, np.exp(-t) * (1 + 1e-9)), ours)[0].startswith("runs, agrees with ours to 1.0e-09")
    text, x = cm.judge(_frame(t, np.exp(-t) + 0.01), ours)
    assert text.startswith("runs, differs (1.0e-02") and x == pytest.approx(0.01, rel=1e-9)
    # accumulated times (0.1 + 0.2 ...) still meet ours; duplicates keep the last value
    acc = np.cumsum(np.r_[0.0, np.full(10, 0.1)])
    assert cm.judge(_frame(np.r_[acc[:1], acc], np.r_[9.0, np.exp(-t)]), ours)[0].startswith("runs, agrees")
    # FMPy's simulate_ssp: the row at t holds the values after the step from t, and the last row is missing
    text, _ = cm.judge(_frame(t[:-1], np.exp(-t[1:])), ours)
    assert "only 10 of our 11 time points" in text and "shifted, agrees to 0.0e+00" in text
    assert cm.judge(_frame(t + 5, np.exp(-t)), ours)[0].startswith("runs, differs (time points")
    assert cm.judge(pd.DataFrame({"b.y": t}, index=t), ours)[0].startswith("runs, none of our outputs")
