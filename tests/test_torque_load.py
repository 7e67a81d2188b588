"""TorqueLoad: tier 1 (equations in-process) and tier 2 (the built FMU through fmpy)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fmus.physics.base import ParameterError
from fmus.physics.elements import InertiaModel, InertiaParams
from fmus.physics.loads import TorqueLoadModel, TorqueLoadParams
from test_fmus_built import open_fmu


def spin(load: TorqueLoadModel, J: float, w0: float, h: float, T: float, phi0: float = 0.0):
    """An inertia driven only by the load (the load as motion-input partner), exchanged every h.  The load is
    static, so it is queried at the step-midpoint angle (a leapfrog-like exchange, second order)."""
    inertia = InertiaModel(InertiaParams(J=J, w0=w0, phi0=phi0))
    x = inertia.initial_state(())
    rows = []
    for k in range(int(round(T / h))):
        tau = load.output(k * h, (), (x[0] + 0.5 * h * x[1], x[1]))[0]
        rows.append((k * h, x[0], x[1], tau))
        x = inertia.advance(k * h, h, x, (tau,))
    return np.array(rows)


def test_pure_friction_load_only_dissipates():
    load = TorqueLoadModel(TorqueLoadParams(T_coulomb=3.0, d=0.2, w_reg=0.05))
    rng = np.random.default_rng(1)
    for phi, w in rng.normal(scale=(10.0, 5.0), size=(200, 2)):
        (tau,) = load.output(0.0, (), (phi, w))
        assert tau * w <= 0.0
    assert load.output(0.0, (), (1.0, 0.0)) == (0.0,)


def test_coulomb_and_viscous_spin_down_follows_the_closed_form():
    """J*w' = -T_c - d*w for w >> w_reg: w(t) = (w0 + T_c/d)*exp(-d*t/J) - T_c/d, stop at t* = J/d*ln(1 + d*w0/T_c)."""
    J, tc, d, w0 = 0.05, 0.4, 0.02, 30.0
    load = TorqueLoadModel(TorqueLoadParams(T_coulomb=tc, d=d, w_reg=1e-4))
    out = spin(load, J, w0, 1e-4, 3.0)
    t_stop = J / d * math.log(1 + d * w0 / tc)
    moving = out[:, 0] < 0.9 * t_stop
    closed = (w0 + tc / d) * np.exp(-d * out[moving, 0] / J) - tc / d
    np.testing.assert_allclose(out[moving, 2], closed, rtol=1e-3, atol=1e-3)
    assert out[-1, 0] > 1.2 * t_stop and abs(out[-1, 2]) < 1e-2   # then stays at rest (regularised stiction)


def test_return_spring_and_constant_torque_give_the_shifted_oscillation():
    """T_const and c: equilibrium phi_ref - T_const/c, frequency sqrt(c/J)."""
    J, c, t0, ref = 0.02, 8.0, 0.5, 0.3
    load = TorqueLoadModel(TorqueLoadParams(T_const=t0, c=c, phi_ref=ref))
    out = spin(load, J, 0.0, 5e-5, 1.0, phi0=ref)
    centre = ref - t0 / c
    amp = ref - centre                                  # released from rest at phi_ref
    assert np.max(out[:, 1]) == pytest.approx(ref, abs=2e-3 * amp)
    assert np.min(out[:, 1]) == pytest.approx(centre - amp, abs=2e-3 * amp)
    closed = centre + amp * np.cos(math.sqrt(c / J) * out[:, 0])
    np.testing.assert_allclose(out[:, 1], closed, atol=2e-3 * amp)


def test_bad_parameters_are_named():
    with pytest.raises(ParameterError, match="w_reg = 0.0"):
        TorqueLoadModel(TorqueLoadParams(w_reg=0.0))
    with pytest.raises(ParameterError, match="fidelity = 1"):
        TorqueLoadModel(TorqueLoadParams(fidelity=1))


def test_fmu_reproduces_the_equation_layer(fmu_dir):
    params = dict(T_const=0.7, T_coulomb=1.5, w_reg=0.02, d=0.1, c=2.0, phi_ref=-0.4)
    load = TorqueLoadModel(TorqueLoadParams(**params))
    md, s = open_fmu(fmu_dir / "TorqueLoad.fmu", name="load")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s.setupExperiment(startTime=0.0)
    s.setReal([vr[k] for k in params], list(params.values()))
    s.enterInitializationMode()
    s.exitInitializationMode()
    h = 1e-3
    for k in range(50):
        u = (0.1 * k, 3.0 * math.sin(0.4 * k))
        s.setReal([vr["flange.phi"], vr["flange.w"]], list(u))
        assert s.getReal([vr["flange.tau"]])[0] == pytest.approx(load.output(k * h, (), u)[0], rel=1e-15, abs=1e-15)
        s.doStep(k * h, h)
    s.terminate()
    s.freeInstance()
