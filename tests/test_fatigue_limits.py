"""Fatigue, strength and limits (harness.reporting.fatigue, harness.reporting.limits) against closed forms, on
synthetic results whose answers are known, and the --limits exit status on a short run."""
import json
import math

import numpy as np
import pandas as pd
import pytest

from harness.errors import SystemDescriptionError
from harness.reporting import fatigue, limits
from harness.reporting.quantities import quantities
from harness.run import load


def test_damage_equivalent_closed_forms():
    # a cosine of range 2A once per machine cycle, peak to peak: S_eq = 2A for any slope (9 full cycles and two
    # halves of the ASTM count)
    t = np.linspace(0.0, 10.0, 10001)
    assert fatigue.damage_equivalent(3.0 * np.cos(2 * np.pi * t), 10, 5.0) == pytest.approx(6.0, rel=1e-9)
    # per cycle one range R1 and one range R2 (a big and a small swing): S_eq = (R1^m + R2^m)^(1/m)
    history = np.tile([0.0, 10.0, 0.0, 4.0], 20)
    n = 20
    for m in (3.0, 5.0, 8.0):
        assert fatigue.damage_equivalent(history, n, m) == pytest.approx((10.0 ** m + 4.0 ** m) ** (1 / m), rel=2e-2)
    assert fatigue.damage_equivalent(np.zeros(50), 3) == 0.0


def test_shear_stress_and_belt_capacity_closed_forms():
    assert fatigue.shear_stress(1000.0, 0.05) == pytest.approx(16e3 / (math.pi * 0.05 ** 3))   # 40.7 MPa
    # flat belt, mu 0.3, wrap pi: T = F1 (1 - e^(-0.3 pi)) r
    assert fatigue.belt_capacity(1000.0, 0.3, math.pi, 0.1) == pytest.approx(1000 * (1 - math.exp(-0.3 * math.pi)) * 0.1)
    # V-belt: mu' = mu / sin(groove / 2)
    v = fatigue.belt_capacity(1000.0, 0.3, math.pi, 0.1, math.radians(34.0))
    assert v == pytest.approx(1000 * (1 - math.exp(-0.3 / math.sin(math.radians(17.0)) * math.pi)) * 0.1)


def _synthetic_bed(n_cycles=6, mean=200.0, amp=80.0):
    """A result of bed_drive at a constant 60 rpm whose main-shaft torque is mean + amp sin(crank angle) (other
    columns absent)."""
    system = load("bed_drive")
    spec = system.quantities
    w = 2 * np.pi
    t = np.linspace(0.0, n_cycles, 200 * n_cycles + 1)
    phi = spec.cycle_origin + w * t
    df = pd.DataFrame({spec.shaft_angle: phi, spec.shaft_speed: np.full_like(t, w),
                       "flywheel.shaft_torque": mean + amp * np.sin(phi)}, index=pd.Index(t, name="time"))
    df.attrs["units"] = {"flywheel.shaft_torque": "N.m"}
    return system, quantities(system, df)


def test_quantities_fatigue_and_strength_rows_on_a_known_history():
    system, q = _synthetic_bed()
    d = system.instance("flywheel").parameters["d"]
    assert q["shaft_torque_damage_equivalent"] == pytest.approx(160.0, rel=1e-3)        # 2 A
    assert q["shaft_torque_shear_stress_peak"] == pytest.approx(16 * 280.0 / (math.pi * d ** 3) / 1e6, rel=1e-4)
    assert q["shaft_torque_shear_stress_damage_equivalent"] == pytest.approx(16 * 160 / (math.pi * d ** 3) / 1e6,
                                                                              rel=1e-3)
    belt = system.quantities.belts[0]
    r = system.instance("motor").parameters["d_driven_pulley"] / 2
    expected = belt.tight_force * (1 - math.exp(-belt.mu / math.sin(math.radians(belt.groove / 2))
                                               * math.radians(belt.wrap))) * r
    assert q["belt_torque_transmittable"] == pytest.approx(expected)
    assert q["belt_torque_slip_margin"] is None                     # the belt's torque is not in this result
    assert "m = 5" in q.row("shaft_torque_damage_equivalent").what


def test_limits_judged_pass_fail_and_no_value(tmp_path):
    _, q = _synthetic_bed()
    f = tmp_path / "l.yaml"
    f.write_text('shaft_torque_damage_equivalent: "<= 150"\nshaft_speed_mean: ">= 59"\nbelt_torque_slip_margin: '
                 '">= 1.5"\n')
    found = limits.read(f)
    v = {x.quantity: x for x in limits.judge(found, [("steady", q)])}
    assert not v["shaft_torque_damage_equivalent"].passed        # 160 > 150
    assert v["shaft_speed_mean"].passed                           # 60 rpm
    assert not v["belt_torque_slip_margin"].passed and v["belt_torque_slip_margin"].value is None
    for bad, said in (('x: "< 5"', "is not a limit"), ("- 1", "a mapping"), ('1x: "<= 1"', "not a quantity name")):
        f.write_text(bad)
        with pytest.raises(SystemDescriptionError, match=said):
            limits.read(f)


def test_run_limits_exit_status_and_records(tmp_path, capsys):
    from harness.__main__ import main

    f = tmp_path / "limits.yaml"
    out = tmp_path / "b.csv"
    f.write_text('speed_fluctuation: "<= 50"\nmachine_rate: ">= 3000"\n')
    assert main(["run", "bed_drive", "--limits", str(f), "--out", str(out), "--quiet-quantities"]) == 0
    saved = json.loads((tmp_path / "b.limits.json").read_text())
    assert saved["all_passed"] and [x["verdict"] for x in saved["verdicts"]] == ["pass", "pass"]
    f.write_text('speed_fluctuation: "<= 1"\nmachine_rate: ">= 3000"\n')
    assert main(["run", "bed_drive", "--limits", str(f), "--out", str(out), "--report", str(tmp_path / "b.html")]) == 3
    text = capsys.readouterr().out
    assert "1 of 2 limits met, 1 FAILED" in text and "[FAIL <= 1]" in text
    rows = {r["name"]: r for r in json.loads((tmp_path / "b.quantities.json").read_text())["quantities"]}
    assert rows["speed_fluctuation"]["limit"] == {"op": "<=", "value": 1.0, "verdict": "FAIL"}
    assert "1 FAILED" in (tmp_path / "b.html").read_text()
    f.write_text('speed_fluctuatoin: "<= 1"\n')
    assert main(["run", "bed_drive", "--limits", str(f)]) == 1
    assert "nearest: speed_fluctuation" in capsys.readouterr().err
