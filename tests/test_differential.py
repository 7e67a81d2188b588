"""JamesDifferential (seed 004, paper B): tier 1 in-process, tier 2 through the built FMU."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fmus.physics.base import ParameterError
from fmus.physics.differential import JamesDifferentialModel as Model, JamesDifferentialParams as P

OUT = {n: i for i, n in enumerate(Model.outputs)}
RNG = np.random.default_rng(4)


def out(model, u, x=None):
    x = model.initial_state(u) if x is None else x
    return dict(zip(Model.outputs, model.output(0.0, x, u)))


@pytest.mark.parametrize("teeth", [(72, 24, 24, 3), (60, 18, 24, 3), (80, 28, 24, 4)])
def test_willis_equation_and_paper_ratios(teeth):
    zr, zp, zs, n = teeth
    m = Model(P(z_ring=zr, z_planet=zp, z_sun=zs, n_planets=n))
    for _ in range(5):
        wr, wc = RNG.normal(size=2) * 10.0
        o = out(m, (0.3, wr, -0.2, wc, 0.0))
        assert (o["sun.w"] - wc) / (wr - wc) == pytest.approx(-zr / zs, rel=1e-12)
        assert o["sun.phi"] == pytest.approx(-zr / zs * 0.3 + (1 + zr / zs) * -0.2, rel=1e-12)
    # paper B: i^b_53 = w5/w3 with the carrier stopped, i^3_5b = w5/wb with the ring stopped (eqs. 3, 4)
    i_b53 = out(m, (0, 1.0, 0, 0.0, 0))["sun.w"] / 1.0
    i_35b = out(m, (0, 0.0, 0, 1.0, 0))["sun.w"] / 1.0
    assert i_b53 == pytest.approx(-zr / zs)
    assert i_35b == pytest.approx(1.0 - i_b53)          # eq. (11)


def test_seed_values_for_ratio_three():
    m = Model(P())                                        # defaults: z_ring/z_sun = 3, 3 planets
    assert m.p.z_ring / m.p.z_sun == 3 and m.p.n_planets == 3
    assert out(m, (0, 1.0, 0, 0.0, 0))["sun.w"] == pytest.approx(-3.0)
    assert out(m, (0, 0.0, 0, 1.0, 0))["sun.w"] == pytest.approx(4.0)


def test_static_torque_split_and_power_balance():
    m = Model(P())
    k = m.p.z_ring / m.p.z_sun
    for _ in range(10):
        wr, wc, tau_s = RNG.normal(size=3) * (5.0, 5.0, 100.0)
        o = out(m, (0.0, wr, 0.0, wc, tau_s))
        T_ring, T_c, T_sun = -o["ring.tau"], -o["carrier.tau"], tau_s     # torques applied TO the shafts
        assert T_ring + T_c + T_sun == pytest.approx(0.0, abs=1e-9)        # M_b = M3 + M5 type identity
        assert T_ring == pytest.approx(k * T_sun)                          # M3 = (z3/z5) M5
        assert -T_c == pytest.approx((1 + k) * T_sun)                      # M_b = (1 + z3/z5) M5
        assert o["power_ring"] + o["power_carrier"] == pytest.approx(o["power_sun"], rel=1e-12, abs=1e-9)
        # direct check of power with the bond convention: sum of T*w over the three shafts is zero
        assert T_ring * wr + T_c * wc + T_sun * o["sun.w"] == pytest.approx(0.0, abs=1e-8)


def test_mesh_losses_only_dissipate():
    m = Model(P(efficiency=0.9))
    for _ in range(20):
        wr, wc, tau_s = RNG.normal(size=3) * (5.0, 5.0, 100.0)
        o = out(m, (0.0, wr, 0.0, wc, tau_s))
        loss = o["power_ring"] + o["power_carrier"] - o["power_sun"]
        # carrier-frame power through the mesh and the two bounds of an eta-efficient gear pair
        p_rel = abs(tau_s * (o["sun.w"] - wc))
        assert loss >= -1e-9
        assert loss == pytest.approx(0.1 * p_rel) or loss == pytest.approx((1 / 0.9 - 1) * p_rel)
        assert -o["ring.tau"] - o["carrier.tau"] + tau_s == pytest.approx(0.0, abs=1e-9)


def test_planet_speed_eq13_and_sun_mesh():
    zr, zp, zs = 72, 24, 24
    m = Model(P())
    wr, wc = 2.0, -0.7
    o = out(m, (0, wr, 0, wc, 0))
    # paper convention: omega3 = -w_ring, omega4 = -w_planet, omega_b = w_c; eq. (13)
    omega4 = (-wr) * zr / zp + wc * (zr / zp - 1)
    assert -o["planet_speed"] == pytest.approx(omega4)
    # planet-sun external mesh with the carrier stopped: (w_p - w_c)/(w_s - w_c) = -z_sun/z_planet
    assert (o["planet_speed"] - wc) / (o["sun.w"] - wc) == pytest.approx(-zs / zp)


def _run(model, u, t_end, h=1e-3):
    x = model.initial_state(u)
    t = 0.0
    for i in range(int(round(t_end / h))):
        x = model.advance(i * h, h, x, u)
    return x, out(model, u, x)


def test_stiff_mesh_tends_to_the_rigid_model():
    u0 = (0.0, 3.0, 0.0, 1.5, -40.0)   # constant input speeds, sun loaded against its motion
    rigid = out(Model(P()), u0)
    for c, tol in ((1e5, 1e-2), (1e7, 1e-4)):
        m = Model(P(fidelity=1, c_alpha=c, d_mesh=2.0 * math.sqrt(c * 0.02)))
        u = list(u0)
        x = m.initial_state(u)
        h = 1e-3
        for i in range(300):   # the input angles move with the held speeds
            u[0], u[2] = u0[1] * i * h, u0[3] * i * h
            x = m.advance(i * h, h, x, u)
        u[0], u[2] = u0[1] * 300 * h, u0[3] * 300 * h
        o = out(m, u, x)
        assert o["sun.w"] == pytest.approx(rigid["sun.w"], rel=tol)
        assert o["ring.tau"] == pytest.approx(rigid["ring.tau"], rel=tol)
        assert o["carrier.tau"] == pytest.approx(rigid["carrier.tau"], rel=tol)
        # static deflection of the mesh spring carries the load: M = -sun.tau
        assert o["mesh_torque"] == pytest.approx(40.0, rel=tol)


@pytest.mark.parametrize("c, d, h", [(1e5, 10.0, 2e-4), (1e7, 0.0, 1e-3), (2e4, 5.0, 1.28e-2)])
def test_compliant_mesh_step_is_the_exact_flow(c, d, h):
    """Fidelity 1 takes ONE exponential step per communication step: with the inputs held the sun on its
    mesh is a linear oscillator forced linearly in time, so the step lands on the closed form (scipy's expm of
    the augmented matrix) to 1e-9 of the motion, however stiff the mesh against the step (omega h up to 22)."""
    import scipy.linalg

    m = Model(P(fidelity=1, c_alpha=c, d_mesh=d, ring_sense=-1, ring_offset=0.3))
    u = (0.2, 3.0, -0.1, 1.5, -40.0)
    x0 = np.array(m.initial_state(u)) + (1e-3, -0.2)
    j = m.p.sun_inertia
    (phi_k, w_k), t0 = m.kinematic(u), 0.7
    # y = (q, v, 1, tau): q' = v, v' = (c (phi_k + w_k tau - q) + d (w_k - v) + T) / J, tau' = 1
    aug = np.zeros((4, 4))
    aug[0, 1] = 1.0
    aug[1] = (-c / j, -d / j, (c * phi_k + d * w_k + u[4]) / j, c * w_k / j)
    aug[3, 2] = 1.0
    exact = scipy.linalg.expm(h * aug) @ np.array([x0[0], x0[1], 1.0, 0.0])
    x1 = m.advance(t0, h, x0, u)
    assert abs(x1[0] - exact[0]) < 1e-9 * max(abs(exact[0] - x0[0]), 1e-3)
    assert abs(x1[1] - exact[1]) < 1e-9 * max(abs(exact[1] - x0[1]), abs(exact[1]))


def test_compliant_mesh_energy_balance():
    """Work in through ring, carrier and sun load = change of kinetic + spring energy + damping loss.

    Inputs are piecewise constant speeds with angles accumulated consistently (what a master delivers);
    the powers are integrated by the trapezoid rule inside each step, independent of the model's RK4."""
    p = P(fidelity=1, c_alpha=2e4, d_mesh=5.0)
    m = Model(p)
    h, n = 1e-4, 4000
    phr = phc = 0.0
    x = m.initial_state((0, 0, 0, 0, 0))
    E0 = 0.5 * p.sun_inertia * x[1] ** 2

    def rates(u, x):
        o = out(m, u, x)
        wk = m.kinematic(u)[1]
        return o["power_ring"] + o["power_carrier"] + u[4] * x[1], p.d_mesh * (wk - x[1]) ** 2

    work = dissipated = 0.0
    for i in range(n):
        t = i * h
        wr, wc, ts = 2.0 * math.sin(5 * t), 1.0 - math.cos(3 * t), -10.0 * math.sin(2 * t)
        u0 = (phr, wr, phc, wc, ts)
        phr, phc = phr + wr * h, phc + wc * h
        u1 = (phr, wr, phc, wc, ts)
        x1 = m.advance(t, h, x, u0)
        (a0, d0), (a1, d1) = rates(u0, x), rates(u1, x1)
        work += 0.5 * h * (a0 + a1)
        dissipated += 0.5 * h * (d0 + d1)
        x = x1
    phik = m.kinematic(u1)[0]
    E = 0.5 * p.sun_inertia * x[1] ** 2 + 0.5 * p.c_alpha * (phik - x[0]) ** 2
    assert E - E0 > 1e-3
    assert work == pytest.approx(E - E0 + dissipated, rel=1e-3)


