"""A jam that blocks the tool: the end stop of RackBed and ParallelShafts (fmus.physics.contact.EndStop) against
closed forms, and the shipped jams (spine_knife, bed_drive) against independent computations: the blocked knife
drive's static balance (the motor's locked-rotor torque from its Kloss curve, through the belt, against the stop
and the cut), the bed's impact on its stop (a linear oscillator), the overload named."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from fmus.physics.parallel_shafts import ParallelShaftsModel, ParallelShaftsParams
from fmus.physics.rack_bed import RackBedModel, RackBedParams

M_BED, K_STOP, ZETA = 250.0, 2.0e8, 0.1        # kg, N/m, 1: the bed on a stop of 10 % critical damping
C_STOP = 2.0 * ZETA * math.sqrt(K_STOP * M_BED)


def _free_bed(catch: int) -> RackBedModel:
    """A bed whose only force is its stop (no friction, printing load, guideway damping; a vanishing mesh)."""
    return RackBedModel(RackBedParams(m_T=M_BED, c_mesh=1e-9, d_mesh=0.0, mu=0.0, d_visc=0.0, F_print=0.0,
                                      stop_position=0.16, stop_stiffness=K_STOP, stop_damping=C_STOP,
                                      stop_catch=catch))


def _oscillator(v0: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Penetration and its rate of the bed m on the spring-damper k, c from x = 0, x' = v0 (closed form)."""
    w = math.sqrt(K_STOP / M_BED)
    wd = w * math.sqrt(1.0 - ZETA ** 2)
    decay = np.exp(-ZETA * w * t)
    return v0 / wd * decay * np.sin(wd * t), v0 * decay * (np.cos(wd * t) - ZETA * w / wd * np.sin(wd * t))


@pytest.mark.parametrize("catch", [0, 1])
def test_the_bed_meets_its_stop_as_a_damped_oscillator(catch):
    """The bed arriving at its stop at 0.6 m/s (a step starts at the contact), stepped 0.1 ms at a time: in
    contact it is the closed form's damped oscillator; an end stop that cannot pull lets it go where the closed
    form's force k x + c x' falls to 0, with the closed form's rebound speed (held after: no other force); a
    catch keeps it on the oscillator about the stop for good (the memory set)."""
    m, v0, h = _free_bed(catch), 0.6, 1e-4
    x = m.initial_state((0.0, 0.0))
    x[0], x[1] = 0.16 + 1e-15, v0
    tt = np.linspace(0.0, 6e-3, 600001)
    pen, rate = _oscillator(v0, tt)
    force = K_STOP * pen + C_STOP * rate
    release = int(np.flatnonzero((force <= 0.0) & (tt > 0))[0])      # where an end stop lets go
    for k in range(1, 61):
        x = m.advance((k - 1) * h, h, x, (0.0, 0.0))
        t = k * h
        if catch or tt[release] > t:           # RK4 at 0.09 rad of the contact's frequency per sub-step
            assert x[0] == pytest.approx(0.16 + np.interp(t, tt, pen), abs=1e-5 * np.max(pen)), (k, t)
        elif tt[release] < t - h:              # the release falls inside a sub-step: first order there
            assert x[1] == pytest.approx(rate[release], rel=2e-3), (k, t)
    assert x[-1] == catch                      # the memory: caught only by a catch
    if not catch:
        assert x[1] < -0.1 * v0 and m.stop_load(x[0], x[1], x[-1]) == 0.0    # rebounded off the stop


@pytest.mark.parametrize("catch", [0, 1])
def test_the_knife_node_steps_at_its_stop_as_its_equations_integrate(catch):
    """ParallelShafts at rest with the knife 1 mrad past its stop and 800 N.m pushing it on (it stays in contact,
    swinging about 0.8 mrad): a step of 0.5 ms (an end stop: RK4 on sub-steps; a catch already reached: the
    caught knife's exact linear step) equals a tight integration of its own derivatives (DOP853), and the catch's
    memory is kept."""
    p = ParallelShaftsParams(stop_position=1.0, stop_stiffness=1e6, stop_damping=6.3, stop_catch=catch, w0=0.0,
                             phi0=1.0)
    m = ParallelShaftsModel(p)
    x0 = m.initial_state((0.0, 0.0, 0.0))
    x0[2] += 1e-3
    x0[6] = catch
    u = (0.0, 800.0, 0.0)
    h = 5e-4
    sol = solve_ivp(lambda t, x: m.derivatives(t, x, u, 0.0), (0.0, h), x0, method="DOP853", rtol=1e-12,
                    atol=1e-14, max_step=1e-6)
    assert np.all(sol.y[2] > 1.0)              # in contact throughout: no kink inside the step
    got = m.advance(0.0, h, x0, u)
    scale = np.array([1e-3, 1.0, 1e-3, 1.0, 1e-3, 1.0]) * np.max(np.abs(sol.y[1::2]))  # angles by their motion
    # RK4 on sub-steps of 0.1 rad of the fastest mode (contact.SUBSTEP_PER_PERIOD): ~1e-6 of the motion; exact: 1e-9
    tol = 1e-9 if catch else 2e-5
    assert np.all(np.abs(got[:6] - sol.y[:6, -1]) <= tol * np.maximum(scale, np.abs(sol.y[:6, -1] - x0[:6])))
    assert got[6] == catch


