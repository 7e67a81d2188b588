"""MotorBelt: tier 1 (equations in-process) and tier 2 (the built FMU through fmpy)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

from fmus.physics.base import ParameterError
from fmus.physics.elements import InertiaModel, InertiaParams
from fmus.physics.motor_belt import MotorBeltModel, MotorBeltParams
from test_fmus_built import open_fmu


def rated(p: MotorBeltParams):
    """Rated torque, rated slip, breakdown torque and breakdown slip, recomputed from the nameplate data.
    s_k is found numerically from M(s_n) = M_n (the Kloss curve through the rated point, stable branch)."""
    m_n = p.P_rated / p.w_rated
    s_n = (p.w_sync - p.w_rated) / p.w_sync
    m_k = p.breakdown_ratio * m_n
    s_k = brentq(lambda sk: 2 * m_k / (s_n / sk + sk / s_n) - m_n, s_n * (1 + 1e-12), 1e3)
    return m_n, s_n, m_k, s_k


RUNNING = (1.0, 0.0)  # inputs supply (rated frequency) and brake (released)

SIX_POLE = MotorBeltParams(P_rated=1100.0, w_rated=2 * math.pi * 920 / 60, w_sync=2 * math.pi * 1000 / 60,
                           breakdown_ratio=2.8)


@pytest.mark.parametrize("params", [MotorBeltParams(), SIX_POLE])
def test_kloss_torque_is_rated_at_rated_slip_and_peaks_at_breakdown(params):
    m = MotorBeltModel(params)
    m_n, s_n, m_k, s_k = rated(params)
    assert m.kloss_torque(params.w_rated) == pytest.approx(m_n, rel=1e-12)
    assert m.kloss_torque(params.w_sync) == 0.0
    assert m.kloss_torque(params.w_sync * (1 - s_k)) == pytest.approx(m_k, rel=1e-12)
    # the maximum of the characteristic, found numerically, is the breakdown point
    best = minimize_scalar(lambda w: -m.kloss_torque(w), bounds=(0.0, params.w_sync), method="bounded",
                           options={"xatol": 1e-10})
    assert -best.fun == pytest.approx(m_k, rel=1e-9)
    assert 1 - best.x / params.w_sync == pytest.approx(s_k, rel=1e-4)


def cosimulate(motor: MotorBeltModel, load: InertiaModel, h: float, T: float):
    """Motor -> belt -> driven pulley (an inertia with a constant load torque), exchanged every h."""
    xm = motor.initial_state((0.0, load.p.w0, *RUNNING))
    xl = load.initial_state(())
    rows = []
    for k in range(int(round(T / h))):
        t = k * h
        u_motor = (xl[0], xl[1], *RUNNING)
        y = motor.output(t, xm, u_motor)
        rows.append((t, xl[1], *y))
        xm = motor.advance(t, h, xm, u_motor)
        xl = load.advance(t, h, xl, (y[0],))
    return np.array(rows)


@pytest.mark.parametrize("fidelity,w_start", [(1, -1.0), (2, -1.0), (2, 0.0)])
def test_steady_state_under_a_constant_load(fidelity, w_start):
    p = MotorBeltParams(fidelity=fidelity, w_start=w_start)
    motor = MotorBeltModel(p)
    m_n, s_n, m_k, s_k = rated(p)
    r_m, r_d = p.d_motor_pulley / 2, p.d_driven_pulley / 2
    load_torque = 0.7 * m_n * r_d / r_m            # 70 % of rated torque, seen at the driven pulley
    w0 = 0.0 if w_start == 0.0 else p.w_rated * r_m / r_d
    load = InertiaModel(InertiaParams(J=0.5, tau_drive=-load_torque, w0=w0))
    out = cosimulate(motor, load, 2e-4, 1.5)
    t, w_d, tau, w_m, m_motor, p_el, p_mech, belt, brake = out[-1]
    assert brake == 0.0  # no brake
    # steady state: the motor delivers the load torque through the belt, on the stable Kloss branch
    m_star = load_torque * r_m / r_d
    lam = m_k / m_star
    s_star = s_k * (lam - math.sqrt(lam * lam - 1))            # Kloss inverted (closed form)
    assert tau == pytest.approx(load_torque, rel=1e-6)
    assert m_motor == pytest.approx(m_star, rel=1e-6) and belt == pytest.approx(m_star, rel=1e-6)
    assert w_m == pytest.approx(p.w_sync * (1 - s_star), rel=1e-8)
    creep = p.creep * (m_star / r_m) / (m_n / r_m) if fidelity == 2 else 0.0
    assert w_d == pytest.approx(w_m * r_m / r_d * (1 - creep), rel=1e-8)
    assert p_mech == pytest.approx(m_star * w_m, rel=1e-6)
    assert p_el == pytest.approx(m_star * p.w_sync / p.efficiency, rel=1e-6)
    if w_start == 0.0:
        assert out[0, 3] == 0.0 and out[0, 1] == 0.0  # a run-up from standstill


def test_ideal_source_stretches_the_belt_linearly():
    """Fidelity 0 with the driven pulley held at a slightly lower constant speed: closed-form belt force."""
    p = MotorBeltParams(fidelity=0)
    motor = MotorBeltModel(p)
    r_m, r_d = p.d_motor_pulley / 2, p.d_driven_pulley / 2
    w_d = 0.999 * p.w_rated * r_m / r_d
    phi0, h = 0.3, 1e-3
    x = motor.initial_state((phi0, w_d, *RUNNING))
    assert motor.output(0.0, x, (phi0, w_d, *RUNNING))[0] == pytest.approx(p.d_belt * (r_m * p.w_rated - r_d * w_d) * r_d)
    for k in range(100):
        x = motor.advance(k * h, h, x, (phi0 + w_d * k * h, w_d, *RUNNING))
    t = 100 * h
    y = motor.output(t, x, (phi0 + w_d * t, w_d, *RUNNING))
    slip_speed = r_m * p.w_rated - r_d * w_d
    force = p.c_belt * slip_speed * t + p.d_belt * slip_speed
    assert y[0] == pytest.approx(force * r_d, rel=1e-9)
    assert y[1] == p.w_rated and y[2] == pytest.approx(force * r_m, rel=1e-9)
    assert y[4] == pytest.approx(force * r_m * p.w_rated, rel=1e-9)


def test_belt_energy_balance_with_a_blocked_rotor_free_oscillation():
    """Fidelity 1, pulley held still, no damping and a negligible motor torque: rotor + belt oscillate at
    sqrt(c_belt*r_m^2/J) and kinetic + belt energy is conserved."""
    p = MotorBeltParams(fidelity=1, d_belt=0.0, w_start=0.0, P_rated=1e-9 * 2200.0)  # motor torque ~ 1e-8 N.m
    motor = MotorBeltModel(p)
    x = motor.initial_state((0.0, 0.0, *RUNNING))
    x[1] = 1.0  # kick the rotor
    h, ts, ws = 1e-4, [], []
    for k in range(2000):
        ws.append(x[1])
        ts.append(k * h)
        x = motor.advance(k * h, h, x, (0.0, 0.0, *RUNNING))
    ws = np.array(ws)
    crossings = np.nonzero(np.diff(np.sign(ws)))[0]
    period = 2 * np.mean(np.diff(crossings)) * h
    omega = math.sqrt(p.c_belt * (p.d_motor_pulley / 2) ** 2 / p.J_motor)
    assert 2 * math.pi / period == pytest.approx(omega, rel=2e-3)
    e0 = 0.5 * p.J_motor * 1.0
    e1 = 0.5 * p.J_motor * x[1] ** 2 + motor.belt_energy(x, 0.0)
    assert e1 == pytest.approx(e0, rel=1e-5)


# -- tier 2: the built FMU ---------------------------------------------------------------------------------

def test_fmu_start_up_reproduces_the_equation_layer(fmu_dir):
    params = dict(fidelity=2, w_start=0.0)
    model = MotorBeltModel(MotorBeltParams(**params))
    md, s = open_fmu(fmu_dir / "MotorBelt.fmu", name="motor")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s.setupExperiment(startTime=0.0)
    s.setInteger([vr["fidelity"]], [2])
    s.setReal([vr["w_start"]], [0.0])
    s.enterInitializationMode()
    p0 = MotorBeltParams()
    w_d = p0.w_rated * p0.d_motor_pulley / p0.d_driven_pulley  # driven pulley held at its rated speed
    s.setReal([vr["pulley.phi"], vr["pulley.w"]], [0.0, w_d])
    s.exitInitializationMode()
    names = model.outputs
    refs = [vr[n] for n in names]
    h = 1e-3
    x = model.initial_state((0.0, w_d, *RUNNING))
    for k in range(300):
        u = (w_d * k * h, w_d, *RUNNING)
        s.setReal([vr["pulley.phi"], vr["pulley.w"]], list(u[:2]))
        got = s.getReal(refs)
        want = model.output(k * h, x, u)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)
        s.doStep(k * h, h)
        x = model.advance(k * h, h, x, u)
    s.terminate()
    s.freeInstance()
    assert got[1] > 0.5 * p0.w_rated   # the motor has run up


# -- transients: supply and brake ------------------------------------------------------------------------------

def test_supply_moves_the_kloss_curve_with_the_synchronous_speed():
    """V/f supply: the same breakdown torque at the same slip SPEED below the new synchronous speed; off: 0."""
    p = MotorBeltParams()
    m = MotorBeltModel(p)
    m_n, s_n, m_k, s_k = rated(p)
    for supply in (0.3, 0.8, 1.2):
        w_sync = supply * p.w_sync
        assert m.kloss_torque(w_sync, supply) == 0.0
        assert m.kloss_torque(w_sync - s_k * p.w_sync, supply) == pytest.approx(m_k, rel=1e-12)
        assert m.kloss_torque(w_sync - s_n * p.w_sync, supply) == pytest.approx(m_n, rel=1e-12)
    assert m.kloss_torque(100.0, 1.0) == pytest.approx(m.kloss_torque(100.0, 1.0 + 1e-15), rel=1e-9)
    assert m.kloss_torque(100.0, 0.0) == 0.0 and m.kloss_torque(-5.0, -1.0) == 0.0
    # its slope in the supply, closed form against central differences
    for w, supply in ((100.0, 1.0), (60.0, 0.5), (150.0, 1.1)):
        d = 1e-6
        fd = (m.kloss_torque(w, supply + d) - m.kloss_torque(w, supply - d)) / (2 * d)
        assert m.kloss_supply_slope(w, supply) == pytest.approx(fd, rel=1e-6)


def free_rotor(fidelity=1, **params):
    """A motor whose belt carries no force (c_belt, d_belt tiny): the rotor alone, J_motor."""
    return MotorBeltModel(MotorBeltParams(fidelity=fidelity, c_belt=1e-12, d_belt=0.0, **params))


@pytest.mark.parametrize("fidelity", [1, 2])
def test_brake_decelerates_the_rotor_at_t_over_j_after_its_delay_and_holds(fidelity):
    """Motor off, brake commanded at t = 0 with an engage delay: the rotor keeps its speed for the delay, then
    decelerates at T_b/J: stopping time t_d + w/a, stopping angle w t_d + w^2/(2a) (closed form), then held."""
    t_b, t_d, w0 = 4.0, 0.013, 120.0
    m = free_rotor(fidelity, holding_torque=t_b, brake_delay=t_d, w_start=w0)
    u = (0.0, 0.0, 0.0, 1.0)                    # supply off, brake on
    x = m.initial_state(u)
    a = t_b / m.p.J_motor
    t_stop, angle = t_d + w0 / a, w0 * t_d + w0 * w0 / (2 * a)
    h, t, trace = 1e-3, 0.0, []
    while t < t_stop + 0.05:
        trace.append((t, x[0], x[1], m.output(t, x, u)[6]))
        x = m.advance(t, h, x, u)
        t = round(t + h, 12)
    trace = np.array(trace)
    before = trace[trace[:, 0] < t_d - 1e-9]
    assert np.all(before[:, 2] == w0) and np.all(before[:, 3] == 0.0)
    sliding = trace[(trace[:, 0] > t_d + h) & (trace[:, 0] < t_stop - h)]
    np.testing.assert_allclose(sliding[:, 2], w0 - a * (sliding[:, 0] - t_d), rtol=1e-9, atol=1e-9)
    assert np.all(sliding[:, 3] == -t_b)
    after = trace[trace[:, 0] > t_stop + h]
    assert np.all(after[:, 2] == 0.0) and np.all(abs(after[:, 3]) < 1e-9)   # held; nothing pushes it
    assert after[0, 1] == pytest.approx(angle, rel=1e-9)
    assert np.all(after[:, 1] == after[0, 1])


def test_a_brake_holds_below_its_torque_and_slips_above_it():
    """Rotor at rest, brake engaged, motor supplied: held while the starting torque is below the holding
    torque (the brake's reaction is the motor torque), turning at (M - T_b)/J when it exceeds it."""
    weak = free_rotor(1, w_start=0.0, holding_torque=1.0)
    m0 = weak.kloss_torque(0.0, 1.0)
    assert m0 > 1.0
    strong = free_rotor(1, w_start=0.0, holding_torque=2 * m0)
    u = (0.0, 0.0, 1.0, 1.0)
    x = strong.initial_state(u)
    for k in range(20):
        x = strong.advance(k * 1e-3, 1e-3, x, u)
    assert x[1] == 0.0 and x[0] == 0.0
    assert strong.output(0.02, x, u)[6] == pytest.approx(-m0, rel=1e-12)
    x = weak.initial_state(u)
    x = weak.advance(0.0, 1e-5, x, u)
    assert x[1] == pytest.approx((m0 - 1.0) / weak.p.J_motor * 1e-5, rel=1e-3)
    # the released brake restarts its timer: engaged only brake_delay after the next command
    timed = free_rotor(1, w_start=50.0, holding_torque=1.0, brake_delay=0.01)
    x = timed.initial_state(u)
    x = timed.advance(0.0, 0.008, x, (0.0, 0.0, 0.0, 1.0))
    x = timed.advance(0.008, 0.001, x, (0.0, 0.0, 0.0, 0.0))
    assert x[3] == 0.0
    x = timed.advance(0.009, 0.008, x, (0.0, 0.0, 0.0, 1.0))
    assert x[1] == 50.0 and not timed.brake_engaged(x, (0.0, 0.0, 0.0, 1.0))


def test_start_up_follows_the_kloss_curve():
    """From rest on a free rotor, J dw/dt = M(w): the time to a speed is the integral of J/M(w) dw."""
    from scipy.integrate import quad
    m = free_rotor(1, w_start=0.0)
    u = (0.0, 0.0, 1.0, 0.0)
    x = m.initial_state(u)
    target = 0.9 * m.p.w_sync
    h, t = 1e-4, 0.0
    while x[1] < target:
        x_prev, t_prev = x, t
        x = m.advance(t, h, x, u)
        t += h
    t_cross = t_prev + h * (target - x_prev[1]) / (x[1] - x_prev[1])
    want = quad(lambda w: m.p.J_motor / m.kloss_torque(w), 0.0, target, limit=200)[0]
    assert t_cross == pytest.approx(want, rel=1e-4)


def test_a_brake_at_fidelity_0_is_refused():
    with pytest.raises(ParameterError, match="holding_torque = 5.0.*fidelity 0"):
        MotorBeltModel(MotorBeltParams(fidelity=0, holding_torque=5.0))


@pytest.mark.parametrize("fidelity,x1,brake", [(0, None, 0.0), (1, None, 0.0), (2, None, 0.0), (1, 0.0, 1.0),
                                               (1, 80.0, 1.0)])
def test_output_jacobian_is_the_derivative_of_the_outputs(fidelity, x1, brake):
    """Every column, supply and brake included, against central differences, also holding at rest."""
    m = MotorBeltModel(MotorBeltParams(fidelity=fidelity, holding_torque=0.0 if fidelity == 0 else 30.0))
    u = (0.3, 15.0, 0.9, brake)
    x = m.initial_state(u)
    x[0] += 0.01
    if x1 is not None:
        x[1] = x1
    D = m.output_jacobian(0.0, x, u)
    ref = m.output_jacobian_by_differences(0.0, x, u)
    ref[:, 3] = 0.0   # the brake command is a switch: no slope (its differences straddle 0.5 only by chance)
    scale = np.maximum(np.abs(ref).max(axis=1, keepdims=True), 1e-12)
    np.testing.assert_allclose(D / scale, ref / scale, atol=1e-6)
