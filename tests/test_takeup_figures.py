"""Seed 000's figures from the model (issue 31): Fig. 2, the roller centre's velocity during the take-up, and
Fig. 3, where the roller lifts off its groove wall for the laws K0 and C0 (the rolling condition).  Each
chart's numbers are checked on a case whose answer is known without the code under test."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from fmus.physics import groove
from fmus.physics import liftoff as L
from fmus.physics import takeup as T

LAM1, LAM2, LAM3, R = 3.5, 4.2, 3.0, 0.040


def _periodic_d(y, h):
    return (np.roll(y, -1) - np.roll(y, 1)) / (2 * h)


def _base_fourbar(n=7200):
    """The base four-bar's own kulisa law on a fine grid: its groove is the circle rho = lambda3."""
    phi = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    g = np.unwrap(groove.base_fourbar_angle(phi, LAM1, LAM2, LAM3))
    h = phi[1] - phi[0]
    g1 = _periodic_d(g, h)
    g2 = (np.roll(g, -1) - 2 * g + np.roll(g, 1)) / h ** 2
    prof = groove.synthesize(phi, g, g1, g2, LAM1, LAM2, groove.base_branch(LAM1, LAM2, LAM3))
    return phi, g, g1, g2, prof


def _crossings(y):
    """Indices i where the periodic samples y change sign between i and i + 1."""
    return set(np.nonzero(y * np.roll(y, -1) < 0.0)[0].tolist())


def test_fig3_circular_groove_lifts_off_at_the_rockers_inflections_and_a_right_transmission_angle():
    """Known answer: the base four-bar's groove is a circle about O2, so its wall normal is the slot; with a
    massless stone the conrod's pull along the slot is all the wall carries, N = -F_c cos(conrod, slot), and
    the conrod's moment F_c rho sin(conrod, slot) drives the kulisa, J gamma''.  So N = 0 exactly where the
    rocker's acceleration changes sign (its inflections) or the conrod stands square to the slot -- and
    nowhere else: not at the dead centres, where the stone reverses along the arc (the old travel-based
    normal flipped there)."""
    phi, g, g1, g2, prof = _base_fourbar()
    assert np.allclose(prof.rho, LAM3, atol=1e-9)
    w = L.wall_forces(prof, g1, g2, R, 15.0, 0.00043, 0.0)
    A = np.stack([-LAM1 + np.cos(phi), np.sin(phi)], axis=-1)
    Bn = LAM3 * np.stack([np.cos(g), np.sin(g)], axis=-1)
    along = np.sum((A - Bn) * np.stack([np.cos(g), np.sin(g)], axis=-1), axis=1)    # conrod . slot
    expected = _crossings(g2) | _crossings(along)
    found = {int(i) for i, _ in w.lift_off}

    def near(a, b):
        return min(abs(a - b), len(phi) - abs(a - b)) <= 1
    assert len(expected) >= 2 and len(found) == len(expected)
    assert all(any(near(f, e) for f in found) for e in expected)
    # the kulisa's moment balance alone fixes the conrod force: F_c (e_c . n) rho = J gamma'' (to the
    # difference-quotient law's own inconsistency, which tilts the circle's normal near the dead centres)
    e_c = (A - Bn) / LAM2
    n = np.stack([-np.sin(g), np.cos(g)], axis=-1)
    moment = 0.00043 * g2 * 15.0 ** 2
    np.testing.assert_allclose(w.F_conrod * np.sum(e_c * n, axis=1) * R * LAM3, moment,
                               atol=1e-3 * np.max(np.abs(moment)))


