"""Scenarios (harness.scenarios): the input table of a scenario's changes, its checks, scenario files, and the
transients of the shipped drives against closed forms and the monolithic reference."""
from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from harness import load, simulate_scenario
from harness import scenarios as S
from harness.errors import SystemError_
from harness.specs import Change, Scenario


def test_the_table_steps_and_ramps_as_fmpy_reads_it():
    """A step is two rows at one time, a ramp a straight line from the value before it; FMPy's interpolation of
    the table (fmpy.simulation.Input) gives the scenario's values at any time."""
    sc = Scenario("x", "", "stop", 3.0, (Change(1.0, "m.supply", 0.8, ramp=0.5), Change(2.0, "m.brake", 1.0),
                                         Change(2.0, "m.supply", 0.0)))
    tab = S.table(sc, {"m.supply": 1.0, "m.brake": 0.0})
    assert list(tab.columns) == ["time", "m.supply", "m.brake"]

    def value(column, t, after=True):
        times = tab["time"].to_numpy()
        x = tab[column].to_numpy()
        same = np.flatnonzero(times == t)
        if same.size:
            return x[same[-1]] if after else x[same[0]]
        return float(np.interp(t, times, x))

    for t, supply in ((0.0, 1.0), (0.99, 1.0), (1.25, 0.9), (1.5, 0.8), (1.9, 0.8), (2.5, 0.0)):
        assert value("m.supply", t) == pytest.approx(supply, abs=1e-12), t
    assert value("m.supply", 2.0, after=False) == pytest.approx(0.8) and value("m.supply", 2.0) == 0.0
    assert value("m.brake", 2.0, after=False) == 0.0 and value("m.brake", 2.0) == 1.0
    assert value("m.brake", 1.7) == 0.0
    assert (np.diff(tab["time"]) >= 0).all()


@pytest.mark.parametrize("change, message", [
    (Change(-0.1, "motor.supply", 0.0), "outside the run"),
    (Change(5.0, "motor.supply", 0.0), "outside the run"),
    (Change(1.0, "motor.supply", 0.0, ramp=-0.2), "ramp = -0.2 s is negative"),
    (Change(1.00013, "motor.supply", 0.0), "not a communication point"),
])
def test_a_bad_change_is_refused_in_one_line(change, message):
    system = load("bed_drive")
    sc = Scenario("bad", "", "stop", 3.0, (change,))
    with pytest.raises(SystemError_, match=message) as e:
        S.check(system, sc, 5e-4, 3.0)
    assert "\n" not in str(e.value) and "scenario bad" in str(e.value)


def test_overlapping_ramps_and_an_unknown_kind_are_refused():
    system = load("bed_drive")
    with pytest.raises(SystemError_, match="starts before its previous ramp ends at 1.5 s"):
        S.check(system, Scenario("o", "", "stop", 3.0, (Change(1.0, "motor.supply", 0.5, ramp=0.5),
                                                        Change(1.2, "motor.supply", 0.0))), 5e-4, 3.0)
    with pytest.raises(SystemError_, match="kind 'brake' is not one of"):
        S.check(system, Scenario("o", "", "brake", 3.0), 5e-4, 3.0)


def test_an_unknown_scenario_lists_the_drives():
    with pytest.raises(SystemError_, match=r"no scenario .estpo.: did you mean estop, startup\? its scenarios: startup, "
                                           r"speed_change, estop"):
        S.find(load("bed_drive"), "estpo")


def test_every_motor_drive_ships_startup_speed_change_and_estop_and_the_feeder_and_knife_a_jam():
    for name in ("bed_drive", "feeder_gto52", "proof_press", "spine_knife", "trimmer_conveyor"):
        names = [sc.name for sc in load(name).scenarios]
        assert {"startup", "speed_change", "estop"} <= set(names), name
    assert "jam" in [sc.name for sc in load("feeder_gto52").scenarios]
    assert "jam" in [sc.name for sc in load("spine_knife").scenarios]
    # a brake of twice the rated torque, engaging 50 ms after the command
    estop = S.find(load("bed_drive"), "estop")
    assert dict(estop.parameters)["motor.holding_torque"] == pytest.approx(2 * 2200.0 / (1425 * 2 * math.pi / 60))


