"""Torsional modes (harness.studies.modes) against seed 003's closed forms and against the ringing of a run."""
import math

import numpy as np
import pytest

from fmus.physics.parallel_shafts import eq10_frequencies, shaft_stiffness
from harness.run import load, simulate_scenario
from harness.specs import Change, Scenario
from harness.studies.modes import modes


def _hz(M, K):
    return np.sort(np.sqrt(np.linalg.eigvals(np.linalg.solve(M, K)).real)) / (2 * math.pi)


def test_rigid_knife_drive_has_the_modes_of_seed_003_eq_10():
    """spine_knife_rigid: the drive end absolutely rigid, the seed's eq. (10): 72.68 and 1029.11 Hz."""
    p = load("spine_knife_rigid").instance("shaft").parameters
    c1 = shaft_stiffness(p["G"], p["d"], p["l"])
    expected = np.array(eq10_frequencies(p["J_red"], p["J_flywheel"], c1, p["belt_stiffness"])) / (2 * math.pi)
    found = modes("spine_knife_rigid")
    assert [m.frequency for m in found.modes] == pytest.approx(list(expected), rel=1e-6)
    assert [round(m.frequency, 2) for m in found.modes] == [72.68, 1029.11]      # docs/seed_003.md
    knife = found.modes[1]
    assert max(knife.shape, key=lambda k: abs(knife.shape[k])) == "shaft.w_knife"


def test_belt_knife_drive_modes_match_the_three_mass_closed_form():
    """spine_knife: the motor belt (c_belt r^2) on the drive-end flywheel, the two shafts (c1 each) to the knife,
    the V-belt (c2) to J1: K, M as tests/test_seed_003.py, 13.19, 103.92, 1031.65 Hz."""
    s = load("spine_knife")
    motor, p = s.instance("motor").parameters, s.instance("shaft").parameters
    cm = motor["c_belt"] * (motor["d_driven_pulley"] / 2) ** 2
    c1, c2 = shaft_stiffness(p["G"], p["d"], p["l"]), p["belt_stiffness"]
    K = np.array([[c1 + c2 + cm, -c1, -c2], [-c1, 2 * c1, -c1], [-c2, -c1, c1 + c2]])
    M = np.diag([p["J_drive"], p["J_red"], p["J_flywheel"]])
    undamped = modes(s, {"motor.d_belt": 0.0, "shaft.belt_damping": 0.0, "shaft.psi": 0.0})
    assert [m.frequency for m in undamped.modes] == pytest.approx(list(_hz(M, K)), rel=1e-9)
    found = modes(s)        # the belts' damping, not proportional, moves |lambda| by 1.3e-4 (measured)
    assert [m.frequency for m in found.modes] == pytest.approx(list(_hz(M, K)), rel=5e-4)
    assert found.speed == pytest.approx(600.0, rel=1e-9)
    assert found.modes[1].exciting and all(abs(n / 600.0 - 1) <= 0.2 for _, n in found.modes[1].exciting)
    # the orders: f_n / (10 cycles/s); 103.92 Hz meets order 10 at 600 * 10.392 / 10 rpm
    assert dict(found.modes[1].exciting)[10] == pytest.approx(600 * found.modes[1].frequency / 10 / 10, rel=1e-9)


def test_the_ringing_after_a_stop_is_the_lowest_mode():
    """The knife drive stopped by the motor brake rings on its lowest mode (the rotor held, as the ideal source
    holds it): the spectrum's peak of the main shaft's speed between the first standstill and settled is 13.19 Hz
    to 1 % (measured: 13.20 Hz)."""
    s = load("spine_knife")
    estop = next(sc for sc in s.scenarios if sc.name == "estop")
    short = Scenario("estop_early", estop.question, "stop", 0.2,
                     tuple(Change(0.1, c.variable, c.value) for c in estop.changes), estop.parameters,
                     settle_limit=2.0)
    df = simulate_scenario(s, short)
    q = df.attrs["transient"]
    t = df.index.to_numpy()
    on = (t >= 0.1 + q["stopping_time"]) & (t <= 0.1 + q["settle_time"])
    x = df["shaft.crank.w"].to_numpy()[on]
    x = (x - x.mean()) * np.hanning(x.size)
    n = 1 << 18
    f = np.fft.rfftfreq(n, t[1] - t[0])[np.argmax(np.abs(np.fft.rfft(x, n)))]
    assert f == pytest.approx(modes(s).modes[0].frequency, rel=1e-2)
