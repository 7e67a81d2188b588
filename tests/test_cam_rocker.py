"""CamRocker: tier 1 (equations in-process) and tier 2 (built FMU through fmpy)."""
import math

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from fmus.physics import laws as L
from fmus.physics.cam_rocker import CamRockerModel, CamRockerParams

W = 2 * math.pi * 150 / 60   # 150 rpm (seed 000: 100-200 rpm)


def run(m, t_end, h=1e-3, phi0=0.0, load=0.0):
    u = [phi0, W, load]
    x = m.initial_state(u)
    ys = []
    for k in range(int(round(t_end / h))):
        t = k * h
        u = [phi0 + W * t, W, load]
        x = m.advance(t, h, x, u)
        ys.append(m.output(t + h, x, [phi0 + W * (t + h), W, load]))
    return np.array(ys)


@pytest.mark.parametrize("mech", [0, 1])
def test_rigid_reproduces_the_law(mech):
    p = CamRockerParams(mechanism=mech, law=1)
    m = CamRockerModel(p)
    phi = np.linspace(0, 2 * math.pi, 997)
    if mech == 1:
        cyc = L.DwellCycle(L.get_law("C0"), L.get_law("C0"), p.phase_forward, p.phase_return, 0.0, p.phi_start)
        s, s1, _ = cyc(phi)
        g, g1 = p.swing * s, p.swing * s1
    else:   # independent: law on the base four-bar's extremes
        from fmus.physics import groove as G
        ext = G.fourbar_extremes(p.lambda1, p.lambda2, p.lambda3)
        (pf, gf), (pe, ge) = ext["folded"], ext["extended"]
        cyc = L.DwellCycle(L.get_law("C0"), L.get_law("C0"), (pe - pf) % (2 * math.pi), 2 * math.pi - (pe - pf) % (2 * math.pi), 0.0, pf)
        s, s1, _ = cyc(phi)
        g, g1 = gf + (ge - gf) * s, (ge - gf) * s1
    for i in range(0, len(phi), 7):
        y = m.output(0.0, m.initial_state([phi[i], W, 0]), [phi[i], W, 0.0])
        assert y[1] == pytest.approx(g[i], abs=1e-9) and y[2] == pytest.approx(g1[i] * W, abs=1e-9)


def test_dwell_is_a_dwell_and_power_balance():
    p = CamRockerParams(mechanism=1, dwell=0.5, phase_forward=3.0, phase_return=2.0, phi_start=0.2)
    m = CamRockerModel(p)
    for phi in np.linspace(3.2 + 1e-6, 3.7 - 1e-6, 11):
        y = m.output(0, m.initial_state([phi, W, 0]), [phi, W, -2.0])
        assert y[1] == p.swing and y[2] == 0.0 and y[0] == 0.0
    pz = CamRockerModel(CamRockerParams(mechanism=0, rocker_inertia=1e-12))
    for phi in np.linspace(0, 2 * math.pi, 13):
        y = pz.output(0, pz.initial_state([phi, W, 0]), [phi, W, -3.0])
        # power into the transformer from the crank (-tau*w) plus from the load (tau_load*w_r) is zero
        assert -y[0] * W + (-3.0) * y[2] == pytest.approx(0.0, abs=1e-9)
        assert (y[0] < 0) == (y[2] > 0) or y[2] == 0.0     # a resisted load brakes the crank


def test_rigid_inertia_torque_from_energy():
    """Crank work over a cycle portion equals the change of rocker kinetic energy (unloaded)."""
    m = CamRockerModel(CamRockerParams(mechanism=1))
    J = m.p.rocker_inertia
    phi = np.linspace(0.1, 2.5, 20001)
    tau = np.array([m.output(0, None, [f, W, 0.0])[0] for f in phi])
    wr = np.array([m.output(0, None, [f, W, 0.0])[2] for f in phi])
    work = -np.trapezoid(tau, phi)
    assert work == pytest.approx(0.5 * J * (wr[-1] ** 2 - wr[0] ** 2), rel=1e-5, abs=1e-9)


def test_elastic_converges_to_rigid():
    errs = []
    for k in (2e3, 2e4, 2e5):
        p = CamRockerParams(mechanism=1, fidelity=1, stiffness=k, damping=2 * 0.3 * math.sqrt(k * 0.00043))
        y = run(CamRockerModel(p), 0.4)
        r = run(CamRockerModel(CamRockerParams(mechanism=1)), 0.4)
        errs.append(np.max(np.abs(y[:, 1] - r[:, 1])))
    assert errs[0] > errs[1] > errs[2] and errs[2] < 0.1 * errs[0]


