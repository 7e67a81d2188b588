"""Batches of variants (harness.run.batch): each variant's result is its own scalar run's, bit for bit.

The references are the variants' own runs with :func:`harness.simulate` (the FMUs through the in-process path):
every number compared is a float64 compared by its bits, every error message and stop time by equality."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from harness import load, simulate
from harness.errors import SystemDescriptionError
from harness.run.batch import BatchOptions, Keep, refusal, simulate_batch


def scalar(system, variant: dict, **settings):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(system, start_values=variant, **settings)


def same_bits(a, b) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def assert_batch_is_scalar(system, variants, settings, columns=None):
    run = simulate_batch(system, variants, settings, Keep(columns=columns, frames=True), BatchOptions(rerun=False))
    for v, r in zip(variants, run.results):
        df = scalar(system, v, **settings)
        assert r.complete == df.attrs["complete"], (v, r.error, df.attrs["error"])
        cols = list(r.frame.columns)
        assert len(r.frame) == len(df), v
        assert same_bits(r.frame[cols].to_numpy(), df[cols].to_numpy()), (v, [
            c for c in cols if not same_bits(r.frame[c], df[c])])
        assert same_bits(r.frame.index, df.index)
    return run


# Each drive with variants that change real parameters and, one at a time, every fidelity level of its components
# (each level a structure of its own: the batch splits them); short runs (40-80 steps)
DRIVES = {
    "bed_drive": (0.02, [{}, {"flywheel.J_flywheel": 6.0, "bed.m_T": 300.0}, {"fourbar.fidelity": 0},
                         {"fourbar.fidelity": 2, "fourbar.clearance": 1e-5}, {"cam.fidelity": 1},
                         {"cam.fidelity": 2}, {"diff.fidelity": 1}, {"bed.fidelity": 0}, {"motor.fidelity": 2},
                         {"flywheel.fidelity": 0}, {"bed.stop_stiffness": 1e8, "bed.stop_position": 0.2},
                         {"bed.stop_stiffness": 1e8, "bed.stop_position": 0.2, "bed.stop_catch": 1}]),
    "feeder_gto52": (0.01, [{}, {"feeder.clearance": 2e-5, "flywheel.d": 0.028}, {"feeder.fidelity": 0},
                            {"feeder.fidelity": 1}, {"feeder.fidelity": 3}, {"motor.fidelity": 0},
                            {"feeder.contact_law": 2}]),
    "proof_press": (0.01, [{}, {"flywheel.J_flywheel": 2.0}, {"press.fidelity": 1}, {"motor.fidelity": 2}]),
    "spine_knife": (0.004, [{}, {"knife.T_cut": 0.03}, {"shaft.fidelity": 0}, {"motor.fidelity": 1},
                            {"knife.fidelity": 0}, {"linkage.fidelity": 1}]),
    "trimmer_conveyor": (0.01, [{}, {"trim.thickness": 0.018, "drive.J_flywheel": 1.0}, {"motor.fidelity": 1},
                                {"drive.fidelity": 0}]),
}
# the trimmer's declared experiment steps its knife load at its own rate (multirate: refused, below); at another
# step every instance steps at it
SETTINGS = {"trimmer_conveyor": {"step": 2.5e-4}}


@pytest.mark.parametrize("name", sorted(DRIVES))
def test_every_variant_of_a_drive_is_its_own_scalar_run(name):
    stop, variants = DRIVES[name]
    run = assert_batch_is_scalar(name, variants, {"stop_time": stop, **SETTINGS.get(name, {})})
    assert sum(g["variants"] for g in run.info["groups"]) == len(variants) and len(run.info["groups"]) >= 2


@pytest.mark.parametrize("master, order", [("jacobi", 0), ("jacobi", 2), ("gauss-seidel", 1),
                                           ("jacobi-sampled", 1)])
def test_each_batched_method_gives_the_scalar_numbers(master, order):
    assert_batch_is_scalar("two_inertia", [{"b.c": 300.0}, {"b.c": 600.0, "a.J": 0.02}],
                           {"stop_time": 0.05, "master": master, "extrapolation": order, "step": 1e-3})
    assert_batch_is_scalar("bed_drive", [{}, {"bed.c_mesh": 1e7}], {"stop_time": 0.005, "master": master,
                                                                    "extrapolation": order})


def test_the_vectorised_physics_and_the_scalar_loop_give_the_same_numbers():
    """The batch with its vectorised components and with every variant's scalar model: the same frames."""
    variants = [{"flywheel.J_flywheel": j} for j in (6.0, 8.0, 11.0)]
    vec = simulate_batch("bed_drive", variants, {"stop_time": 0.02}, Keep(columns=None, frames=True))
    loop = simulate_batch("bed_drive", variants, {"stop_time": 0.02}, Keep(columns=None, frames=True),
                          BatchOptions(vectorise=False))
    assert set(vec.info["groups"][0]["forms"].values()) == {"vectorised"}
    assert set(loop.info["groups"][0]["forms"].values()) == {"scalar loop"}
    for a, b in zip(vec.results, loop.results):
        assert same_bits(a.frame.to_numpy(), b.frame.to_numpy())