def test_a_scenario_file(tmp_path):
    f = tmp_path / "late.yaml"
    f.write_text("name: late\nquestion: q\nkind: stop\nstop_time: 2.5\nparameters: {motor.holding_torque: 30.0}\n"
                 "changes:\n  - {time: 1.0, variable: motor.supply, value: 0.0}\n"
                 "  - {time: 1.0, variable: motor.brake, value: 1, ramp: 0}\n")
    sc = S.find(load("bed_drive"), str(f))
    assert sc == Scenario("late", "q", "stop", 2.5, (Change(1.0, "motor.supply", 0.0), Change(1.0, "motor.brake", 1.0)),
                          (("motor.holding_torque", 30.0),))
    j = tmp_path / "j.json"
    j.write_text(json.dumps({"kind": "load", "stop_time": 1, "changes": [{"time": 0.5, "variable": "a.b",
                                                                          "value": "x"}]}))
    with pytest.raises(SystemError_, match=r"j.json: changes\[0\].value = 'x' is not a finite number"):
        S.read(j)
    (tmp_path / "k.yaml").write_text("kind: stop\nstop_time: 1\nwhen: 3\n")
    with pytest.raises(SystemError_, match="k.yaml: unknown key 'when'"):
        S.read(tmp_path / "k.yaml")
    with pytest.raises(SystemError_, match="does not exist"):
        S.read(tmp_path / "none.yaml")


def _frame(t, w, angle, extra=None) -> pd.DataFrame:
    df = pd.DataFrame({"flywheel.crank.w": w, "flywheel.crank.phi": angle, **(extra or {})},
                      index=pd.Index(t, name="time"))
    df.attrs["units"] = {c: "" for c in df.columns}
    return df


def test_the_stop_quantities_of_a_constant_deceleration():
    """A shaft at w0 decelerating at a from t_e: it stops w0/a later having turned w0^2/(2a) (closed form; the
    quantity counts the shaft stopped below 1 % of w0, i.e. 0.99 w0/a and w0 T - a T^2/2 with T that time)."""
    system = load("bed_drive")
    w0, a, t_e, dt = 6.0, 20.0, 1.5, 1e-4
    t = np.arange(0, 2.2 + dt / 2, dt)
    w = np.where(t < t_e, w0, np.maximum(w0 - a * (t - t_e), 0.0))
    angle = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * dt)])    # the exact integral of w
    stop = Scenario("stop", "", "stop", 2.2, (Change(t_e, "motor.supply", 0.0),), watch="bed.bed.s")
    bed = 0.15 + 0.14 * np.sin(angle + bed_drive_origin())
    q = S.transient(system, stop, _frame(t, w, angle, {"bed.bed.s": bed}))
    T = 0.99 * w0 / a
    assert q["stopping_time"] == pytest.approx(T, abs=2 * dt)
    assert q["stopping_angle"] == pytest.approx(math.degrees(w0 * T - 0.5 * a * T * T), abs=math.degrees(w0 * 2 * dt))
    k = (t >= t_e)
    prior_max = bed[(t >= t_e - 2 * math.pi / w0) & (t < t_e)].max()
    assert q["overrun"] == pytest.approx(max(0.0, bed[k].max() - prior_max), abs=1e-3)


def bed_drive_origin() -> float:
    return load("bed_drive").quantities.cycle_origin


def test_the_startup_quantities_of_a_first_order_run_up():
    """w = W (1 - exp(-t/tau)): 95 % of W at -tau ln(0.05), the angle there W (t95 - tau 0.95) (closed form)."""
    system = load("bed_drive")
    W, tau, dt = 6.5, 0.3, 1e-4
    t = np.arange(0, 6.0 + dt / 2, dt)
    w = W * (1 - np.exp(-t / tau))
    angle = W * (t - tau * (1 - np.exp(-t / tau)))
    q = S.transient(system, Scenario("up", "", "startup", 6.0), _frame(t, w, angle))
    t95 = -tau * math.log(0.05)
    assert q["final_speed"] == pytest.approx(W / (2 * math.pi / 60), rel=1e-6)
    assert q["time_to_speed"] == pytest.approx(t95, rel=1e-4)
    assert q["angle_to_speed"] == pytest.approx(math.degrees(W * (t95 - tau * 0.95)), rel=1e-4)


