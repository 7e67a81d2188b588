"""size: one parameter of a drive sized to an engineering-quantity target (harness.studies.size)."""
from __future__ import annotations

import subprocess
import sys

import pytest

from harness import load
from harness.errors import SystemError_
from harness.studies.size import Target, parse_target, size


def test_a_target_is_a_quantity_an_operator_and_a_value():
    assert parse_target("speed_fluctuation <= 5") == Target("speed_fluctuation", "<=", 5.0)
    assert parse_target(" motor_torque_rms_to_rated>=0.5e-1 ") == Target("motor_torque_rms_to_rated", ">=", 0.05)
    for bad in ("speed_fluctuation < 5", "5 <= speed_fluctuation", "speed_fluctuation <= five", "<= 5"):
        with pytest.raises(SystemError_, match="expected 'QUANTITY <= VALUE' or 'QUANTITY >= VALUE'|not a number"):
            parse_target(bad)


@pytest.mark.parametrize("args, message", [
    (("--vary", "flywheel.J_flywheel", "--target", "speed_fluctuaton <= 5"),
     "no quantity 'speed_fluctuaton' (did you mean speed_fluctuation"),
    (("--vary", "flywheel.J_flywhel", "--target", "speed_fluctuation <= 5"),
     "has no parameter 'J_flywhel' (did you mean J_flywheel"),
    (("--vary", "flywheel.J_flywheel", "--target", "speed_fluctuation <= 5", "--range", "4", "2"),
     "bracket [4, 2] of flywheel.J_flywheel must be two positive increasing values"),
    (("--vary", "flywheel.J_flywheel", "--target", "speed_fluctuation <= 5", "--scheduler", "127.0.0.1:9"),
     "--scheduler 127.0.0.1:9: cannot connect"),
])
def test_bad_input_is_one_line_before_any_run(args, message):
    r = subprocess.run([sys.executable, "-m", "harness", "size", "bed_drive", *args], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 1 and r.stdout == "" and message in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "points to t" not in r.stderr


@pytest.mark.slow
def test_the_trimmer_motor_sized_to_a_thermal_target_against_its_closed_form():
    """The trimmer's motor is an ideal speed source: its torque is the belt's whatever its rating, so
    motor_torque_rms / (P_rated / w_rated) falls as 1/P_rated, and the smallest rating that keeps it <= 0.8 is
    P0 r0 / 0.8 from one run at P0 (closed form); a target no rating in the bracket meets names the range."""
    system = load("trimmer_conveyor")
    one = size(system, "motor.P_rated", "motor_torque_rms_to_rated <= 0.8", (1000.0, 8000.0), xtol=1e-4,
               stop_time=1.2)
    assert one.answer is not None
    p_any, r_any = next(iter(one.runs.items()))
    want = p_any * r_any / 0.8
    assert one.answer == pytest.approx(want, rel=2e-3) and one.verified <= 0.8 + 1e-9
    assert "the smallest value" in one.message
    none = size(system, "motor.P_rated", "motor_torque_rms_to_rated <= 0.01", (1000.0, 8000.0), stop_time=1.2)
    assert none.answer is None and "no value of motor.P_rated in [1000, 8000] meets" in none.message
    assert "motor_torque_rms_to_rated took" in none.message


@pytest.mark.slow
def test_more_candidates_than_the_root_findings_budget_are_all_run():
    """The root finding's budget (max_runs, 16) counts the runs after the candidates: 17 candidates run (as one
    batch), then Brent's method, and the answer is the closed form of the test above (P0 r0 / 0.8 from any run).
    At one step for every FMU (the declared experiment's own rate for the knife load is not batched)."""
    one = size(load("trimmer_conveyor"), "motor.P_rated", "motor_torque_rms_to_rated <= 0.8", (1000.0, 8000.0),
               xtol=1e-3, stop_time=1.2, step=2.5e-4, candidates=17)
    assert len(one.runs) > 17 and one.answer is not None
    p_any, r_any = next(iter(one.runs.items()))
    assert one.answer == pytest.approx(p_any * r_any / 0.8, rel=2e-3) and one.verified <= 0.8 + 1e-9


def test_a_changed_drive_object_is_refused_for_a_scheduler_before_any_run():
    """The workers load the drive by its name: an object that differs from what its name loads would be sized
    as another drive, so it is refused in one line (an unchanged one goes by its name)."""
    import dataclasses

    from harness.studies.size import _sent

    system = load("trimmer_conveyor")
    assert _sent(system, system) == "trimmer_conveyor" and _sent(system, "trimmer_conveyor") == "trimmer_conveyor"
    changed = dataclasses.replace(system, instances=system.instances[::-1])
    with pytest.raises(SystemError_, match="differs from the one 'trimmer_conveyor' loads; give the name or file"):
        size(changed, "motor.P_rated", "motor_torque_rms_to_rated <= 0.8", (1000.0, 8000.0),
             scheduler="127.0.0.1:9")


@pytest.mark.slow
def test_sizing_on_a_dask_cluster_gives_the_serial_answer_from_the_same_runs():
    """Two local worker processes: the bracket's ends run at once, then Brent's runs one by one through the
    client; every run, the answer, the message and the verifying run equal the serial search's."""
    import logging

    from dask.distributed import LocalCluster

    args = ("trimmer_conveyor", "motor.P_rated", "motor_torque_rms_to_rated <= 0.8", (1000.0, 8000.0))
    serial = size(*args, xtol=1e-2, stop_time=1.2)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster:
        spread = size(*args, xtol=1e-2, stop_time=1.2, scheduler=cluster.scheduler_address)
    assert serial.answer is not None and len(serial.runs) >= 4
    assert spread.runs == serial.runs and spread.answer == serial.answer and spread.message == serial.message
    assert spread.verifying.equals(serial.verifying)
    assert spread.verifying.attrs["quantities"]["motor_torque_rms_to_rated"] == serial.verified


@pytest.mark.parametrize("op, q_lo, q_hi, upward", [
    ("<=", 3.0, 2.0, True),     # met at neither end, the quantity falls as the parameter rises: the answer above
    ("<=", 2.0, 3.0, False),    # met at neither, rising: below
    ("<=", 0.3, 0.2, False),    # met at both, falling: the boundary (where it gets worse) below
    ("<=", 0.2, 0.3, True),     # met at both, rising: above
    (">=", 3.0, 2.0, True),     # met at both (>= 1), falling: worse above
    (">=", 0.3, 0.2, False),    # met at neither, falling: better below
    ("<=", 2.0, 2.0, None),     # flat: no way to widen
])
def test_the_default_bracket_widens_towards_the_answer(op, q_lo, q_hi, upward):
    from harness.studies.size import _outward

    assert _outward(parse_target(f"q {op} 1"), q_lo, q_hi) is upward


@pytest.mark.slow
def test_a_target_outside_the_default_bracket_is_found_by_widening_it():
    """The trimmer's motor_torque_rms / rated torque falls as 1 / P_rated (its motor is an ideal speed source): a
    target a tenth of the drive's value lies at ten times its rating, outside the default bracket (a quarter to
    four times it); the bracket widens to sixteen times and finds P0 r0 / target (closed form), and says so."""
    from harness import simulate
    from harness.studies.size import _current

    system = load("trimmer_conveyor")
    p0 = _current(system, "motor.P_rated")
    r0 = simulate(system, stop_time=1.2).attrs["quantities"]["motor_torque_rms_to_rated"]
    found = size(system, "motor.P_rated", f"motor_torque_rms_to_rated <= {r0 / 10!r}", xtol=1e-3, stop_time=1.2)
    assert found.answer == pytest.approx(10 * p0, rel=2e-3)
    assert found.bracket == pytest.approx((4 * p0, 16 * p0)) and "the bracket widened from" in found.message


def test_the_bracket_widens_no_further_than_its_limit_and_what_the_fmu_admits():
    """Four times further out each time, up to 64 times the drive's value (1/64 of it downward), and no further;
    a value the FMU refuses (a rated speed at or above the synchronous one) moved back towards the last end."""
    from harness.studies.size import WIDEN, _beyond, _current

    system = load("trimmer_conveyor")
    p0 = _current(system, "motor.P_rated")
    assert _beyond(system, "motor.P_rated", p0, 4 * p0, True, {}) == pytest.approx(16 * p0)
    assert _beyond(system, "motor.P_rated", p0, 16 * p0, True, {}) == pytest.approx(WIDEN * p0)
    assert _beyond(system, "motor.P_rated", p0, WIDEN * p0, True, {}) is None
    assert _beyond(system, "motor.P_rated", p0, p0 / 16, False, {}) == pytest.approx(p0 / WIDEN)
    w0 = _current(system, "motor.w_rated")
    w_sync = _current(system, "motor.w_sync")
    up = _beyond(system, "motor.w_rated", w0, w0, True, {})
    assert w0 < up < w_sync      # 4 w0 is refused (above the synchronous speed): moved back below it