@pytest.mark.parametrize("law", ["K0", "C0"])
def test_fig3_wall_forces_balance_the_stone_and_the_kulisas_energy(law):
    """The forces of the chart against motion computed without them: the roller centre's acceleration from
    second differences of its path B(t), and the power balance -- the rolling roller's wall force does no
    work (it is normal to the groove), so the conrod alone feeds the kinetic energy of kulisa and stone."""
    case = L.LiftOffCase(law=law, n=14400)
    w = L.lift_off(case)
    om, h = case.omega, w.phi[1] - w.phi[0]
    dt = h / om
    B = w.B
    v = (np.roll(B, -1, axis=0) - np.roll(B, 1, axis=0)) / (2 * dt)
    acc = (np.roll(B, -1, axis=0) - 2 * B + np.roll(B, 1, axis=0)) / dt ** 2
    u = np.stack([np.cos(w.gamma), np.sin(w.gamma)], axis=-1)
    A = case.r * np.stack([-case.lam1 + np.cos(w.phi), np.sin(w.phi)], axis=-1)
    e_c = (A - B) / np.linalg.norm(A - B, axis=1)[:, None]
    gw = _periodic_d(np.unwrap(w.gamma), h) * om
    kinetic = 0.5 * case.J * gw ** 2 + 0.5 * case.m_stone * np.sum(v * v, axis=1)
    power = w.F_conrod * np.sum(e_c * v, axis=1)
    smooth = np.isfinite(w.N) & (np.abs(np.roll(w.N, 1) - w.N) < 0.02) & (np.abs(np.roll(w.N, -1) - w.N) < 0.02)
    smooth &= np.roll(smooth, 1) & np.roll(smooth, -1)          # away from the laws' acceleration jumps
    scale = np.max(np.abs(power[smooth]))
    np.testing.assert_allclose(power[smooth], _periodic_d(kinetic, dt)[smooth], atol=2e-3 * scale)
    # the stone along the slot: conrod and wall forces against its absolute acceleration (the slot's reaction
    # is normal to it)
    lhs = w.F_conrod * np.sum(e_c * u, axis=1) + w.N * np.sum(w.n_wall * u, axis=1)
    rhs = case.m_stone * np.sum(acc * u, axis=1)
    np.testing.assert_allclose(lhs[smooth], rhs[smooth], atol=2e-3 * np.max(np.abs(rhs[smooth])))
    # and the wall force is normal to the groove
    assert np.nanmax(np.abs(np.sum(w.n_wall * v, axis=1) / np.linalg.norm(v, axis=1))[smooth]) < 1e-3


def test_fig3_chart_rows_are_the_zero_crossings_and_lift_offs_happen_between_the_extremes(tmp_path):
    """The chart's table: one row per lift-off, the same crank angles and stone radii (to 0.1 deg, 0.1 mm)
    on a grid four times finer; both laws show lift-offs between the rocker's extreme positions (the seed:
    "not only at the extreme positions of the rocker but also after its lift-off ... at various positions of
    the stone depending on the law"), at different stone radii for K0 and C0; the figure is written."""
    from harness.studies import takeup as S

    df, runs = S.liftoff_map(loads=((150.0, 0.0),))
    for (law, _, _), (case, w) in runs.items():
        rows = df[df["law"] == law].sort_values("phi_deg")
        assert len(rows) == len(w.lift_off) > 0
        fine = L.LiftOffCase(law=law, n=4 * case.n)
        ref = pd.DataFrame(S.liftoff_rows(L.lift_off(fine), fine)).sort_values("phi_deg")
        np.testing.assert_allclose(rows["phi_deg"], ref["phi_deg"], atol=0.1)
        np.testing.assert_allclose(rows["rho_mm"], ref["rho_mm"], atol=0.1)
    mid = df[df["position"] == "intermediate"]
    assert set(mid["law"]) == {"K0", "C0"}
    assert set(np.round(mid[mid["law"] == "K0"]["rho_mm"], 1)).isdisjoint(np.round(mid[mid["law"] == "C0"]["rho_mm"], 1))
    files = S.plot_liftoff(tmp_path, runs)
    assert all(f.is_file() and f.stat().st_size > 1000 for f in files)