def test_a_jam_from_the_command_line(tmp_path):
    """run bed_drive --scenario jam: the bed wedged by a catch at 0.16 m; the jam's quantities printed (the motor's
    overload and pull-out named) and written beside the result; the jam's instant and speed drop equal to those
    computed from the result's columns (the bed passing the stop's position after it was set)."""
    import subprocess
    import sys

    out = tmp_path / "jam.csv"
    r = subprocess.run([sys.executable, "-m", "harness", "run", "bed_drive", "--scenario", "jam", "--out", str(out),
                        "--quiet-quantities"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert "scenario jam (jam)" in r.stdout and "OVERLOAD" in r.stdout and "PULLED OUT" in r.stdout
    saved = {q["name"]: q["value"] for q in json.loads((tmp_path / "jam.transient.json").read_text())["quantities"]}
    df = pd.read_csv(out, index_col=0)
    sc = S.find(load("bed_drive"), "jam")
    stop = dict(sc.parameters)["bed.stop_position"]
    after = df[df.index >= sc.changes[0].time]
    k = int(np.flatnonzero(after["bed.bed.s"].to_numpy() > stop)[0])
    s0, s1 = after["bed.bed.s"].iloc[k - 1], after["bed.bed.s"].iloc[k]
    t0, t1 = after.index[k - 1], after.index[k]
    t_j = t0 + (stop - s0) / (s1 - s0) * (t1 - t0)
    assert saved["jam_time"] == pytest.approx(t_j, abs=1e-9)
    w = df["flywheel.crank.w"]
    w_j = np.interp(t_j, df.index, w)
    assert saved["speed_drop"] == pytest.approx(100 * (1 - w[df.index >= t_j].abs().min() / abs(w_j)), rel=1e-6)
    assert saved["speed_drop"] > 99.0 and saved["rack_force_peak"] > 10 * 500.0   # blocked: far above printing


@pytest.mark.slow
def test_an_emergency_stop_of_the_bed_drive_against_the_monolithic_reference():
    """The bed drive at speed, stopped at 0.5 s (motor off, brake at twice rated torque after 50 ms): the run is
    complete (a drive that stops is not a diverged one), and the co-simulation's crank speed and stopping time
    agree with the monolithic reference, which integrates the brake's hold and slide as events."""
    from harness.studies.reference import scenario_reference

    system = load("bed_drive")
    base = S.find(system, "estop")
    sc = Scenario("estop_early", base.question, "stop", 1.1,
                  tuple(Change(0.5, c.variable, c.value) for c in base.changes), base.parameters, base.watch)
    df = simulate_scenario(system, sc, on_error="raise")
    assert df.attrs["complete"]
    # a stop runs on until the drive has settled (harness.run.settling); the reference a little further (its own
    # settling is judged on what follows), compared over the run's time
    ref = scenario_reference(system, sc, step=system.experiment.step, stop_time=float(df.index[-1]) + 0.25)
    w, wr = df["flywheel.crank.w"].to_numpy(), ref["flywheel.crank.w"].to_numpy()[:len(df)]
    assert np.allclose(ref.index[:len(df)], df.index, atol=1e-12)
    assert np.max(np.abs(w - wr)) < 0.005 * np.ptp(wr)
    q_ref = S.transient(system, sc, ref)
    q = df.attrs["transient"]
    assert q["stopping_time"] == pytest.approx(q_ref["stopping_time"], abs=2 * system.experiment.step)
    assert q["stopping_angle"] == pytest.approx(q_ref["stopping_angle"], rel=0.01)
    # the first standstill is followed by the belt's ring-down (stops.py: ring_down_peak); once settled, the
    # reference's crank stays inside the band that defines rest (harness.reporting.stops.BAND of the speed at 0.5 s)
    from harness.reporting.stops import BAND

    assert q_ref["settle_time"] is not None and q_ref["settle_time"] >= q_ref["stopping_time"]
    w_ref = ref["flywheel.crank.w"].to_numpy()
    band = BAND * abs(float(np.interp(0.5, ref.index, w_ref)))
    assert np.all(np.abs(w_ref[ref.index >= 0.5 + q_ref["settle_time"]]) <= band)


# -- the accuracy a scenario declares, and the cheapest method that meets it -------------------------------------
def test_a_scenario_without_a_declared_accuracy_is_refused_in_one_line(tmp_path):
    from harness.studies.accuracy import scenario_spec

    system = load("bed_drive")
    f = tmp_path / "plain.yaml"
    f.write_text("name: plain\nkind: stop\nstop_time: 1.0\nchanges:\n  - {time: 0.5, variable: motor.brake, value: 1}\n")
    with pytest.raises(ValueError) as e:
        scenario_spec(system, str(f))
    text = str(e.value)
    assert "\n" not in text and "scenario plain" in text and "declares no accuracy" in text and "estop" in text
    assert scenario_spec(system, "estop").accuracy


@pytest.mark.parametrize("drive", ["bed_drive", "feeder_gto52", "proof_press", "spine_knife", "trimmer_conveyor"])
def test_every_shipped_scenario_declares_the_accuracy_of_its_question(drive):
    """Each scenario asks its kind's quantities: a start-up its time to speed, a speed change its new speed, a stop
    its stopping time and angle, a load step its speed drop, a blocking jam its time to the first standstill; each
    beside the peak torques it puts on the parts; a
    transient quantity each names is one the scenario's kind reports."""
    asked = {"startup": "time_to_speed", "speed_change": "speed_after", "stop": "stopping_time", "load": "speed_drop",
             "jam": "time_to_block"}
    system = load(drive)
    for sc in system.scenarios:
        names = [r.quantity for r in sc.accuracy]
        assert asked[sc.kind] in names, (drive, sc.name, names)
        assert any(n.endswith("_torque_peak") for n in names), (drive, sc.name, names)
        assert all(r.tolerance > 0 for r in sc.accuracy)


def test_a_scenario_file_declares_its_accuracy(tmp_path):
    f = tmp_path / "stop.yaml"
    f.write_text("name: s\nkind: stop\nstop_time: 1.0\nchanges:\n  - {time: 0.5, variable: motor.brake, value: 1}\n"
                 "accuracy:\n  - {name: t, quantity: stopping_time, tolerance: 0.002, unit: s}\n"
                 "  - {name: w, quantity: 'r[\"flywheel.crank.w\"]', tolerance: 0.1, unit: rad/s, relative: true}\n")
    sc = S.read(f)
    assert [(r.name, r.quantity, r.tolerance, r.relative) for r in sc.accuracy] == [
        ("t", "stopping_time", 0.002, False), ("w", 'r["flywheel.crank.w"]', 0.1, True)]
    f.write_text("name: s\nstop_time: 1.0\naccuracy:\n  - {name: t, quantity: stopping_time, tolerance: -1}\n")
    with pytest.raises(SystemError_, match=r"accuracy\[0\]\.tolerance = -1 is negative"):
        S.read(f)


def _early_estop(system, accuracy=None):
    """The bed drive's estop moved to 0.5 s and cut to 1.1 s (a shorter reference), with its declared accuracy."""
    from dataclasses import replace

    base = S.find(system, "estop")
    return replace(base, name="estop_early", stop_time=1.1, accuracy=accuracy or base.accuracy,
                   changes=tuple(Change(0.5, c.variable, c.value) for c in base.changes))


@pytest.fixture(scope="module")
def early_estop_reference():
    from harness.studies.reference import scenario_reference

    system = load("bed_drive")
    return scenario_reference(system, _early_estop(system), step=1e-4)


@pytest.mark.slow
def test_the_cheapest_method_meeting_an_estops_declared_accuracy(early_estop_reference):
    """The study judges each run by the scenario's own accuracy against the monolithic reference and names the
    cheapest by FMU steps: jacobi at 1 ms diverges in the bed drive, at 0.5 ms it meets; a step whose grid misses
    the event time (0.3 ms: 0.5 s is no multiple) is not run."""
    from harness.studies.accuracy import cheapest, search_scenario

    system = load("bed_drive")
    sc = _early_estop(system)
    table = search_scenario(system, sc, methods=(("jacobi", 1),), steps=(3e-4, 5e-4, 1e-3),
                            reference=early_estop_reference)
    assert list(table["step"]) == [5e-4, 1e-3]
    assert list(table["meets"]) == [True, False] and not table["complete"].iloc[1]
    for r in sc.accuracy:
        assert table[r.name].iloc[0] <= r.tolerance
    best = cheapest(table)
    assert best["step"] == 5e-4 and best["master"] == "jacobi"
    # the same run judged against a tighter stopping time than its 0.5 ms grid resolves: none meets
    from harness.specs import Requirement

    tight = _early_estop(system, (Requirement("stopping time", "stopping_time", 1e-6, "s"),))
    table = search_scenario(system, tight, methods=(("jacobi", 1),), steps=(5e-4,), reference=early_estop_reference)
    assert not table["meets"].any() and table["complete"].all() and cheapest(table) is None
    assert table["stopping time"].iloc[0] > 1e-6


@pytest.mark.slow
def test_the_scenario_accuracy_study_from_the_command_line_refuses_in_one_line_when_none_meets(tmp_path):
    import subprocess
    import sys

    f = tmp_path / "tight_stop.yaml"
    f.write_text("name: tight_stop\nkind: stop\nstop_time: 0.7\n"
                 "parameters: {motor.holding_torque: 60.0, motor.brake_delay: 0.05}\n"
                 "changes:\n  - {time: 0.5, variable: motor.supply, value: 0.0}\n"
                 "  - {time: 0.5, variable: motor.brake, value: 1.0}\n"
                 "accuracy:\n  - {name: crank speed, quantity: 'r[\"flywheel.crank.w\"]', tolerance: 1.0e-9, "
                 "unit: rad/s}\n")
    r = subprocess.run([sys.executable, "-m", "harness", "study", "accuracy", "bed_drive", "--scenario", str(f),
                        "--masters", "jacobi:1", "--steps", "5e-4", "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=900)
    assert r.returncode == 1, r.stderr
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 1 and "no method and step of the ladder meets the accuracy of bed_drive, scenario " \
                               "tight_stop (1 runs)" in lines[0]
    table = pd.read_csv(tmp_path / "accuracy_bed_drive_tight_stop.csv")
    assert table["complete"].all() and not table["meets"].any()
