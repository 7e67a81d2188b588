"""ParallelShafts (seed 003, Fig. 3): the seed's eqs. (10) and (11) written out here independently, against the
component's equations, its exact step and its energy balance."""
from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import solve_ivp

from fmus.physics.parallel_shafts import ParallelShaftsModel, ParallelShaftsParams, eq10_frequencies

RIGID = 1e12          # kg.m2 at the drive end: the seed's "absolutely rigid" motor, phi0'' = 0


def _eq10_state_matrix(J_red, J1, c1, b1, c2, b2):
    """Eq. (10) with (10a) completed by the driven shaft (spec A2), in (dphi, dphi1) and their rates:
    J_red dphi'' + b1 dphi' + c1 dphi + b1 dphi2' + c1 dphi2 = M,  J1 dphi1'' + b2 dphi1' + c2 dphi1 - b1 dphi2'
    - c1 dphi2 = 0, dphi2 = dphi - dphi1."""
    M = np.diag([J_red, J1])
    K = np.array([[2 * c1, -c1], [-c1, c1 + c2]])
    D = np.array([[2 * b1, -b1], [-b1, b1 + b2]])
    Minv = np.linalg.inv(M)
    return np.block([[np.zeros((2, 2)), np.eye(2)], [-Minv @ K, -Minv @ D]])


def _sorted(ev):
    """Eigenvalues ordered by imaginary part (the conjugate pairs of underdamped modes)."""
    ev = np.asarray(ev)
    return ev[np.lexsort((ev.real, ev.imag))]


def _elastic_eigenvalues(model):
    """Eigenvalues of the component's state matrix other than the drive end's slow pair (|s| < 1)."""
    ev = np.linalg.eigvals(model.A)
    return _sorted(ev[np.abs(ev) > 1.0])


@pytest.mark.parametrize("seed", range(6))
def test_eq10_frequencies_are_the_eigenvalues_of_the_2x2_system(seed):
    rng = np.random.default_rng(seed)
    J_red, J1 = 10 ** rng.uniform(-4, -1), 10 ** rng.uniform(-2, 1)
    c1, c2 = 10 ** rng.uniform(3, 6), 10 ** rng.uniform(1, 6)
    M, K = np.diag([J_red, J1]), np.array([[2 * c1, -c1], [-c1, c1 + c2]])
    w2 = np.sort(scipy.linalg.eigvalsh(K, M))
    assert eq10_frequencies(J_red, J1, c1, c2) == pytest.approx(tuple(np.sqrt(w2)), rel=1e-9)


@pytest.mark.parametrize("d, l, J_red, psi, c2, b2", [(0.05, 0.6, 4e-3, 0.5, 500.0, 0.75),
                                                     (0.03, 0.3, 1e-3, 0.0, 2e4, 0.0),
                                                     (0.04, 0.5, 2e-2, 2.0, 50.0, 3.0)])
def test_fidelity_one_is_eq10_with_the_driven_shaft(d, l, J_red, psi, c2, b2):
    """With the drive end rigid, the component's elastic eigenvalues are those of eq. (10) (two shafts of
    c1 = G pi d^4/(32 l), b1 = psi sqrt(2 c1 J_red)/(4 pi) each, belt c2, b2)."""
    G, J1 = 8.1e10, 0.2
    p = ParallelShaftsParams(fidelity=1, J_drive=RIGID, J_flywheel=J1, J_red=J_red, G=G, d=d, l=l, psi=psi,
                             belt_stiffness=c2, belt_damping=b2)
    c1 = G * math.pi * d ** 4 / (32 * l)
    b1 = psi * math.sqrt(2 * c1 * J_red) / (4 * math.pi)
    expect = _sorted(np.linalg.eigvals(_eq10_state_matrix(J_red, J1, c1, b1, c2, b2)))
    got = _elastic_eigenvalues(ParallelShaftsModel(p))
    assert len(got) == 4 and np.allclose(got, expect, rtol=1e-6, atol=1e-6)
    if psi == 0.0 and b2 == 0.0:
        assert tuple(np.sort(np.abs(got.imag))[::2]) == pytest.approx(eq10_frequencies(J_red, J1, c1, c2), rel=1e-6)


def test_fidelity_zero_is_eq11_with_the_shafts_in_parallel():
    """phi2 = phi0: one mode, J_red s^2 + b_red s + C_red = 0 with C_red = G pi d^4/(16 l) (the seed's 16) and
    n = b_red/(2 J_red) = p psi/(4 pi)."""
    G, d, l, J_red, psi = 8.1e10, 0.05, 0.6, 4e-3, 0.5
    m = ParallelShaftsModel(ParallelShaftsParams(fidelity=0, J_drive=RIGID, J_red=J_red, G=G, d=d, l=l, psi=psi))
    C_red = G * math.pi * d ** 4 / (16 * l)
    p = math.sqrt(C_red / J_red)
    n = p * psi / (4 * math.pi)
    s = _elastic_eigenvalues(m)
    assert len(s) == 2
    wd = math.sqrt(p * p - n * n)
    assert np.allclose(s, [-n - 1j * wd, -n + 1j * wd], rtol=1e-9)
    # a knife turned by delta against a still drive: both shafts pull it back, C_red delta
    x = np.array([0.0, 0.0, -1e-4, 0.0, 0.0, 0.0])
    assert m.derivatives(0.0, x, (0.0, 0.0, 0.0), 0.0)[3] * J_red == pytest.approx(C_red * 1e-4, rel=1e-12)
    x1 = ParallelShaftsModel(ParallelShaftsParams(fidelity=1, J_red=J_red, G=G, d=d, l=l))
    assert x1.derivatives(0.0, x, (0.0, 0.0, 0.0), 0.0)[3] * J_red == pytest.approx(C_red * 1e-4, rel=1e-12)