def test_clearance_level_shows_impacts_and_separations():
    p = CamRockerParams(mechanism=0, fidelity=2, law=0, clearance=20e-6)
    y = run(CamRockerModel(p), 0.4)
    contact = y[:, 6]
    assert y[-1, 7] >= 3                                   # several impacts
    assert np.any(contact == 0.0) and np.any(contact == 1.0)
    assert np.max(y[:, 5]) > 0.0


# the GTO-52 feeder's slotted rocker (systems/feeder_gto52.py) with its head load, crank at 150 rpm
FEEDER = dict(mechanism=0, fidelity=2, law=1, crank_radius=0.040, lambda1=3.5, lambda2=4.2, lambda3=3.0,
              dwell=math.radians(30.0), rocker_inertia=0.00043, clearance=10e-6, contact_stiffness=5e5,
              restitution=0.2, stiffness=5000.0)
W_FEEDER = 960.0 / 6.4 * 2 * math.pi / 60


def run_feeder(contact_law, h, t_end=0.45, exact=True, shrink=1.0):
    """(pin_force at every communication point, approach speeds at the onsets) of the feeder rocker;
    ``exact``: CamRockerModel.exact_contact, ``shrink``: factor on its RK4 sub-step."""
    m = CamRockerModel(CamRockerParams(contact_law=contact_law, **FEEDER))
    m.exact_contact = exact
    m.max_substep *= shrink

    def head(w):                                  # TorqueLoad T_coulomb 0.05 N.m, w_reg 0.05, d 0.002
        return -(0.05 * math.tanh(w / 0.05) + 0.002 * w)
    x = m.initial_state([0.0, W_FEEDER, 0.0])
    force, onsets = [], []
    for k in range(int(round(t_end / h))):
        count = x[3]
        x = m.advance(k * h, h, x, [W_FEEDER * k * h, W_FEEDER, head(x[1])])
        if x[3] > count:
            onsets.append(x[2])
        force.append(m.output((k + 1) * h, x, [W_FEEDER * (k + 1) * h, W_FEEDER, head(x[1])])[5])
    return np.array(force), np.array(onsets)


@pytest.mark.parametrize("contact_law", [1, 3])
def test_feeder_soft_take_up_is_integrated_alike_at_the_communication_step_and_a_fine_one(contact_law):
    """In the head dwell the stone pin creeps into contact (approach speed ~1e-9 m/s) and the joint then
    carries the head's friction.  With chi ~ 1/v0 the Hunt-Crossley family's damping rate exceeded RK4's
    stability limit at the sub-step sized on the contact stiffness: at h = 1e-4 s Flores rattled (10 onsets
    against 6, approach speeds up to 17 m/s, 2.1 kN, where h = 1e-5 s gives 15 mm/s and 3 N), Hunt-Crossley
    took a spurious ninth onset.  The communication step must not matter: same onsets, same approach
    speeds, same forces at the common instants as a run at a ten times finer step.  (The approach speeds
    also need a contact that begins inside a sub-step to use its own speed, not the memory of the previous
    contact, 0 before the first: the first onset then read 16.3 mm/s at 1e-4 s against 16.8 at 1e-5 s.)"""
    fc, vc = run_feeder(contact_law, 1e-4)
    ff, vf = run_feeder(contact_law, 1e-5)
    ff = ff[9::10]                                          # the fine run at the coarse run's instants
    assert len(vc) == len(vf) >= 5
    assert np.min(vc) < 1e-6                                # the soft take-up is there
    assert np.max(np.abs(vc - vf)) < 0.02 * np.max(vf)
    assert np.max(fc) == pytest.approx(np.max(ff), rel=0.02)
    assert np.max(np.abs(fc - ff)) < 0.05 * np.max(ff)


def two_clearance_energy(m, x, phi):
    """Kinetic energy of kulisa and stone plus the elastic energy of both joints (conservative contacts)."""
    p = m.p
    _, _, _, _, (d_p, _), (d_g, _) = m._joints(phi, 0.0, x[0], x[1], x[5], x[6], x)
    pen_p = max(abs(d_p) - p.clearance / 2, 0.0)
    pen_g = max(abs(d_g) - p.groove_clearance / 2, 0.0)
    return (0.5 * (p.rocker_inertia + p.stone_mass * x[5] ** 2) * x[1] ** 2 + 0.5 * p.stone_mass * x[6] ** 2
            + 0.5 * p.contact_stiffness * pen_p ** 2 + 0.5 * p.groove_stiffness * pen_g ** 2)


def rattle(m, phi, w0, rho_rate0, t_end=0.1, h=1e-4):
    """Crank held at phi, no load: (final state, energies at every step) after kicking kulisa and stone."""
    x = m.initial_state([phi, 0.0, 0.0])
    x[1], x[6] = w0, rho_rate0
    energies = [two_clearance_energy(m, x, phi)]
    for k in range(int(round(t_end / h))):
        x = m.advance(k * h, h, x, [phi, 0.0, 0.0])
        energies.append(two_clearance_energy(m, x, phi))
    return x, np.array(energies)


