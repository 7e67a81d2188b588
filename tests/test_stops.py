"""A stop runs until the drive has settled (harness.run.settling) and its quantities (harness.reporting.stops)
do not depend on the stop time asked; checked against the closed forms of
../shared/reference/press-engineering-facts.md ("Stopping") on a flywheel braked through a belt."""
import math

import numpy as np
import pytest

from harness.model import Experiment, Instance, System, bond
from harness.reporting import stops
from harness.run import simulate_scenario
from harness.specs import Change, QuantitySpec, Scenario
from systems import motor_inputs

RPM = 2 * math.pi / 60
W_RATED, RATIO, J_LOAD, J_MOTOR = 1425 * RPM, 5.0, 1.0, 0.007   # rad/s, 1, kg.m2, kg.m2
T_RATED = 2200.0 / W_RATED                                       # N.m: MotorBelt's default 2200 W
DELAY = 0.02                                                     # s


def _flywheel():
    """A 1 kg.m2 flywheel belt-driven by the default motor (ratio 5) at its rated point: the load's viscous
    torque balances the rated torque (d = T_rated * ratio / w), so the run starts steady."""
    w0 = W_RATED / RATIO
    s = System(name="braked_flywheel", description="flywheel braked through its belt",
               instances=[Instance("load", "Inertia", {"J": J_LOAD, "w0": w0, "d_ground": T_RATED * RATIO / w0}),
                          Instance("motor", "MotorBelt", {"fidelity": 1, "J_motor": J_MOTOR, "d_motor_pulley": 0.1,
                                                          "d_driven_pulley": 0.1 * RATIO, "c_belt": 2e6,
                                                          "d_belt": 2e3})],
               bonds=[bond("load.flange", "motor.pulley")],
               experiment=Experiment(stop_time=0.3, step=1e-4, master="jacobi", extrapolation=1),
               free_inputs=motor_inputs())
    s.quantities = QuantitySpec(shaft_angle="load.flange.phi", shaft_speed="load.flange.w", shaft_name="flywheel",
                                motor="motor")
    # at 0.1 s: the motor off, its brake (twice rated) after 20 ms, the load's damping gone (a free flywheel)
    stop = Scenario("estop", "stop", "stop", 0.3, (Change(0.1, "motor.supply", 0.0), Change(0.1, "motor.brake", 1.0),
                                                   Change(0.1, "load.d_ground", 0.0)),
                    parameters=(("motor.holding_torque", 2 * T_RATED), ("motor.brake_delay", DELAY)))
    return s, stop


def test_stop_matches_the_closed_forms_and_not_the_stop_time_asked():
    system, stop = _flywheel()
    df = simulate_scenario(system, stop)
    q = df.attrs["transient"]
    w = q["speed_at_command"] * RPM                           # rad/s of the flywheel at the command
    j = J_LOAD + J_MOTOR * RATIO ** 2                         # kg.m2 reduced to the flywheel
    a = 2 * T_RATED * RATIO / j                               # rad/s2: the brake's torque reduced to the flywheel
    # facts, Stopping: t = t_d + w / a, angle = w t_d + w^2 / (2 a), energy 1/2 J w^2; to the 1 % band of the first
    # standstill a constant deceleration takes (1 - 0.01) w / a and turns (1 - 0.01^2) w^2 / (2 a); the belt's
    # compliance moves them by less than 0.2 % (measured: 0.2677 s, 261.0 deg, 578.6 J against 0.2677 s, 261.0 deg,
    # 579.0 J)
    b = stops.BAND
    assert q["stopping_time"] == pytest.approx(DELAY + (1 - b) * w / a, rel=2e-3)
    assert q["stopping_angle"] == pytest.approx(math.degrees(w * DELAY + (1 - b * b) * w * w / (2 * a)), rel=2e-3)
    assert q["brake_energy"] == pytest.approx(0.5 * j * w * w, rel=5e-3)
    # the run went on past the asked 0.3 s until settled; asked longer, the same numbers
    assert df.index[-1] > 0.3 and q["settle_time"] is not None
    assert df.index[-1] == pytest.approx(0.1 + q["settle_time"] + stops.HOLD, abs=2e-4)
    longer = simulate_scenario(system, stop, stop_time=0.9).attrs["transient"]
    assert longer.to_dict()["quantities"] == q.to_dict()["quantities"]
    # the brake energy is the integral of the brake's power from the command to settled (numpy)
    t = df.index.to_numpy()
    on = (t >= 0.1) & (t <= 0.1 + q["settle_time"])
    p = -(df["motor.brake_torque"] * df["motor.motor_speed"]).to_numpy()
    assert q["brake_energy"] == pytest.approx(np.trapezoid(p[on], t[on]), rel=1e-9)


def test_first_standstill_and_settled_apart():
    """A speed that rings after its first standstill: the first time inside the band, and the time after which
    it stays inside (seen for the hold)."""
    t = np.linspace(0.0, 2.0, 2001)
    w = np.where(t < 0.5, 10.0 * (1 - t / 0.5), 0.5 * np.exp(-(t - 0.5) / 0.1) * np.sin(40 * (t - 0.5)))
    assert stops.first_inside(t, w, 0, 0.1) == pytest.approx(0.5 * (1 - 0.1 / 10.0), abs=1e-9)
    settle = stops.settled_at(t, w, 0, 0.1)
    ring = np.abs(w) > 0.1
    assert settle == pytest.approx(t[np.flatnonzero(ring)[-1] + 1])
    assert settle > 0.55
    assert stops.settled_at(t[t < settle + 0.1], w[t < settle + 0.1], 0, 0.1) is None   # not seen for 0.25 s