def test_only_the_columns_asked_for_are_kept_and_they_are_the_scalar_ones():
    cols = ("bed.bed.s", "fourbar.crank.tau", "motor.pulley.tau", "flywheel.crank.w")
    run = assert_batch_is_scalar("bed_drive", [{}, {"bed.m_T": 200.0}], {"stop_time": 0.02}, columns=cols)
    assert list(run.results[0].frame.columns) == list(cols)


def test_a_variant_that_fails_is_taken_out_alone_and_run_on_its_own():
    """A refused parameter, an output beyond its declared range and a variant whose state blows up each fail with
    their scalar run's error; the others are unaffected."""
    variants = [{}, {"flywheel.J_flywheel": -1.0}, {"bed.c_mesh": 1e14, "bed.d_mesh": 0.0}, {"bed.m_T": 260.0}]
    settings = {"stop_time": 0.03}
    run = simulate_batch("bed_drive", variants, settings, Keep(columns=None, frames=True))
    for v, r in zip(variants, run.results):
        df = scalar("bed_drive", v, **settings)
        assert r.complete == df.attrs["complete"]
        if not r.complete:
            assert r.alone and r.error == str(df.attrs["error"]).splitlines()[0]
        assert same_bits(r.frame.to_numpy(), df.to_numpy()) if len(df) else r.frame is None or not len(r.frame)
    assert not run.results[1].complete and "J_flywheel" in run.results[1].error
    assert run.results[0].complete and not run.results[0].alone and run.results[3].complete


def test_the_screens_window_maximum_is_numpys_over_the_window():
    """The screen's running window maximum (two stacks) equals numpy's max over the stacked window rows (NaN
    included) for windows that move forward by random amounts, jump, and shrink to nothing."""
    from harness.master.batch_watch import _WindowMax

    rng = np.random.default_rng(3)
    rows = [rng.random((2, 5)) for _ in range(300)]
    rows[37][1, 2] = math.nan
    w, a, b = _WindowMax((2, 5)), 0, 0
    for _ in range(250):
        b = min(len(rows), b + int(rng.integers(0, 3)))
        a = min(b, a + int(rng.integers(0, 2)))
        if rng.random() < 0.03:
            a = b = min(len(rows), b + 5)
        want = np.max(np.stack(rows[a:b]), axis=0) if b > a else np.zeros((2, 5))
        assert np.array_equal(w.max(rows, a, b), want, equal_nan=True), (a, b)


def test_the_divergence_screen_stops_a_variant_where_the_scalar_detector_does():
    variants = [{"b.c": c} for c in (1000.0, 2000.0, 5000.0)]
    settings = {"stop_time": 0.3, "master": "jacobi", "extrapolation": 0, "step": 1e-3}
    run = simulate_batch("two_inertia", variants, settings, Keep(columns=None, frames=True),
                         BatchOptions(rerun=False))
    for v, r in zip(variants, run.results):
        df = scalar("two_inertia", v, **settings)
        assert not df.attrs["complete"] and df.attrs["diverged"]
        assert not r.complete and "divergence screen" in r.error
        assert r.frame.index[-1] == df.index[-1]