def test_two_clearances_free_stone_keeps_momentum_and_energy():
    """Both plays wide open: the stone slides freely along the turning slot.  (J + m rho^2) omega and the
    kinetic energy are invariants of the free motion (the Coriolis term keeps the first, the centripetal one
    the second)."""
    p = CamRockerParams(**{**FEEDER, "fidelity": 3, "clearance": 1.0, "groove_clearance": 1.0})
    m = CamRockerModel(p)
    x0 = m.initial_state([2.0, 0.0, 0.0])
    x, energies = rattle(m, 2.0, 5.0, 0.1, t_end=0.05)
    momentum = [(p.rocker_inertia + p.stone_mass * y[5] ** 2) * y[1] for y in (x0, x)]
    assert x[5] - x0[5] > 0.005 and x[3] == x[8] == 0.0       # the stone moved out; no contact
    assert abs(momentum[1] - (p.rocker_inertia + p.stone_mass * x0[5] ** 2) * 5.0) < 1e-9 * momentum[1]
    assert np.max(np.abs(energies - energies[0])) < 1e-9 * energies[0]


def test_two_clearances_conserve_energy_with_elastic_contacts():
    """Crank held, no load, e = 1 (Kelvin-Voigt without damping), a rigid conrod: the kulisa and the stone
    rattle between the eye and both groove walls; kinetic plus elastic energy stays put to the integration
    error at the contact onsets (RK4 across the kink of the contact force), which halves at least with the
    sub-step."""
    p = CamRockerParams(**{**FEEDER, "fidelity": 3, "restitution": 1.0, "stiffness": 1e12, "clearance": 20e-6,
                           "groove_clearance": 20e-6})
    drift = []
    for shrink in (1.0, 0.5):
        m = CamRockerModel(p)
        m.max_substep *= shrink
        x, energies = rattle(m, 2.0, 0.02, 0.01)
        assert x[3] >= 10 and x[8] >= 10                      # both joints struck repeatedly
        drift.append(np.max(np.abs(energies - energies[0])) / energies[0])
    assert drift[0] < 1e-3 and drift[1] < 0.5 * drift[0]


def test_two_clearances_follow_the_groove_and_the_single_play():
    """The running feeder at level 3 (stone pin and roller-groove plays of 10 um, 10 g stone) against level 2:
    the kulisa angle agrees within 1e-3 rad (the plays and compliances are microns at a 0.1 m lever), the
    stone stays on the groove within 0.5 mm, and the roller strikes the groove walls."""
    m2 = CamRockerModel(CamRockerParams(**FEEDER))
    m3 = CamRockerModel(CamRockerParams(**{**FEEDER, "fidelity": 3}))
    y2, y3 = run(m2, 0.3, h=1e-4), run(m3, 0.3, h=1e-4)
    assert np.max(np.abs(y2[:, 1] - y3[:, 1])) < 1e-3
    assert np.max(np.abs(y2[:, 4] - y3[:, 4])) < 5e-4
    assert y3[-1, 10] >= 2 and np.any(y3[:, 9] == 0.0)   # groove impacts and separations
    assert np.all(y2[:, 8:] == 0.0)


def test_kelvin_voigt_free_impact_returns_the_restitution():
    """Crank at rest (G, R fixed), no load: the rocker flies into the play at 0.2 rad/s and rebounds.  The
    Kelvin-Voigt law is calibrated so that a free impact returns e (fmus.physics.contact); the exponential steps
    integrate the linear contact exactly between located events, so the rebound speed is e times the approach
    to 1e-6, the contact counted once, the separation found."""
    for e in (0.2, 0.6, 1.0):
        m = CamRockerModel(CamRockerParams(**{**FEEDER, "restitution": e, "stiffness": 1e9}))
        x = m.initial_state([2.0, 0.0, 0.0])
        x[1] = -0.2                                      # rad/s, away from G: q = R (G - gamma) grows
        touched = False
        for k in range(100):                             # until the first separation
            x = m.advance(k * 1e-4, 1e-4, x, [2.0, 0.0, 0.0])
            touched = touched or x[4] == 1.0
            if touched and x[4] == 0.0:
                break
        assert x[3] == 1.0 and x[4] == 0.0, e
        assert x[1] == pytest.approx(0.2 * e, rel=1e-6), e


