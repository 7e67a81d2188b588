"""The divergence detector (harness/master/divergence.py) on the two stability maps and the issue's cases.

Stable points: every (value, master, order) of both maps at the largest step the map judged stable and a little
below it must run to the end.  Unstable points: clearly beyond the boundary (x1.25 on both maps; on the bed-drive
map over four times its window) the run must be stopped by the detector, with one line naming the bond and the
evidence, before any power passes the master's 1e12 blow-up check.  The exceptions are stated and measured below,
and the jacobian master's bed-drive bounds, which are deviations without growth, have their own test.
"""
from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness import simulate
from harness.master.divergence import DivergenceDetector, DivergenceOptions, Diverged, replay
from harness.studies import stability as st

DOCS = Path(__file__).resolve().parents[1] / "docs" / "images"
TI = pd.read_csv(DOCS / "stability_two_inertia_inertia.csv")
BD = pd.read_csv(DOCS / "stability_bed_drive_fourbar_rocker_inertia.csv")


def _ti_run(r):
    p = TwoInertia = st.TwoInertia(J1=r.p_J1, J2=r.p_J2, c=r.p_c, d=r.p_d, c1=r.p_c1, d1=r.p_d1, c2=r.p_c2,
                                   d2=r.p_d2)
    return st.two_inertia_run(TwoInertia, r.master, int(r.order)), r.h_measured


_REFS: dict = {}


def _bd_run(r):
    if r.value not in _REFS:
        _REFS[r.value] = st.PressRun("bed_drive", "gauss-seidel", 0, {r.sweep: r.value}, duration=r.duration).ref
    return st.PressRun("bed_drive", r.master, int(r.order), {r.sweep: r.value}, duration=r.duration,
                       reference=_REFS[r.value])


def _one_line_divergence(df):
    err = df.attrs["error"]
    assert "\n" not in err and "the run diverged on power bond" in err and "instance" in err, err
    return err


def test_two_inertia_map_stable_points_run_to_the_end():
    for _, r in TI.iterrows():
        run, hb = _ti_run(r)
        for f in (0.99, 0.995):   # the bisection bracket is 0.5 % wide: 0.995 h is judged stable by the study
            df = run(hb * f)
            assert not st.is_unstable(df), (r.ratio, r.master, r.order, f)
            assert df.attrs["complete"] and not df.attrs["suspect"], (r.ratio, r.master, r.order, f, df.attrs["error"])


def test_two_inertia_map_unstable_points_are_stopped():
    stopped = 0
    for _, r in TI.iterrows():
        run, hb = _ti_run(r)
        df = run(hb * 1.25)
        assert st.is_unstable(df)
        # Gauss-Seidel with zero-order hold: the bond's energy error stays near zero while the amplitude grows,
        # so only the geometric-growth test can stop it; at 1.25 times the boundary it grows by x2-3 in power
        # per quarter, and 3 of these 5 runs (ratios 0.2, 1.0, 2.0) ended unconfirmed when the study ran 60
        # periods: it runs 90 now (the map unchanged, every boundary the same bisection point)
        assert not df.attrs["complete"], (r.ratio, r.master, r.order)
        if df.attrs["diverged"]:
            _one_line_divergence(df)
            stopped += 1
        else:  # only the most violent blow-ups reach the master's check before the detector's first blocks
            assert "blow-up limit" in df.attrs["error"] and len(df) < 64, (r.ratio, r.master, r.order)
    assert stopped >= 25  # measured: 25 of these 30 by the detector, the other 5 by the blow-up check


def test_bed_drive_map_stable_points_run_to_the_end():
    for _, r in BD.iterrows():
        prun = _bd_run(r)
        for h in (r.h_stable, 0.9 * r.h_stable):
            df = prun(h)
            assert df.attrs["complete"] and not df.attrs["suspect"], (r.value, r.master, r.order, h, df.attrs["error"])
            assert not prun.judge(df)


