"""Scenarios (harness.scenarios): the input table of a scenario's changes, its checks, scenario files, and the
transients of the shipped drives against closed forms and the monolithic reference."""
from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from harness import load
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
