"""The declared accuracy of a drive (harness.specs.AccuracySpec) and the study that finds the cheapest method and
step meeting it (harness.studies.accuracy)."""
from __future__ import annotations

import math
import warnings
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from harness.specs import AccuracySpec, Requirement
from harness.studies import accuracy

ZONE = 'between(r["s"], 0.2, 0.8)'


def _system(*requirements):
    return SimpleNamespace(name="toy", accuracy=AccuracySpec(tuple(requirements), stop_time=1.0))


def _frame(t, **cols):
    df = pd.DataFrame(cols, index=pd.Index(t, name="time"))
    df.attrs["complete"] = True
    return df


def test_per_sample_requirement_is_judged_only_inside_its_zone():
    t = np.linspace(0.0, 1.0, 101)
    ref = _frame(t, s=t.copy())
    run = _frame(t, s=t + np.where(t < 0.1, 5e-5, 2e-6))          # 50 um off outside the zone, 2 um inside
    sys_ = _system(Requirement("position in the zone", 'r["s"]', 1e-5, "m", where=ZONE))
    [c] = accuracy.check(sys_, run, ref)
    assert c.ok and c.error == pytest.approx(2e-6)
    run_bad = _frame(t, s=t + np.where((t > 0.5) & (t < 0.52), 2e-5, 0.0))
    [c] = accuracy.check(sys_, run_bad, ref)
    assert not c.ok and c.error == pytest.approx(2e-5)


def test_reference_on_a_finer_grid_is_interpolated_to_the_run():
    t_ref = np.linspace(0.0, 1.0, 1001)
    ref = _frame(t_ref, s=t_ref ** 2)
    t = np.linspace(0.0, 1.0, 11)
    run = _frame(t, s=t ** 2)
    [c] = accuracy.check(_system(Requirement("x", 'r["s"]', 1e-5, "m")), run, ref)
    assert c.ok and c.error < 1e-6          # linear interpolation of t^2 on a 1e-3 grid: 2.5e-7


def test_relative_scalar_and_event_lists():
    t = np.linspace(0.0, 1.0, 101)
    ref = _frame(t, s=t.copy(), f=100.0 * np.sin(6 * t), k=(t > 0.33).astype(float) + (t > 0.71))
    run = _frame(t, s=t.copy(), f=103.0 * np.sin(6 * t), k=(t > 0.34).astype(float))
    peak = Requirement("peak force", 'peak(r["f"])', 0.05, "N", relative=True)
    events = Requirement("instants", 'at_rises(r["k"], t)', 0.02, "s")
    cp, ce = accuracy.check(_system(peak, events), run, ref)
    assert cp.ok and cp.error == pytest.approx(0.03) and cp.unit == "1"
    assert not ce.ok and "1 values in the run, 2 in the reference" in ce.note


def test_an_incomplete_run_meets_nothing_and_says_why():
    t = np.linspace(0.0, 1.0, 11)
    ref = _frame(t, s=t.copy())
    run = _frame(t[:4], s=t[:4].copy())
    run.attrs.update(complete=False, error="t = 0.3 s: diverged")
    [c] = accuracy.check(_system(Requirement("x", 'r["s"]', 1.0, "m")), run, ref)
    assert not c.ok and "diverged" in c.note


def test_a_system_without_declared_accuracy_is_refused():
    with pytest.raises(ValueError, match="declares no accuracy"):
        accuracy.check(SimpleNamespace(name="toy", accuracy=None), _frame([0.0, 1.0], s=[0, 1]),
                       _frame([0.0, 1.0], s=[0, 1]))


def test_bed_drive_search_names_the_cheapest_run_that_meets_every_requirement():
    """The bed drive over its first 0.4 s (its printing zone begins inside it): jacobi at 2 ms is stopped as
    diverged and meets nothing; the cheapest that meets is a complete run that passed every check."""
    from harness import load

    system = load("bed_drive")
    system = replace(system, accuracy=replace(system.accuracy, stop_time=0.4))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = accuracy.search(system, methods=(("jacobi", 1), ("jacobian", 1)), steps=(5e-4, 2e-3))
    assert len(table) == 4
    names = [r.name for r in system.accuracy.requirements]
    diverged = table[(table.master == "jacobi") & (table.step == 2e-3)].iloc[0]
    assert not diverged["complete"] and not diverged["meets"] and diverged["error"]
    best = accuracy.cheapest(table)
    assert best is not None and best["meets"] and best["complete"]
    for name, req in zip(names, system.accuracy.requirements):
        assert best[name] <= req.tolerance
    assert best["fmu_steps"] == table[table.meets]["fmu_steps"].min()


def test_fmu_steps_count_every_do_step():
    """jacobi: one fmi2DoStep per FMU and step; jacobian: two per FMU and step, plus one per held input at each
    Jacobian estimate, plus the steps taken again."""
    from harness import simulate
    from harness import master as masters

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        j = simulate("two_inertia", stop_time=0.1, step=1e-3, master="jacobi", extrapolation=1)
        box = {}
        init = masters.InterfaceJacobian.__init__

        def keep(self, *a, **k):
            init(self, *a, **k)
            box["m"] = self
        masters.InterfaceJacobian.__init__ = keep
        try:
            ij = simulate("two_inertia", stop_time=0.1, step=1e-3, master="jacobian", extrapolation=1)
        finally:
            masters.InterfaceJacobian.__init__ = init
    assert j.attrs["fmu_steps"] == 100 * 2
    m = box["m"]
    assert m.estimates >= 1
    assert ij.attrs["fmu_steps"] == 2 * 100 * 2 + m.estimates * len(m.u) + 2 * 2 * m.retries
    assert not math.isnan(ij.attrs["fmu_steps"])