def test_bed_drive_map_unstable_points_are_stopped():
    """Every explicit method's point 1.25 times beyond its map boundary, run over four times the map's window
    (0.4 s; a run of the drive is 1-2 s), is stopped: by the detector, or by the blow-up check for the most
    violent.  Over the map's own 0.1 s window the slowest of these (zero-order hold) are still growing when the
    run ends: with the seed's branch -1 mechanism, 0.5 kg.m2 with jacobi order 0 had its crank torque at 130
    times the reference's when the 70 steps ended, and was stopped at 0.146 s of the longer run.  (1.5 times
    the boundary is no longer always unstable: with a zero-order hold the verdicts come in bands, e.g. 0.25
    kg.m2, jacobi order 0, deviating at 1.0 and 1.25 times and within the criterion at 1.5 times over 0.1 s.)"""
    by_detector = by_blowup = 0
    for _, r in BD[BD.master != "jacobian"].iterrows():   # jacobian: the next test
        ref_key = (r.value, "long")
        if ref_key not in _REFS:
            _REFS[ref_key] = st.PressRun("bed_drive", "gauss-seidel", 0, {r.sweep: r.value},
                                         duration=4 * r.duration).ref
        prun = st.PressRun("bed_drive", r.master, int(r.order), {r.sweep: r.value}, duration=4 * r.duration,
                           reference=_REFS[ref_key])
        df = prun(1.25 * r.h_unstable)
        assert prun.judge(df), (r.value, r.master, r.order)
        assert not df.attrs["complete"], (r.value, r.master, r.order)
        if df.attrs["diverged"]:
            _one_line_divergence(df)
            by_detector += 1
        else:
            # the violent blow-ups (power x30 per step) pass 1e12 within the detector's first blocks
            assert "blow-up limit" in df.attrs["error"] and len(df) <= 40, (r.value, r.master, r.order, len(df))
            by_blowup += 1
    # measured: 29 of the 30 by the detector, 1 by the blow-up check (jacobi order 2 at 2.5 kg.m2)
    assert by_detector >= 28


def test_bed_drive_map_jacobian_bounds_are_bounded_deviations_not_divergences():
    """The jacobian master's bounds on the bed-drive map are of another kind: at the step the map judged unstable
    the run completes with every output bounded, and no power bond created power (the implicit coupling
    dissipates on each bond), so the detector rightly has nothing to stop; the deviation (as large as the
    signal's own variation over the window's last quarter, the map's criterion) is an accuracy failure, which
    the accuracy study judges against the drive's declared tolerances.  Its verdicts also come in bands (stable
    again above the first unstable step), which is why the map's search scans upward by 2^(1/4)."""
    rows = BD[BD.master == "jacobian"]
    assert len(rows) == len(BD["value"].unique())
    for _, r in rows[rows.status == "bracketed"].iterrows():
        prun = _bd_run(r)
        df = prun(r.h_unstable)
        assert prun.judge(df), (r.value, r.h_unstable)
        assert df.attrs["complete"] and not df.attrs["diverged"], (r.value, df.attrs["error"])
        assert np.all(np.isfinite(df.to_numpy(dtype=float)))


def test_bed_drive_jacobi_sampled_with_hold_at_0p2_ms_is_reported_incomplete_early():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = simulate("bed_drive", master="jacobi-sampled", step=2e-4, extrapolation=0)
    assert not df.attrs["complete"] and df.attrs["diverged"]
    assert df.index[-1] < 0.2
    err = _one_line_divergence(df)
    assert err.startswith(f"t = {df.index[-1]:.9g} s: instance ")
    assert np.max(np.abs(df["bed.bed.v"])) < 5.0  # the bed was still within its physical speed range


def test_two_inertia_textbook_setup_is_stopped():
    """Undamped free-free Jacobi with zero-order hold is unstable at every step (stability theory); at the
    default step it grows 17x in 1 s without the detector.  (The system's default master is now ``jacobian``,
    which runs it to the end: tests/test_jacobian.py.)"""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = simulate("two_inertia", master="jacobi", extrapolation=0)
    assert not df.attrs["complete"] and df.attrs["diverged"]
    _one_line_divergence(df)


def test_stable_drives_with_load_onsets_are_not_stopped():
    """spine_knife: the cut starts on bonds that carried no power (growth from numerical rest)."""
    for system in ("spine_knife", "feeder_gto52"):
        df = simulate(system, stop_time=0.5)
        assert df.attrs["complete"], (system, df.attrs["error"])


def test_detector_can_be_switched_off_and_replayed():
    from harness import RunOptions

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = simulate("two_inertia", master="jacobi", extrapolation=0, options=RunOptions(divergence=None))
    assert df.attrs["complete"]
    reason = replay(df.attrs["bonds"])
    assert "the run diverged on power bond a.flange->b.drive" in reason