def test_kelvin_voigt_exponential_steps_are_closer_to_a_fine_reference_than_rk4():
    """The feeder's soft take-ups with the Kelvin-Voigt law at the default step 1e-4 s: the exponential steps
    between located events (the default) against the former RK4 sub-steps (exact_contact = False), both against
    RK4 at 20 times finer sub-steps.  Measured: pin force within 6e-4 of its peak (RK4: 1.2e-2), onset speeds
    within 1e-3 (RK4: 2e-2), the same onsets."""
    f_exp, v_exp = run_feeder(0, 1e-4)
    f_rk4, v_rk4 = run_feeder(0, 1e-4, exact=False)
    f_ref, v_ref = run_feeder(0, 1e-4, exact=False, shrink=0.05)
    scale = np.max(f_ref)
    assert len(v_exp) == len(v_ref) == len(v_rk4) >= 4
    assert np.max(np.abs(f_exp - f_ref)) < 2e-3 * scale
    assert np.max(np.abs(f_exp - f_ref)) < 0.2 * np.max(np.abs(f_rk4 - f_ref))
    assert np.max(np.abs(v_exp - v_ref)) < 3e-3 * np.max(v_ref)


@pytest.mark.parametrize("mechanism", [0, 1])
def test_kelvin_voigt_jet_is_the_derivative_of_the_acceleration(mechanism):
    """The closed-form rates of the Kelvin-Voigt step (_kv_jet: d/dgamma, d/domega, d/dt of the rocker's
    acceleration on a wall, with G'' and the stone radius' rate) against central differences of the
    acceleration itself, over a crank turn on both walls: within 1e-5 except at the law's joins (where G''
    jumps and a central difference straddles two phases)."""
    kw = dict(FEEDER, contact_law=0) if mechanism == 0 else dict(mechanism=1, fidelity=2, contact_law=0)
    m = CamRockerModel(CamRockerParams(**kw))
    w, tau = W_FEEDER, 0.03
    checked = 0
    for phi in np.linspace(0.01, 2 * math.pi - 0.01, 401):
        co = m._kv_coefficients(phi, w)
        for mode in (1.0, -1.0):
            gamma, omega = co[0] - 1e-4 * mode, 0.9 * co[1]
            a0, a_q, a_v, a_t = m._kv_jet(gamma, omega, tau, co, mode)

            def acc(dt, dq=0.0, dv=0.0):
                return m._kv_acceleration(gamma + dq, omega + dv, tau, m._kv_coefficients(phi + w * dt, w), mode)
            assert a0 == acc(0.0)
            numeric = ((acc(1e-7) - acc(-1e-7)) / 2e-7, (acc(0.0, 1e-7) - acc(0.0, -1e-7)) / 2e-7,
                       (acc(0.0, 0.0, 1e-4) - acc(0.0, 0.0, -1e-4)) / 2e-4)
            scale = abs(a_q) * 1e-3
            if abs(a_t - numeric[0]) > 1e-5 * max(abs(numeric[0]), scale):
                # a join of the law: the one-sided differences agree with the jet on one side
                right = (acc(2e-7) - acc(0.0)) / 2e-7
                left = (acc(0.0) - acc(-2e-7)) / 2e-7
                assert min(abs(a_t - right), abs(a_t - left)) < 1e-3 * max(abs(a_t), scale), phi
                continue
            assert a_q == pytest.approx(numeric[1], rel=1e-5)
            assert a_v == pytest.approx(numeric[2], rel=1e-5)
            checked += 1
    assert checked > 700


def test_kelvin_voigt_steps_with_the_jet_match_those_by_differences(monkeypatch):
    """The exponential steps with the closed-form rates (the default) against the former differences
    (_kv_jet returning None) on the feeder's take-ups: the same onsets, pin force within 1e-6 of its peak and
    onset speeds within 1e-6 relative (the differences' own truncation and rounding)."""
    f_jet, v_jet = run_feeder(0, 2e-4)
    monkeypatch.setattr(CamRockerModel, "_kv_jet", lambda *args: None)
    f_dif, v_dif = run_feeder(0, 2e-4)
    assert len(v_jet) == len(v_dif) >= 4
    assert np.max(np.abs(f_jet - f_dif)) < 1e-6 * np.max(f_dif)
    assert np.max(np.abs(v_jet - v_dif)) < 1e-6 * np.max(v_dif)