@pytest.mark.parametrize("fidelity", [0, 1])
@pytest.mark.parametrize("h", [5e-5, 2e-3, 0.05])
def test_exact_step_matches_an_integration_of_the_equations(fidelity, h):
    m = ParallelShaftsModel(ParallelShaftsParams(fidelity=fidelity))
    rng = np.random.default_rng(3)
    x0 = m.initial_state((0.0, 0.0, 0.0)) + np.array([0.0, 0.0, 1e-4, 0.3, -2e-4, -0.1, 0.0]) * (fidelity == 1)
    u = tuple(rng.normal(size=3) * 10)
    sol = solve_ivp(lambda t, x: m.derivatives(t, x, u, 0.0), (0.0, h), x0, method="DOP853", rtol=1e-12, atol=1e-13)
    got = m.advance(0.0, h, x0, u)
    assert np.allclose(got, sol.y[:, -1], rtol=1e-8, atol=1e-10)
    assert np.array_equal(m.advance(0.0, 0.0, x0, u), x0)


@pytest.mark.parametrize("fidelity", [0, 1])
def test_energy_balance_closes(fidelity):
    """Work of the held torques = change of kinetic + elastic energy + the dissipated energy (the output
    ``dissipation`` integrated by the trapezoidal rule on steps of 1/30 of the knife mode's period: its error
    ~ (2 omega h)^2/12 = 3.5e-4)."""
    m = ParallelShaftsModel(ParallelShaftsParams(fidelity=fidelity))
    h, n = 5e-6, 10000
    x = m.initial_state((0.0, 0.0, 0.0))
    work = dissipated = 0.0
    out = m.output(0.0, x, (0.0, 0.0, 0.0))
    e0 = out[10] + out[11]
    for k in range(n):
        u = (5.0, -5.0 - 5.0 * math.sin(60.0 * k * h), 0.0)
        xn = m.advance(k * h, h, x, u)
        work += u[0] * (xn[0] - x[0]) + u[1] * (xn[2] - x[2])
        nxt = m.output((k + 1) * h, xn, u)
        dissipated += 0.5 * h * (out[12] + nxt[12])
        x, out = xn, nxt
    assert dissipated > 0.0
    assert work - (out[10] + out[11] - e0) == pytest.approx(dissipated, rel=5e-4)


def test_fmu_runs_like_the_model(fmu_dir):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    path = fmu_dir / "ParallelShafts.fmu"
    md = read_model_description(str(path))
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)), modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="shaft")
    v = {x.name: x.valueReference for x in md.modelVariables}
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    m = ParallelShaftsModel(ParallelShaftsParams())
    x, h = m.initial_state((0.0, 0.0, 0.0)), 1e-4
    names = ["crank.w", "shaft_twist", "driven_twist", "belt_twist"]
    for k in range(50):
        u = (5.0, -5.0 - 5.0 * math.sin(60.0 * k * h), 0.0)
        s.setReal([v["pulley.tau"], v["crank.tau"]], list(u[:2]))
        s.doStep(k * h, h)
        x = m.advance(k * h, h, x, u)
    got = s.getReal([v[n] for n in names])
    out = dict(zip(m.outputs, m.output(50 * h, x, u)))
    assert got == pytest.approx([out[n] for n in names], rel=1e-12, abs=1e-15)
    assert abs(out["belt_twist"]) > 0.0
    s.terminate()
    s.freeInstance()


def test_spine_knife_shaft_energy_balance_closes(fmu_dir):
    """In the shipped knife drive (co-simulated on the built FMUs): the work through the shaft's two bonds (exact
    for held torques) = its energy change + the dissipated energy (output ``dissipation``, trapezoidal rule on
    the communication points, 19 per period of the knife mode) to 1 % of the dissipated energy."""
    import warnings

    from harness import load, simulate
    from harness.model import SystemWarning
    from harness.studies.energy import bond_power

    s = load("spine_knife")
    s = s.on_fmus(fmu_dir)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SystemWarning)      # the unconnected aux take-off
        df = simulate(s, stop_time=0.25, on_error="raise")
    assert df.attrs["complete"]
    df.attrs.setdefault("master", "jacobi")
    H = np.diff(df.index.to_numpy(dtype=float))
    bonds = [("shaft.pulley", "motor.pulley"), ("shaft.crank", "linkage.crank")]
    powers = [bond_power(df, b)["P_out"].to_numpy()[1:] for b in bonds]
    work = sum(np.nansum(P * H) for P in powers)
    gross = sum(np.nansum(np.abs(P) * H) for P in powers)
    energy = (df["shaft.kinetic_energy"] + df["shaft.potential_energy"]).to_numpy()
    loss = df["shaft.dissipation"].to_numpy()
    dissipated = np.sum(0.5 * (loss[1:] + loss[:-1]) * H)
    assert dissipated > 0.0 and np.max(np.abs(df["shaft.belt_twist"])) > 0.0
    # measured: the residual is 1e-3 of the dissipated energy, which is 5e-7 of the work through the bonds
    assert abs(work - (energy[-1] - energy[0]) - dissipated) < 1e-2 * dissipated, (work, energy[-1] - energy[0],
                                                                                dissipated, gross)