def test_overrun_only_for_a_tool_that_dwells_or_reverses():
    t = np.linspace(0, 1, 101)
    assert stops.reverses(np.sin(2 * np.pi * t)) and not stops.reverses(t + 0.1 * np.sin(2 * np.pi * t))
    assert stops.reverses(np.minimum(t, 0.5))          # a dwell


def test_duty_cycle_equivalent_torque_against_numpy():
    """harness duty: T_eq = sqrt((N_s int_start T^2 + N_e int_stop T^2 + t_run T_rms^2) / (N_s t_s + N_e t_e + t_run
    + K t_rest)) recomputed with numpy from the three runs it made (facts: the motor's thermal duty)."""
    from harness.studies.duty import Duty, duty
    from systems import motor_scenarios

    system, _ = _flywheel()
    system.experiment = Experiment(stop_time=0.6, step=2e-4, master="jacobi", extrapolation=1)
    system.scenarios = motor_scenarios(system, {"load.w0": 0.0}, change_at=0.3, stop_time=1.2)
    table = duty(system, Duty(starts=30, stops=12, running=0.5, cooling_at_rest=0.5))
    runs = table.runs
    t_of = lambda df: df.index.to_numpy()  # noqa: E731
    tq = lambda df: df["motor.motor_torque"].to_numpy()  # noqa: E731
    steady = runs["steady"].attrs["quantities"].cycles.steady
    t = t_of(runs["steady"])
    on = (t >= steady[0]) & (t <= steady[1])
    rms = math.sqrt(np.trapezoid(tq(runs["steady"])[on] ** 2, t[on]) / (steady[1] - steady[0]))
    up, down = runs["startup"], runs["estop"]
    a = up.attrs["quantities"].cycles.steady[0]
    on = t_of(up) <= a
    start_sq = np.trapezoid(tq(up)[on] ** 2, t_of(up)[on])
    c, s = down.attrs["stop_command"], down.attrs["transient"]["settle_time"]
    on = (t_of(down) >= c) & (t_of(down) <= c + s)
    stop_sq = np.trapezoid(tq(down)[on] ** 2, t_of(down)[on])
    busy = 30 * a + 12 * s
    t_eq = math.sqrt((30 * start_sq + 12 * stop_sq + 1800 * rms ** 2) / (busy + 1800 + 0.5 * (1800 - busy)))
    assert table["duty_torque_rms"] == pytest.approx(t_eq, rel=1e-3)
    assert table["duty_torque_rms_to_rated"] == pytest.approx(t_eq / T_RATED, rel=1e-3)
    assert table["brake_power_mean"] == pytest.approx(12 * down.attrs["transient"]["brake_energy"] / 3600)


def test_size_the_brake_for_a_stopping_angle():
    """size --scenario: the brake torque that stops the flywheel within 200 deg, against the closed form
    T_b = J w^2 (1 - 0.01^2) / (2 ratio (theta - w t_d)) (facts: brake sizing, to the 1 % band)."""
    from harness.studies.size import size

    system, stop = _flywheel()
    found = size(system, "motor.holding_torque", "stopping_angle <= 200", (15.0, 60.0), xtol=1e-2, scenario=stop)
    speed = found.verifying.attrs["transient"]["speed_at_command"] * RPM
    j = J_LOAD + J_MOTOR * RATIO ** 2
    theta = math.radians(200.0)
    closed = j * speed ** 2 * (1 - stops.BAND ** 2) / (2 * RATIO * (theta - speed * DELAY))
    assert found.answer == pytest.approx(closed, rel=1e-2)
    assert found.verified <= 200.0


def test_a_jam_names_the_motors_overload_and_pull_out():
    """A load step's motor verdicts against the Kloss curve's closed forms: M_k = 2.2 T_rated, s_k = s_n (2.2 +
    sqrt(2.2^2 - 1)) (fmus/physics/motor_belt.py's rating), on a made-up result of bed_drive's motor."""
    import pandas as pd

    from harness.run import load

    system = load("bed_drive")
    m = system.instance("motor").parameters
    m_k = 2.2 * m["P_rated"] / m["w_rated"]
    s_n = 1 - m["w_rated"] / m["w_sync"]
    s_k = s_n * (2.2 + math.sqrt(2.2 ** 2 - 1))
    for torque, slip, words in ((0.5 * m_k, 0.5 * s_k, ("within the margin", "on the stable branch")),
                                (0.9 * m_k, 1.5 * s_k, ("OVERLOAD", "PULLED OUT"))):
        t = np.linspace(0, 1, 11)
        df = pd.DataFrame({"motor.motor_torque": np.full(11, torque),
                           "motor.motor_speed": np.full(11, (1 - slip) * m["w_sync"])}, index=pd.Index(t))
        rows = {}
        stops.overload_rows(system, "motor", df, t >= 0.5,
                            lambda name, value, unit, what, note="": rows.setdefault(name, (value, what)))
        assert rows["motor_torque_peak_to_breakdown"][0] == pytest.approx(torque / m_k)
        assert rows["motor_slip_peak"][0] == pytest.approx(100 * slip)
        assert rows["motor_torque_peak_to_breakdown"][1].startswith(words[0])
        assert rows["motor_slip_peak"][1].startswith(words[1])