def test_a_contact_change_located_at_a_sub_steps_very_end_ends_that_sub_step():
    """Recorded in the full bed model at 8 ms under the jacobian master (a halved step of 1 ms at 0.536 s): the
    bisection located a change of contact mode at the very end of an exponential sub-step, and the loop tried
    the rest of that sub-step, of zero length, again (ZeroDivisionError in the step's 2 / dt^2)."""
    p = CamRockerParams(mechanism=1, fidelity=2, law=8, law_return=9, law_km=0.24617589310910504, lambda2=4.03,
                        swing=0.6981317007977318, phase_forward=3.7853767407351455,
                        phase_return=2.4978085664444403, phi_start=1.6217653617394077,
                        cam_base_radius=0.12268945277524954, follower_arm=0.14885991460543516,
                        cam_distance=0.210526, rocker_inertia=0.05, stiffness=2537170.95845,
                        damping=101.48683833799998, clearance=1e-05, contact_stiffness=1e8, restitution=0.2)
    m = CamRockerModel(p)
    x0 = np.array([0.6898989840173047, 0.46758566057467094, 0.13254057460368482, 7.0, 1.0, 0, 0, 0, 0, 0])
    u = [5.094339883749697, 6.30065558158122, -1488.859417135856]
    x = m.advance(0.536, 0.001, x0.copy(), u)
    assert np.isfinite(x).all()
    assert x[3] >= x0[3]                                    # impacts only counted up
    ref = m.advance(0.536, 0.0005, x0.copy(), u)              # the same interval in two halves: the same motion
    ref = m.advance(0.5365, 0.0005, ref, [u[0] + u[1] * 0.0005, u[1], u[2]])
    assert abs(x[0] - ref[0]) < 1e-3 * abs(x0[0] - ref[0]) + 1e-9, (x[0], ref[0])


def test_built_fmu_matches_the_model(fmu_dir):
    path = fmu_dir / "CamRocker.fmu"
    md = read_model_description(str(path))
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)), modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="cr")
    s.instantiate()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s.setupExperiment(startTime=0.0)
    s.setInteger([vr["mechanism"]], [1])
    s.enterInitializationMode()
    s.exitInitializationMode()
    m = CamRockerModel(CamRockerParams(mechanism=1))
    for k in range(20):
        phi = 0.05 * k
        s.setReal([vr["crank.phi"], vr["crank.w"], vr["rocker.tau"]], [phi, W, -1.0])
        got = s.getReal([vr["rocker.phi"], vr["rocker.w"], vr["crank.tau"], vr["pressure_angle"]])
        ref = m.output(0, None, [phi, W, -1.0])
        assert got == pytest.approx([ref[1], ref[2], ref[0], ref[3]], abs=1e-12)
        s.doStep(k * 1e-3, 1e-3)
    s.terminate()
    s.freeInstance()


# -- output_jacobian in closed form (issue 29) ---------------------------------------------------------------
from fmus.physics import base as _base   # noqa: E402
from fmus.physics import contact as _contact   # noqa: E402
from fmus.physics import groove as _groove   # noqa: E402

# (mechanism, law, law_return, law_km, lambda2): every law the component takes on both mechanisms; P6 and the
# seed-004 carrier laws (bed004 rise with its bed004r return) need a longer conrod for the slotted rocker's groove
JACOBIAN_CASES = ([(0, law, -1, 0.4, 4.03) for law in (0, 1, 2, 3, 4, 5, 7)] + [(0, 6, -1, 0.4, 4.5), (0, 8, 9, 0.2, 4.5)]
                  + [(1, law, -1, 0.4, 4.03) for law in range(8)] + [(1, 8, 9, 0.2, 4.03)])
JACOBIAN_IDS = [f"mech{c[0]}-law{c[1]}" for c in JACOBIAN_CASES]


def _model(case, **kw):
    mech, law, ret, km, l2 = case
    return CamRockerModel(CamRockerParams(mechanism=mech, law=law, law_return=ret, law_km=km, lambda2=l2, **kw))


def _junctions(m):
    """Crank angles where the rigid law changes segment (its G'' or G''' jumps): the dwell cycle's phase ends and
    each law's segment ends within its phase."""
    cyc = m.kulisa.cycle if m.p.mechanism == 0 else m.cycle

    def ends(law):
        return [e for e, _ in law.pieces] + [v for n, u in law.params if n == "runup" for v in (u, 1.0 - u)]
    out = [0.0, cyc._t1, cyc._t2, cyc._t3]
    out += [e * cyc.phase_forward for e in ends(cyc.forward)]
    out += [cyc._t2 + e * cyc.phase_return for e in ends(cyc.ret)]
    return [cyc.phi_start + v + s * 2 * math.pi for v in out for s in (-1, 0, 1)]


def _reference_jacobian(m, x, u):
    """output_jacobian_by_differences at 16, 8 and 4 times its step, Richardson-combined (truncation O(h^6)): the
    larger steps keep the differences' rounding (the law's polynomials near k = 1 give G to a few ulps only, which
    the contact stiffness turns into pin-force noise) below 1e-7 of the slopes, the combination their truncation
    (the pressure angle curves fast near the stone's turning points), so the comparison measures the closed form."""
    step = _base.DIFFERENCE_STEP
    d = []
    try:
        for f in (16.0, 8.0, 4.0):
            _base.DIFFERENCE_STEP = f * step
            d.append(_base.Model.output_jacobian_by_differences(m, 0.0, x, u))
    finally:
        _base.DIFFERENCE_STEP = step
    r1, r2 = (4.0 * d[1] - d[0]) / 3.0, (4.0 * d[2] - d[1]) / 3.0
    return (16.0 * r2 - r1) / 15.0