def test_methods_whose_algebra_does_not_vectorise_are_refused_by_name():
    system = load("bed_drive")
    for master in ("iterative", "jacobian"):
        assert f"master {master!r}" in refusal(system, {"master": master})
        with pytest.raises(SystemDescriptionError, match=f"no batch: master {master!r}"):
            simulate_batch(system, [{}, {}], {"master": master, "stop_time": 0.01})
    assert "step control" in refusal(system, {"step_control": "richardson"})
    assert refusal(load("two_inertia"), {"master": "gauss-seidel"}) is None
    # each FMU at its own rate (the trimmer's declared experiment), a checkpoint: every variant's own run
    trimmer = load("trimmer_conveyor")
    assert "instance trim steps at its own rate" in refusal(trimmer, {})
    assert refusal(trimmer, {"step": 2.5e-4}) is None and refusal(trimmer, {"master": "gauss-seidel"}) is None
    assert "from_checkpoint is given" in refusal(system, {"from_checkpoint": "x.ckpt"})


def test_quantities_of_interest_streamed_or_recorded_are_those_of_the_whole_result():
    from harness.reporting import qoi
    from harness.reporting.qoi_stream import plan

    exprs = {"peak": 'peak(window(r["bed.bed.v"], 0.005, 0.015))', "ptp": 'ptp(r["flywheel.crank.w"])',
             "ratio": 'max(r["bed.bed.s"]) / (1 + abs(min(window(r["fourbar.crank.tau"], 0.0, 0.01))))',
             "mean": 'mean(window(r["flywheel.crank.w"], 0.005, 0.02))', "at": 'at(r["bed.bed.s"], 0.0123)',
             "final": 'final(r["motor.motor_speed"])', "empty": 'peak(window(r["bed.bed.v"], 5.0, 6.0))'}
    assert plan(exprs["peak"]).streamed and plan(exprs["ratio"]).streamed and not plan(exprs["mean"]).streamed
    assert plan(exprs["mean"]).span == (0.005, 0.02) and plan(exprs["at"]).span is None
    variants = [{}, {"bed.m_T": 300.0}]
    run = simulate_batch("bed_drive", variants, {"stop_time": 0.02}, Keep(columns=(), reduce=tuple(exprs.items())))
    for v, r in zip(variants, run.results):
        df = scalar("bed_drive", v, stop_time=0.02)
        for name in list(exprs)[:-1]:
            assert same_bits(r.values[name], qoi.evaluate(exprs[name], df)), name
        assert r.value_error.startswith("QoIError: ") and "empty" in r.value_error
    assert run.results[0].frame is None


def test_a_thousand_variants_keep_no_time_series_for_streamed_quantities():
    """What a batch keeps of a streamed quantity is a few numbers per variant, whatever the run's length."""
    from harness.reporting.qoi_stream import Reducers

    red = Reducers({"p": 'peak(r["a.b"])', "q": 'ptp(window(r["a.c"], 0.1, 0.2))'}, {"a.b": 0, "a.c": 1}, 1000)
    for k in range(500):
        red.row(k * 1e-3, np.random.default_rng(k).normal(size=(2, 1000)), np.arange(1000), k, False)
    assert red.rec_rows == [] and red.hi_v.shape == (2, 1000)