# ------------------------------------------------------------------------------------------------ tier 2
def _open(fmu_dir, name="JamesDifferential"):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    path = fmu_dir / f"{name}.fmu"
    md = read_model_description(str(path))
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)), modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="diff")
    s.instantiate()
    return {v.name: v for v in md.modelVariables}, s


def test_fmu_rigid_willis_and_power(fmu_dir):
    v, s = _open(fmu_dir)
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    vr = lambda *n: [v[x].valueReference for x in n]
    s.setReal(vr("ring.phi", "ring.w", "carrier.phi", "carrier.w", "sun.tau"), [0.1, 2.0, 0.05, 0.5, -30.0])
    s.doStep(0.0, 1e-3)
    sw, pr, pc, ps, rt = s.getReal(vr("sun.w", "power_ring", "power_carrier", "power_sun", "ring.tau"))
    assert (sw - 0.5) / (2.0 - 0.5) == pytest.approx(-72 / 24)
    assert pr + pc == pytest.approx(ps)
    assert rt == pytest.approx(-3.0 * -30.0)
    s.terminate()
    s.freeInstance()


def test_fmu_compliant_mesh_follows_the_kinematics(fmu_dir):
    v, s = _open(fmu_dir)
    s.setupExperiment(startTime=0.0)
    s.setInteger([v["fidelity"].valueReference], [1])
    s.enterInitializationMode()
    s.exitInitializationMode()
    vr = lambda *n: [v[x].valueReference for x in n]
    h = 1e-3
    for i in range(200):
        s.setReal(vr("ring.phi", "ring.w", "carrier.phi", "carrier.w", "sun.tau"), [1.0 * i * h, 1.0, 0.0, 0.0, 0.0])
        s.doStep(i * h, h)
    s.setReal(vr("ring.phi", "ring.w"), [200 * h, 1.0])   # inputs at the new time before reading outputs
    sw, m = s.getReal(vr("sun.w", "mesh_torque"))
    assert sw == pytest.approx(-3.0, rel=1e-3)
    assert abs(m) < 1.0
    s.terminate()
    s.freeInstance()