def _tolerance(m, x, u, ref):
    """1e-6 of each column's largest entry, and not below the reference's own rounding: the outputs hold the plays
    as differences of lengths ~1e3 times larger (|B - A| - L, (B - B_g).n_g, R (G - gamma)), so they are known to
    ~1e-13 of their size, which the differences divide by their step (a small slope of a large force)."""
    y = np.abs(np.asarray(m.output(0.0, x, u), dtype=float))
    steps = _base.DIFFERENCE_STEP * np.maximum(1.0, np.abs(np.asarray(u, dtype=float)))
    return np.maximum(1e-6 * np.max(np.abs(ref), axis=0)[None, :], 1e-13 * y[:, None] / steps[None, :])


def _checked_phases(m, points, contact_law):
    """output_jacobian against the Richardson-combined differences at each of ``points`` ((x, u, phase)), every
    entry within its tolerance; yields each point's phase for the caller's count."""
    for x, u, phase in points:
        got = m.output_jacobian(0.0, x, u)
        ref = _reference_jacobian(m, x, u)
        bad = np.abs(got - ref) > _tolerance(m, x, u, ref)
        assert not bad.any(), (contact_law, phase, u, np.argwhere(bad), got[bad], ref[bad])
        yield phase


def _steady(state_of, m, phi, w, x):
    """``state_of(m, phi, w, x)`` (a contact phase), or None where it changes within the differences' step (40
    times Model's, in the crank angle or speed, either way): the comparison would straddle a kink there."""
    state = state_of(m, phi, w, x)
    step = 40 * _base.DIFFERENCE_STEP
    near = [state_of(m, phi + s * step * max(1.0, phi), w, x) for s in (-1, 1)]
    near += [state_of(m, phi, w + s * step * w, x) for s in (-1, 1)]
    return None if any(n != state for n in near) else state


def _pin_state(m, phi, w, x):
    """(side of the stone-pin play, pin force == 0, energy speed above the approach speed) at one input: the
    contact phase the outputs are in, and which speed sets the Hunt-Crossley family's chi (a kink between)."""
    g, g1, R = m._kin(phi)
    q, qd, k, m_eff = m._pin(g, g1, R, w, x)
    pen, _, side = _contact.penetration(q, qd, m.p.clearance)
    v0 = x[2] if x[4] else abs(qd)
    energy = side != 0.0 and _contact.energy_speed(pen, k, m_eff, m.p.contact_exponent) > v0
    return side, m.output(0.0, x, [phi, w, 0.0])[5] == 0.0, energy


def _jacobian_points(m, rng, n_phi=24):
    """(x, u, phase) at crank angles away (>= 2e-3 rad) from the law's junctions; at fidelity 2 each angle in the
    three phases of the play (separated, on the positive wall, on the negative wall, penetration 1-5 clearances),
    the rate of the play random (some receding contacts clipped to zero force), contact flag 1 with a stored
    onset speed or 0 (an onset inside the sub-step: the speed is |qdot|).  Angles where the rocker creeps
    (0 < |G'| < 1e-2 of its largest, near a polynomial law's ends) are left out: there G is a sum of terms ~100
    times larger, correct to a few ulps only, and the differences of the outputs that amplify it (the pin force,
    k R (G - gamma)) are rounding at the 1e-6 level of the small slopes.  Angles whose differences would cross a
    wall, the clipping or the switch of chi between the approach and the energy speed (the state differs at
    phi or w +- 40 difference steps, well beyond the reference's largest) are left out: there the outputs have a kink
    and no slope."""
    p = m.p
    junctions = _junctions(m)
    w, half = 15.7, 0.5 * p.clearance
    turn = np.linspace(0.0, 2 * math.pi, n_phi, endpoint=False) + 0.05
    g1_max = max(abs(m.kinematics(phi)[1]) for phi in np.linspace(0.0, 2 * math.pi, 720))
    for phi in turn:
        if min(abs(phi - j) for j in junctions) < 2e-3:
            continue
        u = [phi, w, -0.7]
        g, g1, _ = m.kinematics(phi)
        if 0.0 < abs(g1) < 1e-2 * g1_max:
            continue
        x = m.initial_state(u)
        if p.fidelity == 1:
            x[0], x[1] = g + 1e-3 * rng.normal(), g1 * w * (1.0 + 0.1 * rng.normal())
            yield x, u, "elastic"
            continue
        if p.fidelity == 0:
            yield x, u, "rigid"
            continue
        R = m.lever(phi, g)
        k, m_eff = m._pin_stiffness(R)
        c = _contact.kelvin_voigt_damping(k, m_eff, p.restitution)
        for phase in ("separated", "positive wall", "negative wall"):
            pen = p.clearance * rng.uniform(1.0, 5.0)
            q = {"separated": 0.6 * half * rng.uniform(-1, 1), "positive wall": half + pen,
                 "negative wall": -half - pen}[phase]
            qd = rng.uniform(-1.5, 1.5) * k * pen / c
            x = m.initial_state(u)
            x[0], x[1] = g - q / R, g1 * w - qd / R
            x[4] = float(rng.integers(0, 2))
            x[2] = abs(qd) * rng.uniform(0.5, 2.0) if x[4] else 0.0
            state = _steady(_pin_state, m, phi, w, x)
            if state is None:
                continue
            yield x, u, phase