def test_detector_on_synthetic_growth_and_steady_signals():
    def feed(powers, created, options=None):
        det = DivergenceDetector(["a.p->b.p"], [("b", "p.tau")], options)
        e = 0.0
        for k, p in enumerate(powers):
            e += created * abs(p) * 1e-3
            det.update((k + 1) * 1e-3, np.array([[p], [p], [e]]), 1e-3)
        return det.finish(len(powers) * 1e-3)

    steady = [10.0 * math.sin(0.3 * k) for k in range(2000)]
    feed(steady, 0.5)                            # no growth: never stopped, whatever the energy error
    growing = [math.exp(0.01 * k) * math.sin(0.3 * k) for k in range(2000)]
    no_geometric = DivergenceOptions(geometric=None)
    feed(growing, 0.0, no_geometric)             # growth without energy created by the coupling: not stopped
    with pytest.raises(Diverged, match="instance b: output p.tau: the run diverged on power bond a.p->b.p"):
        feed(growing, 0.1, no_geometric)
    # ... unless it is geometric: the same rate over three quarters of the run (Gauss-Seidel's zero-order hold)
    with pytest.raises(Diverged, match="grew geometrically"):
        feed(growing, 0.0)
    linear = [(1.0 + 0.01 * k) * math.sin(0.3 * k) for k in range(2000)]  # a resonance building up
    feed(linear, 0.0)
    saturating = [(1.0 - math.exp(-0.005 * k)) * 100.0 * math.sin(0.3 * k) for k in range(2000)]  # a spin-up
    feed(saturating, 0.0)
    from_rest = [(k * 1e-3) ** 3 * math.sin(0.3 * k) for k in range(2000)]  # a start from rest: power ~ t^3
    feed(from_rest, 0.0)
    # a run that ends before the geometric growth could be confirmed (x2.7 per quarter from 280 steps on,
    # confirmation due at 420): reported at the end, as its rate did not slow; a start from rest ending as
    # short passes both ratios too (x3.4, x2.4) but slows, as any power of t does, and is not
    # (and fed by the coupling: 1 % of the flow created; the same growth with nothing created is the machine's)
    assert "still growing geometrically at the end of the run" in feed(growing[:400], 0.01)
    assert feed(growing[:400], 0.0) == ""
    assert feed(from_rest[:400], 0.01) == ""
    assert feed(growing[:400], 0.01, DivergenceOptions(end_rate=None)) == ""   # the end report switched off


def test_a_load_that_jumps_is_not_divergence_but_sustained_creation_is():
    """A load coming on within one step (a cut starting) makes a coupling that samples the effort a step late
    book about half the jump times the step, once; then the power is steady x100.  Not stopped.  The same jump
    with the coupling creating 10 % of the flow at every step after it is."""
    h = 1e-3

    def feed(creation_per_step):
        det = DivergenceDetector(["a.p->b.p"], [("b", "p.tau")])
        e = 0.0
        for k in range(2000):
            p = 0.1 if k < 1000 else 10.0
            if k == 1000:
                e += 0.5 * (10.0 - 0.1) * h          # the one-off of the jump
            elif k > 1000:
                e += creation_per_step * p * h
            det.update((k + 1) * h, np.array([[p], [p], [e]]), h)
        return det.finish(2000 * h)

    assert feed(0.0) == ""
    with pytest.raises(Diverged, match=r"grew from 0.1 W .* to 10 W \(x100, limit x10\); the coupling created"):
        feed(0.1)


def test_spine_knife_cut_under_sampled_coupling_runs_to_the_end(fmu_dir, monkeypatch):
    """The benchmark's spine_knife case (jacobi-sampled, hold, 5e-5 s) was stopped as diverged when the cut began
    at 0.025 s, though it makes the Jacobi run's cut (the one-off of the jump: harness.master.divergence)."""
    from harness import load

    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))
    system = load("spine_knife")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sampled = simulate(system, stop_time=0.1, step=5e-5, master="jacobi-sampled", extrapolation=0,
                           on_error="return")
        jacobi = simulate(system, stop_time=0.1, step=5e-5, master="jacobi", extrapolation=0)
    assert sampled.attrs["complete"] and not sampled.attrs["suspect"], sampled.attrs["error"]
    tau = "linkage.crank.tau"
    assert jacobi[tau].abs().max() > 1.0                                   # the cut is in the run
    peak = jacobi[tau].abs().max()
    assert abs(sampled[tau].abs().max() - peak) < 0.02 * peak                # the same cut, a step late
    force = jacobi["knife.feed_force"].max()
    assert abs(sampled["knife.feed_force"].max() - force) < 0.02 * force


