"""RackBed: tier 1 (equations in-process) and tier 2 (the built FMU through fmpy)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fmus.physics.rack_bed import RackBedModel, RackBedParams
from test_fmus_built import open_fmu

G = 9.80665


def drive(R, T=0.5, stroke=0.8):
    """Pinion speed sampled at step midpoints: the bed goes 0 -> stroke -> 0 in T (one printing cycle)."""
    amp, om = 0.5 * stroke / R, 2.0 * math.pi / T
    return lambda t, h: amp * om * math.sin(om * (t + 0.5 * h))


def run(model, h, T, speed, phi0=0.0, both_sides=False):
    """Co-simulate the model with a pinion turning at the held speed ``speed(t, h)`` on each step (the angle
    advances exactly as the model extrapolates it).  Returns the outputs at each step start; with
    ``both_sides`` the mean of the values just before and just after the new speed is set."""
    n = int(round(T / h))
    phi, w_old = phi0, speed(0.0, h)
    x = model.initial_state((phi, w_old))
    rows = []
    for k in range(n):
        t = k * h
        w = speed(t, h)
        y = np.array(model.output(t, x, (phi, w)))
        if both_sides:
            y = 0.5 * (y + np.array(model.output(t, x, (phi, w_old))))
        rows.append(np.concatenate(([t, phi, w], y)))
        x = model.advance(t, h, x, (phi, w))
        phi += w * h
        w_old = w
    return np.array(rows)


def test_pitch_radius_zone_profile_and_parameter_errors():
    m = RackBedModel(RackBedParams(module=0.005, z_pinion=30))
    assert m.R == pytest.approx(0.005 * 30 / 2, rel=1e-15)
    p = m.p
    assert m.zone(p.s_print_start) == 0.0 and m.zone(p.s_print_end) == 0.0
    assert m.zone(0.5 * (p.s_print_start + p.s_print_end)) == 1.0
    assert m.zone(p.s_print_start + 0.5 * p.ramp) == pytest.approx(0.5, abs=1e-15)  # smoothstep midpoint
    s = np.linspace(p.s_print_start - 0.01, p.s_print_end + 0.01, 20001)
    g = np.array([m.zone(v) for v in s])
    assert np.max(np.abs(np.diff(g))) <= 1.5 * (s[1] - s[0]) / p.ramp * (1 + 1e-9)  # continuous, slope 1.5/ramp
    assert m.printing_load(0.4, -0.5) == 0.0  # no load on the return stroke (bad parameters: test_parameter_errors)


@pytest.mark.parametrize("v_bed", [0.3, -0.3])
def test_rigid_level_at_constant_speed_is_friction_plus_printing_load(v_bed):
    p = RackBedParams(fidelity=0)
    m = RackBedModel(p)
    R = m.R
    phi0 = 0.4 / R  # middle of the printing zone
    out = run(m, 1e-3, 0.01, lambda t, h: v_bed / R, phi0=phi0)
    tau = out[-1, 3]
    forward = v_bed > 0
    expected_force = (p.mu * p.m_T * G * math.tanh(v_bed / p.v_reg) + p.d_visc * v_bed
                      + (p.F_print * math.tanh(v_bed / p.v_reg) if forward else 0.0))
    assert tau == pytest.approx(-R * expected_force, rel=1e-12)
    assert out[-1, 4] == pytest.approx(R * out[-1, 1], rel=1e-15)  # bed.s = R*phi
    assert out[-1, 6] == 0.0  # bed.a at constant speed


def test_elastic_level_settles_to_the_static_mesh_deflection():
    p = RackBedParams(fidelity=1)
    m = RackBedModel(p)
    R, v = m.R, 0.1
    out = run(m, 1e-3, 0.5, lambda t, h: v / R, phi0=0.3 / R)
    f_expected = p.mu * p.m_T * G * math.tanh(v / p.v_reg) + p.d_visc * v + p.F_print * math.tanh(v / p.v_reg)
    t, phi, w, tau, s, vb, a, f = out[-1]
    assert f == pytest.approx(f_expected, rel=1e-6)
    assert R * phi - s == pytest.approx(f_expected / p.c_mesh, rel=1e-5)
    assert tau == pytest.approx(-R * f, rel=1e-15)
    assert vb == pytest.approx(v, rel=1e-9) and abs(a) < 1e-6


def test_energy_balance_of_the_elastic_level_over_a_printing_cycle():
    """Work of the pinion = change of kinetic + mesh energy + friction, load and mesh-damping losses."""
    c, mass = 1.0e7, 250.0
    p = RackBedParams(fidelity=1, c_mesh=c, d_mesh=2 * 0.3 * math.sqrt(c * mass), m_T=mass)
    m = RackBedModel(p)
    R, h, T = m.R, 1e-4, 0.5
    speed = drive(R, T)

    def zone(s):  # smoothstep ramps, written again from the documented profile
        x = np.clip((s - p.s_print_start) / p.ramp, 0, 1)
        y = np.clip((p.s_print_end - s) / p.ramp, 0, 1)
        return (3 * x**2 - 2 * x**3) * (3 * y**2 - 2 * y**3)

    def losses(s, v, w):
        fric = p.mu * mass * G * math.tanh(v / p.v_reg) + p.d_visc * v
        load = p.F_print * zone(s) * max(0.0, math.tanh(v / p.v_reg))
        return (fric + load) * v + p.d_mesh * (R * w - v) ** 2

    def energy(x, phi):
        return 0.5 * mass * x[1] ** 2 + 0.5 * c * (R * phi - x[0]) ** 2

    phi = 0.0
    x = m.initial_state((phi, speed(0.0, h)))
    e0, work, lost = energy(x, phi), 0.0, 0.0
    for k in range(int(round(T / h))):
        t, w = k * h, speed(k * h, h)
        f0, l0 = m.output(t, x, (phi, w))[4], losses(x[0], x[1], w)
        x = m.advance(t, h, x, (phi, w))
        phi += w * h
        f1, l1 = m.output(t + h, x, (phi, w))[4], losses(x[0], x[1], w)
        work += R * w * h * 0.5 * (f0 + f1)
        lost += h * 0.5 * (l0 + l1)
    gained = energy(x, phi) - e0
    assert lost > 0.0 and work > 0.0
    assert work == pytest.approx(gained + lost, rel=2e-4)


def test_rigid_and_elastic_levels_converge_as_the_mesh_stiffens():
    """The pinion torque of fidelity 1 tends to that of fidelity 0 when c_mesh grows (step resolving the
    mesh: omega*h fixed; samples averaged across the held-speed jump) and the deflection falls as 1/c."""
    mass, T = 250.0, 0.5
    errors, deflections = [], []
    for c, h in ((1e6, 1e-3), (1e7, 3.16e-4), (1e8, 1e-4)):
        common = dict(m_T=mass, c_mesh=c, d_mesh=2 * math.sqrt(c * mass))
        rigid = RackBedModel(RackBedParams(fidelity=0, **common))
        elastic = RackBedModel(RackBedParams(fidelity=1, **common))
        speed = drive(rigid.R, T)
        a = run(rigid, h, T, speed, both_sides=True)
        b = run(elastic, h, T, speed, both_sides=True)
        keep = slice(len(a) // 10, None)  # after the start transient
        errors.append(np.sqrt(np.mean((a[keep, 3] - b[keep, 3]) ** 2)) / np.max(np.abs(b[:, 3])))
        deflections.append(np.max(np.abs(b[:, 1] * rigid.R - b[:, 4])))
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 3e-3
    assert deflections[0] / deflections[1] == pytest.approx(10.0, rel=0.05)
    assert deflections[1] / deflections[2] == pytest.approx(10.0, rel=0.05)


# -- tier 2: the built FMU ---------------------------------------------------------------------------------

def run_fmu(path, params: dict, speed, h, n):
    md, s = open_fmu(path, name="rackbed")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    types = {v.name: v.type for v in md.modelVariables}
    s.setupExperiment(startTime=0.0)
    for name, value in params.items():
        (s.setInteger if types[name] == "Integer" else s.setReal)([vr[name]], [value])
    s.enterInitializationMode()
    phi = 0.0
    s.setReal([vr["pinion.phi"], vr["pinion.w"]], [phi, speed(0.0, h)])
    s.exitInitializationMode()
    outs = [vr[n_] for n_ in ("pinion.tau", "bed.s", "bed.v", "bed.a", "mesh_force")]
    rows = []
    for k in range(n):
        w = speed(k * h, h)
        s.setReal([vr["pinion.phi"], vr["pinion.w"]], [phi, w])
        rows.append(s.getReal(outs))
        s.doStep(k * h, h)
        phi += w * h
    s.terminate()
    s.freeInstance()
    return np.array(rows)


@pytest.mark.parametrize("fidelity", [0, 1])
def test_fmu_reproduces_the_equation_layer(fmu_dir, fidelity):
    params = dict(fidelity=fidelity, m_T=180.0, z_pinion=20)
    model = RackBedModel(RackBedParams(**params))
    speed = drive(model.R, T=0.5)
    h, n = 1e-3, 200
    got = run_fmu(fmu_dir / "RackBed.fmu", params, speed, h, n)
    want = run(model, h, n * h, speed)[:, 3:]
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