def test_a_stop_needs_the_beds_own_state():
    from fmus.physics.base import ParameterError

    with pytest.raises(ParameterError, match="stop_stiffness.*fidelity 1"):
        RackBedModel(RackBedParams(fidelity=0, stop_stiffness=1e8))


def test_without_a_stop_the_components_step_as_before():
    """stop_stiffness 0 (the default) takes the equations without a stop: the same numbers, to the bit, as a stop
    far out of reach, and RackBed's sub-step is its own."""
    far = dict(stop_position=1e6, stop_damping=1e3)
    bed, bed_far = RackBedModel(RackBedParams()), RackBedModel(RackBedParams(stop_stiffness=1e8, **far))
    assert bed_far.max_substep < bed.max_substep
    x = bed.initial_state((0.3, 2.0))
    assert np.array_equal(bed.advance(0.0, 1e-3, x, (0.3, 2.0))[:2],
                          RackBedModel(RackBedParams(stop_position=1e6)).advance(0.0, 1e-3, x, (0.3, 2.0))[:2])
    shaft = ParallelShaftsModel(ParallelShaftsParams())
    shaft_far = ParallelShaftsModel(ParallelShaftsParams(stop_stiffness=1e6, **far))
    x, u = shaft.initial_state((0.0, 0.0, 0.0)), (3.0, -2.0, 0.0)
    assert np.array_equal(shaft.advance(0.0, 5e-5, x, u), shaft_far.advance(0.0, 5e-5, x, u))


def test_the_blocked_knife_drive_holds_the_stalled_motor():
    """spine_knife's jam: the knife caught at crank angle 135 deg (mid-cut) blocks the drive; held, the motor is
    stalled at its locked-rotor torque (Kloss at slip 1: 2 M_k s_k / (1 + s_k^2), M_k = lambda P / w_n, s_k =
    s_n (lambda + sqrt(lambda^2 - 1))), which the belt (ratio d_driven/d_motor) hands to the knife node, where the
    stop holds it less the cut's torque there (eq. 9 at the sample F_T2: 135 deg is half the cut's time); the
    motor's overload and pull-out are named."""
    from fmus.physics import knife as kn
    from fmus.physics.motor_belt import MotorBeltParams
    from harness import load, simulate_scenario

    system = load("spine_knife")
    df = simulate_scenario(system, "jam")
    q = df.attrs["transient"]
    motor = {**{s.name: s.default for s in MotorBeltParams.specs()}, **system.instance("motor").parameters}
    lam, m_n = motor["breakdown_ratio"], motor["P_rated"] / motor["w_rated"]
    s_k = (1.0 - motor["w_rated"] / motor["w_sync"]) * (lam + math.sqrt(lam * lam - 1.0))
    locked = 2.0 * lam * m_n * s_k / (1.0 + s_k * s_k)
    g = kn.KnifeLoadParams(**system.instance("knife").parameters)
    cut = 0.5 * g.R * kn.k_geo(g.beta, g.gamma, g.alpha3, g.f) * g.F_T2      # eq. (9) at the sample F_T2
    assert q["blocked_time"] is not None and q["time_to_block"] < 0.01
    assert q["motor_torque_held"] == pytest.approx(locked, rel=2e-3)
    ratio = motor["d_driven_pulley"] / motor["d_motor_pulley"]
    assert q["stop_torque_held"] == pytest.approx(ratio * locked - cut, rel=5e-3)
    assert q.row("motor_torque_peak_to_breakdown").what.startswith("OVERLOAD")
    assert q.row("motor_slip_peak").what.startswith("PULLED OUT")
    assert q["motor_torque_peak_to_breakdown"] > 0.8 and q["speed_drop"] == pytest.approx(100.0, abs=1.0)
