"""Power-bond energy diagnostics (harness.studies.energy).

Tier 1: held-value reconstruction against polynomials, and the coupling energy of an in-process Jacobi
zero-order-hold co-simulation of the physics models against the true energy drift of the coupled system
(computed from the states) and the energy argument's ratio.
Tier 2: the free-free two-inertia FMU drive with zero-order hold: the diagnostic reports energy created by
the coupling (> 0 and growing), like the true energy drift, and agrees with the master's own bond log.
"""
from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from fmus.physics.elements import InertiaModel, InertiaParams, SpringInertiaModel, SpringInertiaParams
from harness.studies import energy as en
from harness.studies.stability import TwoInertia

COLS = ["a.flange.phi", "a.flange.w", "b.drive.tau", "b.phi", "b.w"]


def jacobi_zoh(p: TwoInertia, h: float, n: int, x0) -> pd.DataFrame:
    """In-process Jacobi co-simulation with zero-order hold of the two physics models (test code)."""
    ip = p.instance_parameters()
    A = InertiaModel(InertiaParams(**ip["a"]))
    B = SpringInertiaModel(SpringInertiaParams(**ip["b"]))
    xa, xb = np.array(x0[:2], float), np.array(x0[2:], float)
    rows = []
    tau = B.output(0.0, xb, xa)[0]
    for k in range(n + 1):
        rows.append([xa[0], xa[1], tau, xb[0], xb[1]])
        if k == n:
            break
        t = k * h
        xa, xb = A.advance(t, h, xa, (tau,)), B.advance(t, h, xb, xa.copy())
        tau = B.output(t + h, xb, xa)[0]
    df = pd.DataFrame(rows, columns=COLS, index=pd.Index(np.arange(n + 1) * h, name="time"))
    df.attrs.update(master="jacobi", extrapolation=0)
    return df


def true_drift(p: TwoInertia, df: pd.DataFrame) -> np.ndarray:
    x = df[["a.flange.phi", "a.flange.w", "b.phi", "b.w"]].to_numpy()
    e = p.energy(x)
    return e - e[0]


# -- tier 1 ---------------------------------------------------------------------------------------------------
def test_held_values_follow_the_midpoint_polynomial():
    t = np.cumsum(np.r_[0.0, np.full(9, 0.1), np.full(6, 0.05)])   # a step change in H too
    quad = 3.0 - 2.0 * t + 5.0 * t ** 2
    lin = 1.0 + 4.0 * t
    mid = 0.5 * (t[1:] + t[:-1])
    for inc in (False, True):
        h2 = en.held_values(t, quad, 2, inc)
        np.testing.assert_allclose(h2[2 - int(inc):], (3.0 - 2.0 * mid + 5.0 * mid ** 2)[2 - int(inc):], rtol=1e-12)
        h1 = en.held_values(t, lin, 1, inc)
        np.testing.assert_allclose(h1[1 - int(inc):], (1.0 + 4.0 * mid)[1 - int(inc):], rtol=1e-12)
    np.testing.assert_array_equal(en.held_values(t, quad, 0, False), quad[:-1])
    np.testing.assert_array_equal(en.held_values(t, quad, 0, True), quad[1:])
    assert en.held_values(t, lin, 1, False)[0] == lin[0]   # one sample only: degree drops to 0


def test_zero_order_hold_jacobi_energy_matches_the_energy_argument():
    """Undamped free-free, relative mode (zero momentum): the true drift per step is c dphi1 (dphi1/2 -
    dphi2) > 0; the diagnostic (exact A side, trapezoidal B side) reports c H^2 w1 (w1 - w2)/2 +
    H^2 tau^2/(2 J1), on average (1 + J1/J2) / (1/2 + J1/J2) times the true drift."""
    p = TwoInertia(J1=0.01, J2=0.02, c=100.0)
    h = 1e-4
    df = jacobi_zoh(p, h, 4000, [0.0, 1.0, 0.0, -p.J1 / p.J2])
    drift = true_drift(p, df)
    ce = en.coupling_energy(df, ("a.flange", "b.drive"))
    assert drift[-1] > 0 and ce.iloc[-1] > 0
    k = np.linspace(0, len(df) - 1, 5).astype(int)
    assert np.all(np.diff(ce.to_numpy()[k]) > 0) and np.all(np.diff(drift[k]) > 0)
    ratio = (1 + p.J1 / p.J2) / (0.5 + p.J1 / p.J2)
    assert ce.iloc[-1] / drift[-1] == pytest.approx(ratio, rel=0.02)