@pytest.mark.parametrize("bad", [dict(block=0), dict(growth=-1.0), dict(creation=float("nan"))])
def test_options_are_checked(bad):
    with pytest.raises(ValueError, match="DivergenceOptions"):
        DivergenceOptions(**bad)


def test_gauss_seidel_zero_order_hold_growth_is_stopped():
    """The issue's miss: two_inertia (undamped, free-free: any energy is made by the coupling) with
    gauss-seidel and zero-order hold at its default 1 ms step grew its spring torque from 4.2 to 3.2e3 N.m in
    5 s and ended complete; the geometric-growth test stops it, in one line, before the torque has doubled."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = simulate("two_inertia", stop_time=5.0, step=1e-3, master="gauss-seidel", extrapolation=0)
    assert not df.attrs["complete"] and df.attrs["diverged"]
    err = _one_line_divergence(df)
    assert "grew geometrically" in err and "instance b: output drive.tau" in err
    assert df.index[-1] < 2.0 and df["b.drive.tau"].abs().max() < 2 * 4.2


def test_a_drive_cut_short_in_its_first_cycle_is_not_suspect():
    """bed_drive over exactly one machine cycle (1 s at 60 rpm): the return stroke's power grows x3 per quarter
    at the end, but the coupling feeds none of it (1e-3 J of ~150 J): no 'still growing' line, nothing printed
    but the result (issue 30: this line was noise on a plain `run bed_drive --stop-time 1`)."""
    import subprocess
    import sys

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        df = simulate("bed_drive", stop_time=1.0)
    assert df.attrs["complete"] and df.attrs["suspect"] == "", df.attrs["suspect"]
    assert not [w for w in caught if "growing" in str(w.message)]
    r = subprocess.run([sys.executable, "-m", "harness", "run", "bed_drive", "--stop-time", "1"],
                       capture_output=True, text=True)
    assert r.returncode == 0 and "growing" not in r.stderr, r.stderr


def _feed_step(detector: DivergenceDetector, event: bool, n_before: int = 200, n_after: int = 40,
               h: float = 1e-3, jump: float = 1e4) -> None:
    """One bond carrying 1 W, then from step ``n_before`` on ``jump`` W (a load put on: a jam), the coupling
    booking an error on the transient the jump excites (half the power over four steps, then none: as a cut
    starting in spine_knife books 6 % of the little energy flowed since); ``event``: the detector is told of the
    input step."""
    energy = 0.0
    for k in range(n_before + n_after):
        if event and k == n_before:
            detector.event(k * h, np.array([[1.0], [1.0], [energy]]))
        p = 1.0 if k < n_before else jump
        if n_before <= k < n_before + 4:
            energy += 0.5 * p * h
        detector.update((k + 1) * h, np.array([[p], [p], [energy]]), h)


def test_a_legitimate_step_of_the_power_at_an_event_is_no_divergence():
    """A load step at an input event multiplies a bond's power by 1e4 (amplitude x100) and the coupling books
    its usual error on the jump: judged on the scale before the event it reads as divergence; told of the event
    the detector judges the run after it on its own scale and lets it run."""
    with pytest.raises(Diverged):
        _feed_step(DivergenceDetector(["a.p->b.p"], [("b", "p.tau")]), event=False)
    _feed_step(DivergenceDetector(["a.p->b.p"], [("b", "p.tau")]), event=True)


def test_a_divergence_after_an_event_is_still_caught():
    """After the event the detector judges on the event's scale: a bond whose power then grows geometrically
    (x1.2 per step, fed by the coupling) is stopped."""
    d = DivergenceDetector(["a.p->b.p"], [("b", "p.tau")])
    energy, h = 0.0, 1e-3
    with pytest.raises(Diverged):
        for k in range(2000):
            if k == 100:
                d.event(k * h, np.array([[1.0], [1.0], [energy]]))
            p = 1.0 if k < 100 else 1.2 ** min(k - 100, 150)
            energy += (0.2 * p * h) if k >= 100 else 0.0
            d.update((k + 1) * h, np.array([[p], [p], [energy]]), h)