@pytest.mark.parametrize("fidelity", [0, 1])
def test_reversing_pair_is_the_reversed_connection(fidelity):
    """ring_sense = -1 with ring_offset o is the plain differential driven at (o - phi, -w) with its ring
    torque reversed: the same machine as a connection with factor -1 and offset o (power kept)."""
    o = 0.7
    rev = Model(P(fidelity=fidelity, ring_sense=-1, ring_offset=o))
    plain = Model(P(fidelity=fidelity))
    u = (0.3, 2.0, -0.1, 1.5, -40.0)
    u_plain = (o - u[0], -u[1], *u[2:])
    x_rev, x_plain = rev.initial_state(u), plain.initial_state(u_plain)
    np.testing.assert_allclose(x_rev, x_plain, rtol=1e-15, atol=1e-15)
    for _ in range(5):
        x_rev, x_plain = rev.advance(0.0, 1e-3, x_rev, u), plain.advance(0.0, 1e-3, x_plain, u_plain)
    np.testing.assert_allclose(x_rev, x_plain, rtol=1e-12, atol=1e-15)
    y_rev, y_plain = rev.output(0.0, x_rev, u), plain.output(0.0, x_plain, u_plain)
    names = Model.outputs
    assert y_rev[names.index("ring.tau")] == pytest.approx(-y_plain[names.index("ring.tau")], rel=1e-12)
    for name in ("carrier.tau", "sun.phi", "sun.w", "power_ring", "power_carrier", "planet_speed"):
        assert y_rev[names.index(name)] == pytest.approx(y_plain[names.index(name)], rel=1e-12, abs=1e-12)
    # the power through the port is the gear set's: ring.tau * ring.w (port values) = plain's
    assert y_rev[0] * u[1] == pytest.approx(y_plain[0] * u_plain[1], rel=1e-12)


def test_ring_sense_admits_only_plus_or_minus_one():
    with pytest.raises(ParameterError, match="ring_sense"):
        Model(P(ring_sense=0))