def test_fig3_without_load_the_lift_offs_do_not_depend_on_the_crank_speed():
    """Every force is an inertia force, omega^2 times a function of the crank angle."""
    a = L.lift_off(L.LiftOffCase(law="K0", rpm=100.0))
    b = L.lift_off(L.LiftOffCase(law="K0", rpm=200.0))
    np.testing.assert_array_equal(a.lift_off, b.lift_off)
    np.testing.assert_allclose(b.N, 4.0 * a.N, rtol=1e-9, atol=1e-12)


def test_fig3_refuses_a_law_without_a_groove_and_unphysical_values_in_one_line():
    with pytest.raises(ValueError, match="lambda2 = 3.6 has no groove"):
        L.lift_off(L.LiftOffCase(law="K0", lam2=3.6))
    for kw, msg in (({"rpm": 0.0}, r"LiftOffCase.rpm = 0.0 outside \(0, inf\)"),
                    ({"m_stone": -0.01}, r"LiftOffCase.m_stone = -0.01 outside \[0, inf\)"),
                    ({"J": 0.0, "m_stone": 0.0}, "moves nothing"), ({"law": "Sh"}, "law")):
        with pytest.raises(ValueError, match=msg) as e:
            L.lift_off(L.LiftOffCase(**kw))
        assert "\n" not in str(e.value)