def _refuse_differences(*args):
    raise AssertionError("output_jacobian took differences")


@pytest.mark.parametrize("fidelity", [0, 1, 2])
@pytest.mark.parametrize("case", JACOBIAN_CASES, ids=JACOBIAN_IDS)
def test_output_jacobian_is_the_derivative_of_the_outputs(monkeypatch, case, fidelity):
    """output_jacobian (closed form at fidelities 0-2) against the differences of output() (Richardson-combined
    output_jacobian_by_differences) for every law on both mechanisms, at crank angles over a turn away from the
    law's junctions; at fidelity 2 for each contact law in the three phases of the play (separated, on either
    wall, incl. clipped receding contacts, onset and stored approach speeds): every entry within 1e-6 of its
    column's largest, without taking differences (the model's output_jacobian_by_differences refuses; the
    reference calls Model's).  Fails on the previous code (differences; at their own step they differ by up to
    2e-4 from the slope of the pressure angle near the stone's turning points)."""
    rng = np.random.default_rng(29 + fidelity)
    phases = {}
    for contact_law in ((0, 1, 2, 3) if fidelity == 2 else (0,)):
        # a 1 mm play at fidelity 2: wide enough that the differences of a separated play stay inside it
        m = _model(case, fidelity=fidelity, contact_law=contact_law, clearance=1e-3 if fidelity == 2 else 1e-5)
        monkeypatch.setattr(m, "output_jacobian_by_differences", _refuse_differences)
        for phase in _checked_phases(m, _jacobian_points(m, rng), contact_law):
            phases[phase] = phases.get(phase, 0) + 1
    if fidelity == 2:
        assert all(phases.get(p, 0) >= 20 for p in ("separated", "positive wall", "negative wall")), phases
    else:
        assert sum(phases.values()) >= 18


@pytest.mark.parametrize("mechanism, fidelity", [(0, 0), (0, 1), (0, 2), (0, 3), (1, 0), (1, 1), (1, 2)])
def test_output_jacobian_takes_no_differences(monkeypatch, mechanism, fidelity):
    """Every fidelity gives D from its equations: output_jacobian never calls output_jacobian_by_differences
    (monkeypatched to raise).  Fails on the previous code (differences at every fidelity)."""
    m = _model((mechanism, 1, -1, 0.4, 4.03), fidelity=fidelity, contact_law=1)
    monkeypatch.setattr(m, "output_jacobian_by_differences", _refuse_differences)
    for phi in (0.3, 2.0, 4.1):
        u = [phi, 15.7, 0.2]
        x = m.initial_state(u)
        x[0] += 2e-4
        assert np.isfinite(m.output_jacobian(0.0, x, u)).all()


def _joints_state(m, phi, w, x):
    """Level 3: per joint (side of its play, force == 0, energy speed above the approach speed) at one input."""
    p = m.p
    gamma, rho = x[0], x[5]
    f_p, f_g, _, (ex, ey), (d_p, r_p), (d_g, r_g) = m._joints(phi, w, gamma, x[1], rho, x[6], x)
    nx, ny = m._frame(phi, w)[6:]
    j_t = p.rocker_inertia + p.stone_mass * rho * rho

    def reduced_mass(vx, vy):      # the stone's mobility along (vx, vy), as the module docstring states it
        eu, en = vx * math.cos(gamma) + vy * math.sin(gamma), -vx * math.sin(gamma) + vy * math.cos(gamma)
        return 1.0 / (eu * eu / p.stone_mass + en * en * rho * rho / j_t)
    k_p = 1.0 / (1.0 / p.contact_stiffness + rho * rho / p.stiffness)
    out = []
    for d, rate, play, k, m_eff, force, v, flag in (
            (d_p, r_p, p.clearance, k_p, reduced_mass(ex, ey), f_p, x[2], x[4]),
            (d_g, r_g, p.groove_clearance, p.groove_stiffness, reduced_mass(nx, ny), f_g, x[7], x[9])):
        pen, _, side = _contact.penetration(d, rate, play)
        v0 = v if flag else abs(rate)
        out.append((side, force == 0.0,
                    side != 0.0 and _contact.energy_speed(pen, k, m_eff, p.contact_exponent) > v0))
    return tuple(out)