def test_bond_power_sides_and_residual():
    p = TwoInertia()
    h = 2e-4
    df = jacobi_zoh(p, h, 500, [0.0, 1.0, 0.0, 0.0])
    bp = en.bond_power(df, "a.flange->b.drive")
    assert list(bp.columns) == ["P_out", "P_in", "residual"] and np.isnan(bp.iloc[0]).all()
    # P_out is exactly the energy the Inertia received: J1 dw1 w_mean per step = kinetic energy change
    dke = np.diff(0.5 * p.J1 * df["a.flange.w"].to_numpy() ** 2) / h
    np.testing.assert_allclose(bp["P_out"].to_numpy()[1:], dke, rtol=1e-9, atol=1e-12)
    # P_in: speed held by SpringInertia (w1 at t_k) times its mean torque
    tau = df["b.drive.tau"].to_numpy()
    np.testing.assert_allclose(bp["P_in"].to_numpy()[1:], df["a.flange.w"].to_numpy()[:-1] * 0.5 * (tau[1:] + tau[:-1]))
    np.testing.assert_allclose(bp["residual"], bp["P_out"] - bp["P_in"])
    res = en.ecco_residual(df, ("a.flange", "b.drive"))
    np.testing.assert_allclose(res.to_numpy()[1:], np.abs(bp["residual"].to_numpy()[1:]) * h)


def test_bad_input_is_named():
    df = jacobi_zoh(TwoInertia(), 1e-3, 10, [0.0, 1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="b.drive.tau"):
        en.bond_power(df.drop(columns=["b.drive.tau"]), ("a.flange", "b.drive"))
    with pytest.raises(ValueError, match="bond"):
        en.bond_power(df, 42)
    with pytest.raises(ValueError, match="master"):
        en.bond_power(df, ("a.flange", "b.drive"), master="newton")
    bare = df.copy()
    bare.attrs.clear()
    with pytest.raises(ValueError, match="master"):
        en.coupling_energy(bare, ("a.flange", "b.drive"))


# -- tier 2: the FMU drive ------------------------------------------------------------------------------------
def test_free_free_zero_order_hold_energy_growth_is_reported(fmu_dir):
    from harness import load, simulate
    from harness.model import Instance
    from harness.results import bond_energy

    base = load("two_inertia")
    system = type(base)(name=base.name, instances=[Instance(i.name, fmu_dir / f"{i.fmu}.fmu", dict(i.parameters))
                                                   for i in base.instances], bonds=base.bonds)
    p = TwoInertia.from_mapping({f"{i.name}.{k}": v for i in base.instances for k, v in i.parameters.items()
                                 if k in ("J", "c", "d", "c_ground", "d_ground")})
    assert p.c1 == p.c2 == p.d == 0.0   # free-free, undamped: only the coupling can change the energy
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # the divergence detector would stop this run at 0.70 s (that is its point); here the growth is measured
        from harness import RunOptions

        df = simulate(system, stop_time=1.0, step=1e-3, master="jacobi", extrapolation=0, outputs=COLS,
                      options=RunOptions(divergence=None))
    assert df.attrs["complete"]
    ce = en.coupling_energy(df, base.bonds[0])           # a harness.model.Bond
    drift = true_drift(p, df)
    k = np.linspace(0, len(df) - 1, 6).astype(int)
    e = ce.to_numpy()[k]
    assert e[-1] > 0 and np.all(np.diff(e) > 0), e
    assert drift[-1] > 0 and np.all(np.diff(drift[k]) > 0)
    assert 0.3 < ce.iloc[-1] / drift[-1] < 3.0            # same energy, up to the estimate of B's side
    # the master's own bookkeeping (harness.master, written independently) agrees with the reconstruction
    log = bond_energy(df)
    np.testing.assert_allclose(ce.to_numpy(), log["energy_error"].to_numpy(), rtol=1e-9, atol=1e-12)