def test_study_figures_option_writes_figs_2_and_3_without_the_map(tmp_path):
    p = subprocess.run([sys.executable, "-m", "harness", "study", "takeup", "--figures", "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    names = {f.name for f in tmp_path.iterdir()}
    assert {"takeup_velocity.png", "takeup_liftoff.png", "takeup_liftoff.csv"} <= names
    assert "takeup.csv" not in names
    assert "lift-off" in p.stdout


@pytest.mark.parametrize("law", ["K0", "C0"])
def test_fig2_kinematic_row_is_the_roller_paths_velocity_and_zero_across_the_slot_at_the_extremes(law):
    """Fig. 2's top row against motion computed without its formulas: along the slot d rho/dt and across it
    rho d gamma/dt from central differences of the roller's path over time; at every marked extreme the
    rocker's velocity is zero (the seed: "its angular (kinematic) velocity is zero"), while the stone can still
    run along the slot (V3 of eq. 10)."""
    from harness.studies import takeup as S

    case = L.LiftOffCase(law=law, n=14400)
    w = L.lift_off(case)
    dt = (w.phi[1] - w.phi[0]) / case.omega
    slot = _periodic_d(w.rho, dt)
    across = w.rho * _periodic_d(np.unwrap(w.gamma), dt)
    ok = np.isfinite(slot)
    scale = np.max(np.abs(across))
    # (5e-4: the central difference at the laws' acceleration jumps, e.g. K0's at the folded dead centre)
    np.testing.assert_allclose(w.v_slot[ok], slot[ok], atol=5e-4 * scale)
    np.testing.assert_allclose(w.v_rocker, across, atol=5e-4 * scale)
    ext = S.rocker_extremes(w)
    assert len(ext) == 3                        # the folded dead centre and both ends of the dwell
    assert np.all(np.abs(w.v_rocker[ext]) < 2e-3 * scale)
    assert np.max(np.abs(w.v_slot[ext])) > 0.2  # the stone runs along the slot at the dwell's ends
    p = S.params_for(0.040, 0.0, S.BASE, 1.0, 0.0)
    rows = S.kinematic_rows(w, case, p)
    alpha = T.mass_ratio(p.I1, p.I2, p.r, p.R3, p.beta, p.theta, p.chi)
    for row in rows:   # eq. (10) by hand
        assert row["V3y_eq10"] == pytest.approx((alpha * 1.2 * p.v_pin + (1 - 0.2 * alpha) * row["V3"]) / (alpha + 1))


def test_fig2_circular_groove_has_no_velocity_along_the_slot():
    """Known answer: on the base four-bar's circle the stone never moves along the slot; the roller centre
    moves across it at lambda3 r gamma' omega."""
    phi, g, g1, g2, prof = _base_fourbar()
    w = L.wall_forces(prof, g1, g2, R, 15.0, 0.00043, 0.01)
    assert np.max(np.abs(w.v_slot)) < 1e-6 * np.max(np.abs(w.v_rocker))
    np.testing.assert_allclose(w.v_rocker, LAM3 * R * g1 * 15.0, rtol=1e-9)


def _one_lift_off(N_of_k):
    """The K0 case's first lift-off sample i with the wall force replaced by N_of_k(k - i, dt) (k the sample,
    dt the time step between samples)."""
    import dataclasses

    case = L.LiftOffCase(law="K0")
    w = L.lift_off(case)
    i = int(w.lift_off[0][0])
    k = (np.arange(len(w.phi)) - i) % len(w.phi)
    s = math.copysign(1.0, w.N[i])
    dt = (w.phi[1] - w.phi[0]) / case.omega
    w = dataclasses.replace(w, N=s * N_of_k(k.astype(float), dt), lift_off=np.array([[i, (i + 1) % len(w.phi)]]))
    return case, w, dt


def test_crossing_of_the_play_after_a_lift_off_meets_the_closed_forms():
    """After a lift-off the roller crosses the play under the missing wall force over its reduced mass.
    Known answers: a force that passes zero at the rate Ndot crosses 10 um in t = (6 clearance m_n / Ndot)^(1/3)
    and strikes at Ndot t^2 / (2 m_n); a force that steps to N1 (a law's acceleration jump, ramped over the
    half sample after the crossing) in the time of constant acceleration after that ramp."""
    clearance, Ndot = 10e-6, 50.0
    case, w, dt = _one_lift_off(lambda k, dt: -Ndot * (np.where(k > 1000, 1000, k) - 0.5) * dt)
    cr = L.crossing(w, case, clearance)[0]
    m_n = cr["m_n"]
    t = (6 * clearance * m_n / Ndot) ** (1 / 3)
    assert cr["t_cross"] == pytest.approx(t, rel=1e-4)
    assert cr["v_impact"] == pytest.approx(Ndot * t * t / (2 * m_n), rel=1e-4)
    assert cr["crank_deg"] == pytest.approx(math.degrees(case.omega * t), rel=1e-4)
    N1 = 1.0
    case, w, dt = _one_lift_off(lambda k, dt: np.where(k == 0, N1, -N1))
    cr = L.crossing(w, case, clearance)[0]
    a0, ramp = N1 / cr["m_n"], dt / 2
    x = -ramp / 2 + math.sqrt(ramp ** 2 / 4 - 2 * (ramp ** 2 / 6 - clearance / a0))
    assert cr["t_cross"] == pytest.approx(ramp + x, rel=1e-4)
    assert cr["v_impact"] == pytest.approx(a0 * (ramp / 2 + x), rel=1e-4)
    # a force that turns back before the roller has crossed: it returns to its wall, no crossing
    case, w, dt = _one_lift_off(lambda k, dt: np.where((k >= 1) & (k <= 3), -1e-3, 1.0))
    assert math.isnan(L.crossing(w, case, clearance)[0]["t_cross"])


def test_crossing_mass_is_the_free_kulisas_inertia_seen_along_the_wall_normal():
    """m_n = (J + m_s |dB/dgamma|^2) / (dB/dgamma . n_g)^2, with dB/dgamma from the stone's position at the
    frozen crank angle for two kulisa angles (central difference of the roller centre, not of rho)."""
    case = L.LiftOffCase(law="C0")
    w = L.lift_off(case)
    branch = groove.base_branch(case.lam1, case.lam2, case.lam3)
    for (i, _), cr in zip(w.lift_off, L.crossing(w, case)):
        phi, g, dg = w.phi[i], w.gamma[i], 1e-5

        def B(gg):
            return case.r * groove.stone_radius_scalar(phi, gg, case.lam1, case.lam2, branch) * np.array(
                [math.cos(gg), math.sin(gg)])
        dB = (B(g + dg) - B(g - dg)) / (2 * dg)
        assert cr["m_n"] == pytest.approx((case.J + case.m_stone * dB @ dB) / (dB @ w.n_wall[i]) ** 2, rel=1e-6)