def _two_clearance_points(m, rng, n_phi=24):
    """(x, u, (phase of the conrod eye, phase of the groove)) for level 3 at crank angles away from the law's
    junctions and the creeping ends: the stone's pose (gamma, rho_s) and rates moved off the rigid law by a few
    plays (1 mm each), contact flags 0 or 1 with stored approach speeds; points whose differences would cross a
    wall, the clipping or chi's switch between approach and energy speed of either joint (the joints' states at
    phi or w +- 40 difference steps) are left out."""
    junctions = _junctions(m)
    w = 15.7
    g1_max = max(abs(m.kinematics(phi)[1]) for phi in np.linspace(0.0, 2 * math.pi, 720))
    for phi in np.linspace(0.0, 2 * math.pi, n_phi, endpoint=False) + 0.05:
        g1 = m.kinematics(phi)[1]
        if min(abs(phi - j) for j in junctions) < 2e-3 or 0.0 < abs(g1) < 1e-2 * g1_max:
            continue
        u = [phi, w, -0.7]
        for _ in range(6):
            x = m.initial_state(u)
            x[0] += 2e-3 / x[5] * rng.normal()
            x[5] += 2e-3 * rng.normal()
            x[1] += 0.05 * abs(x[1]) * rng.normal()
            x[6] += 0.05 * abs(x[6]) * rng.normal()
            x[4], x[9] = float(rng.integers(0, 2)), float(rng.integers(0, 2))
            x[2], x[7] = rng.uniform(0.01, 1.0), rng.uniform(0.01, 1.0)
            state = _steady(_joints_state, m, phi, w, x)
            if state is None:
                continue
            names = {0.0: "separated", 1.0: "positive wall", -1.0: "negative wall"}
            yield x, u, (names[state[0][0]], names[state[1][0]])


@pytest.mark.parametrize("case", JACOBIAN_CASES[:9], ids=JACOBIAN_IDS[:9])
def test_two_clearance_output_jacobian_is_the_derivative_of_the_outputs(monkeypatch, case):
    """Level 3 (seed 000's two clearances, slotted rocker): output_jacobian in closed form against the
    Richardson-combined differences of output() for every law, each contact law, with the conrod eye and the
    roller each separated or on either wall: every entry within 1e-6 of its column's largest, without taking
    differences.  Fails on the previous code (differences)."""
    rng = np.random.default_rng(2900)
    phases = {}
    for contact_law in (0, 1, 2, 3):
        m = _model(case, fidelity=3, contact_law=contact_law, clearance=1e-3, groove_clearance=1e-3)
        monkeypatch.setattr(m, "output_jacobian_by_differences", _refuse_differences)
        for phase in _checked_phases(m, _two_clearance_points(m, rng), contact_law):
            for joint, ph in zip(("eye", "groove"), phase):
                phases[joint, ph] = phases.get((joint, ph), 0) + 1
    for joint in ("eye", "groove"):
        assert all(phases.get((joint, ph), 0) >= 10 for ph in ("separated", "positive wall", "negative wall")), phases


def test_stone_slopes_are_the_derivatives_of_the_stone_radius_rate_and_pressure_angle():
    """groove.stone_slopes_scalar (rho'', theta') against central differences of stone_scalar's rho' and theta
    along the kulisa law (C0 with a dwell, lambda2 4.2) over a turn, away from the law's junctions and from the
    points where theta is clipped or 0: within 1e-6 of the largest slope."""
    m = CamRockerModel(CamRockerParams(**FEEDER))
    p, junctions = m.p, _junctions(m)

    def stone(phi):
        g, g1, _ = m.kinematics(phi)
        return _groove.stone_scalar(phi, g, g1, p.lambda1, p.lambda2, m.branch)
    h = 1e-6
    got, ref = [], []
    for phi in np.linspace(0.0, 2 * math.pi, 720, endpoint=False):
        if min(abs(phi - j) for j in junctions) < 1e-3 or not 0.0 < stone(phi)[2] < 0.5 * math.pi - 1e-3:
            continue
        got.append(_groove.stone_slopes_scalar(phi, *m.kinematics(phi), p.lambda1, p.lambda2, m.branch))
        ref.append([(stone(phi + h)[i] - stone(phi - h)[i]) / (2 * h) for i in (1, 2)])
    got, ref = np.array(got), np.array(ref)
    assert len(got) > 300
    assert np.all(np.abs(got - ref) <= 1e-6 * np.max(np.abs(ref), axis=0))
