"""FlywheelShaft: tier 1 (equations in-process) and tier 2 (the built FMU through fmpy)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fmus.physics.flywheel_shaft import FlywheelShaftModel, FlywheelShaftParams
from test_fmus_built import open_fmu


def stiffness(p):
    return p.G * math.pi * p.d ** 4 / (32 * p.l)   # one solid round shaft


def run(model, torques, h, n):
    """Advance with held torques(t) -> (pulley.tau, crank.tau, aux.tau); outputs at every step end."""
    x = model.initial_state((0.0, 0.0, 0.0))
    rows = [model.output(0.0, x, torques(0.0))]
    for k in range(n):
        x = model.advance(k * h, h, x, torques(k * h))
        rows.append(model.output((k + 1) * h, x, torques((k + 1) * h)))
    return np.array(rows)


def kick(duration, torque=50.0):
    """A short torque pulse on the flywheel, then free motion."""
    return lambda t: (torque if t < duration - 1e-12 else 0.0, 0.0, 0.0)


def test_natural_frequency_of_the_free_vibration():
    p = FlywheelShaftParams(psi=0.0, J_flywheel=1.2, J_crank=0.2, J_flywheel2=0.1)
    m = FlywheelShaftModel(p)
    j1, j2 = p.J_flywheel, p.J_crank + p.J_flywheel2
    expected = math.sqrt(stiffness(p) * (j1 + j2) / (j1 * j2))
    h, n = 2e-5, 20000
    twist = run(m, kick(1e-3), h, n)[:, 7]
    t = np.arange(n + 1) * h
    sign = np.sign(twist[60:])                      # after the pulse
    idx = np.nonzero(sign[:-1] * sign[1:] < 0)[0] + 60
    # zero crossings by linear interpolation, then the mean half period
    zeros = t[idx] - twist[idx] * h / (twist[idx + 1] - twist[idx])
    half = (zeros[-1] - zeros[0]) / (len(zeros) - 1)
    assert math.pi / half == pytest.approx(expected, rel=1e-6)


def test_exact_step_agrees_with_an_independent_ode_solution():
    p = FlywheelShaftParams(psi=0.8)
    m = FlywheelShaftModel(p)
    c = stiffness(p)
    j1, j2 = p.J_flywheel, p.J_crank + p.J_flywheel2
    j = j1 * j2 / (j1 + j2)
    b = p.psi * math.sqrt(c * j) / (2 * math.pi)
    tp, tc, ta = 120.0, -70.0, -20.0

    def rhs(t, y):
        ts = c * (y[0] - y[2]) + b * (y[1] - y[3])
        return [y[1], (tp - ts) / j1, y[3], (tc + ta + ts) / j2]

    T = 0.05
    ref = solve_ivp(rhs, (0, T), [p.phi0, p.w0, p.phi0, p.w0], method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
    for h in (T, T / 7):    # any step size: the step is exact for held torques
        x = m.initial_state((0, 0, 0))
        for k in range(int(round(T / h))):
            x = m.advance(k * h, h, x, (tp, tc, ta))
        np.testing.assert_allclose(x[:4], ref, rtol=1e-9, atol=1e-11)


def test_energy_is_conserved_without_damping_and_work_is_accounted():
    p = FlywheelShaftParams(psi=0.0)
    m = FlywheelShaftModel(p)
    free = run(m, kick(2e-3), 1e-4, 2000)
    energy = free[:, 8] + free[:, 9]
    after = energy[25:]                              # torque-free from t = 2 ms on
    assert np.ptp(after) <= 1e-12 * after[0]
    # constant torques: energy gain = work of the three torques on their own ports
    torques = (80.0, -30.0, -25.0)
    out = run(m, lambda t: torques, 1e-3, 300)
    work = (torques[0] * (out[-1, 0] - out[0, 0]) + (torques[1] + torques[2]) * (out[-1, 2] - out[0, 2]))
    gain = out[-1, 8] + out[-1, 9] - out[0, 8] - out[0, 9]
    assert gain == pytest.approx(work, rel=1e-10)


def test_loss_coefficient_sets_the_decay_of_the_free_vibration():
    """Ratio of successive twist peaks = exp(-2*pi*zeta/sqrt(1 - zeta^2)) with zeta = psi/(4*pi)."""
    p = FlywheelShaftParams(psi=0.5)
    m = FlywheelShaftModel(p)
    twist = run(m, kick(1e-3), 1e-5, 20000)[200:, 7]
    peaks = [twist[i] for i in range(1, len(twist) - 1) if twist[i - 1] < twist[i] >= twist[i + 1] and twist[i] > 0]
    zeta = p.psi / (4 * math.pi)
    ratio = np.exp(np.mean(np.diff(np.log(peaks))))
    assert ratio == pytest.approx(math.exp(-2 * math.pi * zeta / math.sqrt(1 - zeta * zeta)), rel=2e-3)


def test_rigid_level_equals_compliant_level_with_a_very_stiff_shaft():
    def torques(t):
        return (300.0 + 200.0 * math.sin(40 * t), -250.0 * (1 + math.sin(25 * t)) ** 2, -50.0 * math.cos(60 * t))

    stiff = dict(G=8.1e10 * 1e6)
    rigid = run(FlywheelShaftModel(FlywheelShaftParams(fidelity=0, **stiff)), torques, 1e-3, 500)
    elastic = run(FlywheelShaftModel(FlywheelShaftParams(fidelity=1, **stiff)), torques, 1e-3, 500)
    for col in (0, 1, 2, 3, 4, 5, 8):                 # motions of all ports, kinetic energy
        np.testing.assert_allclose(elastic[:, col], rigid[:, col], rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(elastic[1:, 6], rigid[1:, 6], rtol=1e-4, atol=1e-3)   # shaft torque
    assert np.all(rigid[:, 7] == 0.0) and np.all(np.abs(elastic[:, 7]) < 1e-6)
    np.testing.assert_array_equal(rigid[:, 0], rigid[:, 2])


# -- tier 2: the built FMU ---------------------------------------------------------------------------------

@pytest.mark.parametrize("fidelity", [0, 1])
def test_fmu_reproduces_the_equation_layer(fmu_dir, fidelity):
    model = FlywheelShaftModel(FlywheelShaftParams(fidelity=fidelity, J_flywheel2=0.4))
    md, s = open_fmu(fmu_dir / "FlywheelShaft.fmu", name="flywheel")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s.setupExperiment(startTime=0.0)
    s.setInteger([vr["fidelity"]], [fidelity])
    s.setReal([vr["J_flywheel2"]], [0.4])
    s.enterInitializationMode()
    s.exitInitializationMode()
    ins = [vr[n] for n in model.inputs]
    outs = [vr[n] for n in model.outputs]
    h = 1e-3
    x = model.initial_state((0.0, 0.0, 0.0))
    for k in range(200):
        u = (100.0 * math.sin(30 * k * h), -60.0, -10.0 * math.cos(50 * k * h))
        s.setReal(ins, list(u))
        np.testing.assert_allclose(s.getReal(outs), model.output(k * h, x, u), rtol=1e-14, atol=1e-12)
        s.doStep(k * h, h)
        x = model.advance(k * h, h, x, u)
    s.terminate()
    s.freeInstance()
