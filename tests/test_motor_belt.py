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


def test_bad_parameters_are_named():
    with pytest.raises(ParameterError, match="w_rated"):
        MotorBeltModel(MotorBeltParams(w_rated=200.0, w_sync=157.0))
    with pytest.raises(ParameterError, match="breakdown_ratio = 1.0"):
        MotorBeltModel(MotorBeltParams(breakdown_ratio=1.0))


def cosimulate(motor: MotorBeltModel, load: InertiaModel, h: float, T: float):
    """Motor -> belt -> driven pulley (an inertia with a constant load torque), exchanged every h."""
    xm = motor.initial_state((0.0, load.p.w0))
    xl = load.initial_state(())
    rows = []
    for k in range(int(round(T / h))):
        t = k * h
        u_motor = (xl[0], xl[1])
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
    t, w_d, tau, w_m, m_motor, p_el, p_mech, belt = out[-1]
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
    x = motor.initial_state((phi0, w_d))
    assert motor.output(0.0, x, (phi0, w_d))[0] == pytest.approx(p.d_belt * (r_m * p.w_rated - r_d * w_d) * r_d)
    for k in range(100):
        x = motor.advance(k * h, h, x, (phi0 + w_d * k * h, w_d))
    t = 100 * h
    y = motor.output(t, x, (phi0 + w_d * t, w_d))
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
    x = motor.initial_state((0.0, 0.0))
    x[1] = 1.0  # kick the rotor
    h, ts, ws = 1e-4, [], []
    for k in range(2000):
        ws.append(x[1])
        ts.append(k * h)
        x = motor.advance(k * h, h, x, (0.0, 0.0))
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
    x = model.initial_state((0.0, w_d))
    for k in range(300):
        u = (w_d * k * h, w_d)
        s.setReal([vr["pulley.phi"], vr["pulley.w"]], list(u))
        got = s.getReal(refs)
        want = model.output(k * h, x, u)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)
        s.doStep(k * h, h)
        x = model.advance(k * h, h, x, u)
    s.terminate()
    s.freeInstance()
    assert got[1] > 0.5 * p0.w_rated   # the motor has run up