def test_the_vector_math_gives_pythons_math_bits():
    """VECTOR (numpy where its bits are math's on this machine, math per element elsewhere) and an unchecked Vector
    (math per element for all) against math element by element: 20000 random arguments (numpy's own exp, tanh,
    acos, atan2, power and math.hypot differ on a few percent of them: fmus/physics/mathns.py), a number as one
    operand, and the domain and range errors as NaN and inf."""
    from fmus.physics.mathns import VECTOR, Vector

    line = VECTOR.check()
    rng = np.random.default_rng(1)
    x, y = rng.uniform(-30.0, 30.0, 20000), rng.uniform(-3.0, 3.0, 20000)
    x[:5] = (0.0, -0.0, 1e-300, 710.0, -745.5)
    plain = Vector()     # Python's math per element for every function (not checked)
    for ns in (VECTOR, plain):
        for name, f, args in (("exp", math.exp, (x / 2,)), ("tanh", math.tanh, (x,)), ("sin", math.sin, (x,)),
                              ("cos", math.cos, (x,)), ("acos", math.acos, (np.tanh(x),)),
                              ("atan2", math.atan2, (x, y)), ("atan2", math.atan2, (x, 0.3)),
                              ("hypot", math.hypot, (x, y)), ("hypot", math.hypot, (1.5, y)),
                              ("pow", lambda a, b: a ** b, (np.abs(x) + 1e-3, y)),
                              ("pow", lambda a, b: a ** b, (np.abs(x) * 1e-4, 1.5)),
                              ("chypot", lambda a, b: abs(complex(a, b)), (x, y))):
            want = np.array([f(*(float(a[i]) if isinstance(a, np.ndarray) else a for a in args))
                             for i in range(len(x))])
            assert same_bits(getattr(ns, name)(*args), want), (name, line)
        assert same_bits(ns.exp(np.array([1.0, 800.0])), [math.e, math.inf])
        assert same_bits(ns.acos(np.array([2.0, 1.0])), [math.nan, 0.0])
        assert same_bits(ns.pow(np.array([0.0, -8.0, 4.0]), np.array([-1.0, 1 / 3, 0.5])), [math.inf, math.nan, 2.0])
        assert ns.tanh(0.5) == math.tanh(0.5) and ns.atan2(1.0, np.float64(2.0)) == math.atan2(1.0, 2.0)
    assert "Python's math per element for exp, tanh, acos, atan2, pow, hypot" in line


def test_batched_sweep_rows_are_the_point_by_point_rows(tmp_path):
    from harness.studies.sweep import parse_spec, run_sweep

    spec = parse_spec({"grid": {"bed.m_T": [200.0, 240.0, 280.0, 320.0], "flywheel.J_flywheel": [6.0, 9.0]},
                       "stop_time": 0.02, "outputs": {"peak_v": 'peak(r["bed.bed.v"])',
                                                      "mean_w": 'mean(r["flywheel.crank.w"])'}})
    batched = run_sweep("bed_drive", spec, workers=0, progress=False)
    one_by_one = run_sweep("bed_drive", spec, workers=0, progress=False, batch=False)
    for col in ("bed.m_T", "flywheel.J_flywheel", "peak_v", "mean_w"):
        assert same_bits(batched[col], one_by_one[col]), col
    assert list(batched["error"]) == list(one_by_one["error"])


def test_a_tolerance_study_draws_from_its_distributions_and_reports_the_spread():
    import pandas as pd
    from scipy import stats

    from harness.studies.sweep import parse_spec
    from harness.studies.sweep_checks import SweepError
    from harness.studies.tolerance import spread

    data = {"sample": {"n": 5, "seed": 2, "distributions": {"bed.m_T": {"normal": [250.0, 5.0]},
                                                              "cam.clearance": {"uniform": [5e-6, 1.5e-5]}}},
            "outputs": {"q": 'peak(r["bed.bed.v"])'}}
    spec = parse_spec(data, "tol.yaml", sample=400)
    m = np.array([p["bed.m_T"] for p in spec.points])
    assert len(m) == 400 and spec.tolerance and spec.variable_key("bed.m_T") == "sample.distributions.bed.m_T"
    # Latin hypercube: exactly one point in each of the 400 equiprobable strata of the normal distribution
    strata = np.floor(stats.norm(250.0, 5.0).cdf(m) * 400).astype(int)
    assert sorted(strata) == list(range(400))
    with pytest.raises(SweepError, match=r"tol.yaml: sample.distributions.bed.m_T.normal: the spread -1.0 must be > 0"):
        parse_spec({**data, "sample": {"n": 3, "distributions": {"bed.m_T": {"normal": [250.0, -1.0]}}}}, "tol.yaml")
    with pytest.raises(SweepError, match="--sample 4 draws points from a 'sample:' section"):
        parse_spec({"grid": {"bed.m_T": [1.0]}}, "g.yaml", sample=4)
    df = pd.DataFrame({"q": [1.0, 2.0, 3.0, np.nan], "error": ["", "", "", "failed"]})
    table = spread(df, ["q"])
    assert table.loc["q", "points"] == 3 and table.loc["q", "mean"] == 2.0 and table.loc["q", "std"] == 1.0
    assert table.loc["q", "p50"] == 2.0 and table.loc["q", "min"] == 1.0 and table.loc["q", "max"] == 3.0
