"""Seed 000's take-up model (fmus.physics.takeup) against closed forms: a free two-body impact gives Newton's
restitution and the central-impact velocities of eqs (10), (11); an undamped take-up peaks at eq. (17)'s
z_max and eq. (18)'s force and lasts half a period of eq. (7)'s lambda_m; the damped peak is the
Kelvin-Voigt closed form; the roller's take-up scales by eq. (23); the contact equations have the natural
frequencies of eqs (8)-(9); alpha_c = c1/(c2 R3^2) turns the consistent model into the seed's alpha-form."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fmus.physics import contact
from fmus.physics import takeup as T
from fmus.physics.two_mass import seed_frequencies, two_mass_frequencies

FREE = [  # e, beta, theta, chi, alpha_m, V3 [m/s]
    (0.2, 0.0, 0.0, 0.2, 1.0, 0.0),
    (0.5, 0.6, 0.2, 0.2, 0.5, 0.1),
    (0.9, 1.1, -0.3, 0.0, 2.0, -0.05),
    (0.2, 0.3, 0.0, 0.3, 5.0, 0.2),
]


@pytest.mark.parametrize("e, beta, theta, chi, am, V3", FREE)
def test_free_impact_gives_the_restitution_and_eqs_10_11(e, beta, theta, chi, am, V3):
    # c1 = 0: the crank side is a free body; the contact law must return e and the central-impact velocities
    p = T.TakeUpParams(alpha_c=0.0, alpha_m=am, e=e, beta=beta, theta=theta, chi=chi, V3=V3)
    res = T.simulate(p)
    assert res.opened and res.classical
    assert res.e_measured == pytest.approx(e, rel=1e-6)
    alpha = T.mass_ratio(p.I1, p.I2, p.r, p.R3, beta, theta, chi)
    assert res.v_rocker_after == pytest.approx(T.v3y_first(alpha, e, p.v_pin, V3), rel=1e-6, abs=1e-9)
    # eq (11) is the velocity of the body of mass ratio alpha after the impact: here the crank side
    assert res.v_crank_after == pytest.approx(T.v3y_rebound(alpha, e, V3, p.v_pin), rel=1e-6, abs=1e-9)


def test_mass_ratio_is_alpha_m_in_the_normalised_case():
    assert T.mass_ratio(0.7, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0) == pytest.approx(0.7, rel=1e-15)
    # and the seed's (10) with V3 = 0, e = 1, equal masses: the pin takes the crank pin's speed
    assert T.v3y_first(1.0, 1.0, 0.5, 0.0) == pytest.approx(0.5, rel=1e-15)


@pytest.mark.parametrize("beta, V3, am", [(0.0, 0.0, 1.0), (0.5, 0.0, 2.0), (0.2, 0.1, 0.5)])
def test_undamped_take_up_peaks_at_eq17_and_lasts_half_a_period(beta, V3, am):
    p = T.TakeUpParams(alpha_c=0.0, alpha_m=am, e=1.0, beta=beta, V3=V3)
    res = T.simulate(p)
    lam = p.lambda_m()
    assert res.z_peak == pytest.approx(T.z_max(p.v_pin, V3, lam, e=1.0), rel=1e-5)
    assert res.F_peak == pytest.approx(T.impact_force(p.v_pin, V3, lam, p.c2, e=1.0), rel=1e-5)
    assert res.duration == pytest.approx(math.pi / lam, rel=1e-7)
    assert res.e_measured == pytest.approx(1.0, rel=1e-7)


@pytest.mark.parametrize("e", [0.2, 0.5])
def test_damped_peak_is_the_kelvin_voigt_closed_form(e):
    # x = v/wd exp(-zeta wn t) sin(wd t): peak at tan(wd t) = sqrt(1 - zeta^2)/zeta
    p = T.TakeUpParams(alpha_c=0.0, e=e)
    res = T.simulate(p)
    z = contact.kelvin_voigt_zeta(e)        # the no-pull law's damping ratio (the FMUs' law)
    wn = p.lambda_m()
    wd = wn * math.sqrt(1 - z * z)
    tp = math.atan2(math.sqrt(1 - z * z), z) / wd
    assert res.z_peak == pytest.approx(p.v_in / wd * math.exp(-z * wn * tp) * math.sin(wd * tp), rel=1e-5)
    assert res.z_peak < T.z_max(p.v_pin, 0.0, wn)          # eq (17) is the undamped bound


def test_roller_take_up_scales_by_eq23():
    mu, nu = 0.4, 0.3
    pin = T.simulate(T.TakeUpParams(alpha_c=0.0, e=1.0))
    roller = T.simulate(T.TakeUpParams(alpha_c=0.0, e=1.0, projection=math.cos(mu) * math.cos(nu)))
    assert roller.F_peak == pytest.approx(T.roller_force(pin.F_peak, mu, nu), rel=1e-5)
    p = pin.params
    assert T.v3y_roller(1.0, 0.2, p.v_pin, 0.0, mu, nu) == pytest.approx(
        T.v3y_first(1.0, 0.2, p.v_pin * math.cos(mu) * math.cos(nu), 0.0), rel=1e-15)


@pytest.mark.parametrize("ac, am, beta, theta", [(0.2, 1.0, 0.0, 0.0), (1.5, 0.5, 0.5, 0.2), (0.05, 5.0, 1.0, -0.2)])
def test_closed_joint_has_the_frequencies_of_eqs_8_9(ac, am, beta, theta):
    # the module's equations with the joint closed (mode +1) linearised: eigenvalues -> lambda1, lambda3
    p = T.TakeUpParams(alpha_c=ac, alpha_m=am, beta=beta, theta=theta, e=1.0)
    rhs, _ = T._rhs_factory(p, 0.0, q0=p.clearance + 1.0)    # deep in the contact: the force stays a push
    y0 = np.zeros(4)
    f0 = np.asarray(rhs(0.0, y0, 1))
    J = np.column_stack([(np.asarray(rhs(0.0, y0 + 1e-3 * np.eye(4)[k], 1)) - f0) / 1e-3 for k in range(4)])
    w = np.sort(np.abs(np.linalg.eigvals(J).imag))[::2]
    f = p.frequencies()
    assert (w[1], w[0]) == pytest.approx((float(f.lambda1), float(f.lambda3)), rel=1e-6)


def test_seed_alpha_c_gives_the_printed_alpha_form():
    # alpha_c = c1/(c2 R3^2) and r = R3: the consistent model's frequencies are (8)-(9) in units sqrt(c2 R3^2/I2)
    I2, c2, R3 = 0.00043, 5e5, 0.1
    for am, ac, beta, theta in [(0.5, 0.05, 0.0, 0.0), (2.0, 0.3, 0.4, 0.2), (5.0, 0.4, 1.0, -0.3)]:
        c1 = ac * c2 * R3 ** 2
        assert float(T.seed_alpha_c(c1, c2, R3)) == pytest.approx(ac, rel=1e-14)
        f = two_mass_frequencies(am * I2, I2, c1, c2, R3, R3, beta, theta, 0.2)
        g = seed_frequencies(am, ac, beta, theta, 0.2, c2_over_I2=c2 * R3 ** 2 / I2)
        assert (float(f.lambda1), float(f.lambda3)) == pytest.approx((float(g.lambda1), float(g.lambda3)), rel=1e-12)


def test_classification_free_impact_is_classical_and_a_held_contact_is_not():
    assert T.classify(alpha_c=0.0).classical
    p = T.TakeUpParams()
    held = T.classify(V3=p.v_pin - 0.01, load=2.0)      # 10 mm/s approach, 2 N pressing the rocker back
    assert not held.opened and not held.classical
    assert held.duration == pytest.approx(p.periods * p.lambda_m() ** -1 * 2 * math.pi, rel=1e-9)


def test_bad_input_names_the_parameter_and_the_range():
    with pytest.raises(ValueError, match=r"TakeUpParams.e = 1.5 outside"):
        T.simulate(T.TakeUpParams(e=1.5))
    with pytest.raises(ValueError, match=r"approach speed .* at beta = 90 deg: the pin does not close"):
        T.simulate(T.TakeUpParams(beta=math.pi / 2))
    with pytest.raises(ValueError, match=r"TakeUpParams.e = 0.1 below 0.13"):
        T.simulate(T.TakeUpParams(e=0.1))
    with pytest.raises(ValueError, match=r"TakeUpParams.c4 = 0.0 outside \(0, inf\]"):
        T.simulate(T.TakeUpParams(c4=0.0))
    with pytest.raises(ValueError, match=r"approach speed"):
        T.simulate(T.TakeUpParams(V3=T.TakeUpParams().v_pin))        # the rocker side as fast as the pin


def test_lambda_m_is_two_mass_eq7():
    p = T.TakeUpParams(alpha_c=0.3, alpha_m=2.0, beta=0.4, theta=0.1)
    assert p.lambda_m() == pytest.approx(float(p.frequencies().lambda_m), rel=1e-12)


def test_study_map_and_summary(tmp_path):
    from harness.studies import takeup as S

    feeder = {"v_median": 0.01, "F_min": 1.0}
    grid = [("", 0.0, dict(S.BASE)), ("", 90.0, dict(S.BASE)), ("e", 0.0, {**S.BASE, "e": 1.0})]
    df = S.run_map(feeder, alpha_c=(0.0, 0.3, 3.0), alpha_m=(1.0,), grid=grid, geometries={"seed r=R3": 0.04})
    assert set(df["case"]) == {"seed", "feeder", "feeder held"}
    seed = df[(df["case"] == "seed") & (df["varied"] == "") & (df["beta_deg"] == 0.0)].set_index("alpha_c")
    assert bool(seed.loc[0.0, "classical"])                       # free impact
    assert not df[(df["beta_deg"] == 90.0)]["take_up"].any()      # the pin moves across the joint: no take-up
    assert (df[df["case"] == "feeder held"]["classical"] == False).all()   # noqa: E712  held: never opens
    summ = S.summarise(df)
    row = summ[(summ["case"] == "seed") & (summ["varied"] == "")].iloc[0]
    non = seed.index[~seed["classical"].astype(bool)]
    assert (math.isnan(row["first_nonclassical"]) if len(non) == 0 else row["first_nonclassical"] == non.min())
    with pytest.raises(FileNotFoundError, match="feeder clearance sweep"):
        S.feeder_takeups(tmp_path / "missing.csv")


def test_study_default_grid_holds_the_seeds_cases_and_its_help_is_whole(tmp_path, monkeypatch):
    """Issue 31: the default grid covers the seed's parameters (its alpha_c 0.05-0.3, alpha_m 0.5-5, beta
    0-180 deg, e = 0.2 and 1, 5-20 um, c2 1e5-1e6, chi 0.2, 100-200 rpm, theta varied), the default input
    path is the source tree's from any folder, and the help text ends with a full stop."""
    from harness.__main__ import build_parser
    from harness.studies import takeup as S

    grid = list(S.settings_grid())
    values = {k: {s[k] for _, _, s in grid} for k in S.BASE}
    assert {0.2, 1.0} <= values["e"] and {5.0, 20.0} <= values["clearance_um"] and {1e5, 1e6} <= values["c2"]
    assert {100.0, 200.0} <= values["rpm"] and 0.2 in values["chi"] and len(values["theta_deg"]) > 1
    assert {0.0, 180.0} <= {b for _, b, _ in grid} and {0.05, 0.3} <= set(S.ALPHA_C)
    assert {0.5, 5.0} <= set(S.ALPHA_M)
    monkeypatch.chdir(tmp_path)
    args = build_parser().parse_args(["study", "takeup"])
    assert args.feeder_csv.is_absolute() and args.feeder_csv.is_file()
    sub = build_parser()._subparsers._group_actions[0].choices["study"]
    desc = sub._subparsers._group_actions[0].choices["takeup"].description
    assert desc.rstrip().endswith(".")                        # not cut mid-sentence
    assert "crank speed" in desc


# ---- issue 31: a contact only pushes; the seed's classical impact; the first impact; the whole beta range ----

@pytest.mark.parametrize("e", [0.2, 0.5, 0.9])
@pytest.mark.parametrize("beta, theta, am", [(0.0, 0.0, 1.0), (0.6, 0.2, 0.5), (2.2, -0.3, 2.0)])
def test_free_impact_never_pulls_and_is_shorter_than_half_a_take_up_period(e, beta, theta, am):
    """The seed's e = 0.2 used to pull (-31 N against a 159 N peak) and last 1.12 half-periods: a contact
    pushes only, so its force never falls below zero and, with e < 1, it opens before pi/lambda_m (the
    undamped one lasts exactly that: test_undamped_take_up_peaks_at_eq17_and_lasts_half_a_period)."""
    p = T.TakeUpParams(alpha_c=0.0, alpha_m=am, e=e, beta=beta, theta=theta)
    res = T.simulate(p, samples=4000)
    assert res.opened and res.F_min >= 0.0
    first = res.F[res.t <= res.duration] * np.sign(res.v_in)       # signed as the first contact's wall
    assert first.min() >= -1e-12 * res.F_peak                      # (the end is an event: rounding only)
    assert res.duration < math.pi / p.lambda_m()
    assert res.e_measured == pytest.approx(e, rel=1e-6)


def test_beyond_90_degrees_the_pin_closes_the_other_wall():
    """beta = 120 deg: cos(beta) < 0, the crank pin moves the other way and the joint closes on its back wall;
    the free impact is the mirror of beta = 60 deg's (cos(beta) cos(beta + theta) is the same)."""
    back = T.simulate(T.TakeUpParams(alpha_c=0.0, beta=math.radians(120.0)))
    front = T.simulate(T.TakeUpParams(alpha_c=0.0, beta=math.radians(60.0)))
    assert back.v_in < 0.0 < front.v_in and back.history[0].wall == -1 and front.history[0].wall == 1
    assert back.F_peak == pytest.approx(front.F_peak, rel=1e-6)
    assert back.duration == pytest.approx(front.duration, rel=1e-6)
    assert back.e_measured == pytest.approx(0.2, rel=1e-6)


def test_negative_cos_product_is_simulated():
    """cos(beta) cos(beta + theta) < 0 (beta = 80, theta = 20 deg): the crank side's reduced mass is negative,
    lambda_m^2 = k (1/m1 + 1/m2) smaller; the undamped free take-up still lasts pi/lambda_m.  With a light
    crank side (alpha_m = 0.05, beta = theta = 60 deg) lambda_m^2 < 0: unstable, never classical."""
    p = T.TakeUpParams(alpha_c=0.0, e=1.0, beta=math.radians(80.0), theta=math.radians(20.0))
    m1, m2 = p.masses()
    assert m1 < 0.0 < m2
    res = T.simulate(p)
    assert res.stable and res.duration == pytest.approx(math.pi / p.lambda_m(), rel=1e-7)
    bad = T.simulate(T.TakeUpParams(alpha_m=0.05, R3=0.04, beta=math.radians(60.0), theta=math.radians(60.0)))
    assert not bad.stable and not bad.classical and math.isnan(T.TakeUpParams(
        alpha_m=0.05, R3=0.04, beta=math.radians(60.0), theta=math.radians(60.0)).lambda_m())


def test_classical_is_the_seeds_alpha_y_of_the_first_contact():
    """alpha_y = natural period 2 pi/lambda3 over the first contact's duration (the seed's definition).
    Known answers: without a drive stiffness the natural period is infinite (classical); a contact held
    closed by a load never opens (not classical); with the drive at alpha_c = 0.3, alpha_m = 1 (r = R3) the
    e = 0.2 contact is held by the drive until its slow mode turns: it lasts half the natural period,
    alpha_y = 2 (not classical); at alpha_c = 0.01 it is a collision, shorter than pi/lambda_m."""
    free = T.classify(alpha_c=0.0)
    assert free.alpha_y == math.inf and free.classical
    p = T.TakeUpParams()
    held = T.classify(V3=p.v_pin - 0.01, load=2.0)
    assert not held.opened and not held.classical
    drive = T.classify(alpha_c=0.3, R3=0.04)
    lam3 = float(drive.params.frequencies().lambda3)
    assert drive.alpha_y == pytest.approx(2.0 * math.pi / lam3 / drive.duration, rel=1e-12)
    assert drive.duration == pytest.approx(math.pi / lam3, rel=0.03) and not drive.classical
    short = T.classify(alpha_c=0.01, R3=0.04)
    assert short.duration < math.pi / short.params.lambda_m() and short.alpha_y > 4.0 and short.classical


def test_only_the_first_impact_counts_is_checked():
    """S0-6 as a check over the run: with e = 0.2 the later contacts are weaker (the first governs); with
    e = 1 the drive feeds the bouncing pin and a later contact peaks above the first."""
    lossy = T.classify(alpha_c=0.01, alpha_m=0.5, R3=0.04)
    assert len(lossy.history) >= 2 and lossy.first_governs
    assert max(c.F_peak for c in lossy.history[1:]) < lossy.history[0].F_peak
    elastic = T.classify(alpha_c=0.01, alpha_m=0.5, R3=0.04, e=1.0)
    assert not elastic.first_governs
    assert max(c.F_peak for c in elastic.history[1:]) > elastic.history[0].F_peak
    assert T.first_governs(elastic.history[:1])


@pytest.mark.parametrize("beta, theta, am, V3", [(0.0, 0.0, 1.0, 0.0), (0.5, 0.3, 2.0, 0.1), (2.4, -0.2, 0.5, 0.0)])
def test_closed_forms_14_to_17_follow_the_undamped_free_take_up(beta, theta, am, V3):
    """Their range of validity: eq. (5), no drive (c1 = 0), no load, an undamped contact (e = 1), within the
    first contact.  (14) the crank angle, (15) the pin's displacement R3 gamma, (16) the approach q."""
    p = T.TakeUpParams(alpha_c=0.0, alpha_m=am, e=1.0, beta=beta, theta=theta, V3=V3)
    res = T.simulate(p, samples=20000)
    lam = p.lambda_m()
    inside = res.t <= res.duration
    t, y = res.t[inside], res.y[inside]
    C = T.takeup_constants(p)
    scale = abs(p.v_in) / lam
    np.testing.assert_allclose(T.crank_angle(t, C, lam), y[:, 0], rtol=0, atol=1e-7 * scale / p.r)
    np.testing.assert_allclose(T.pin_displacement(t, C, lam, p), p.R3 * y[:, 2], rtol=0, atol=1e-7 * scale)
    q = res.q[inside] - (p.clearance if p.v_in > 0 else 0.0)
    np.testing.assert_allclose(T.approach(t, p.v_in, 0.0, lam), q, rtol=0, atol=1e-7 * scale)
    assert abs(res.z_peak) == pytest.approx(T.z_max(abs(p.v_in), 0.0, lam), rel=1e-6)


@pytest.mark.parametrize("c4", [2e5, 5e5, 3e6])
def test_eq13_with_a_joint_stiffness_c4_and_eq22_with_the_rollers_c4(c4):
    """(13)/(18): with the joint's own c4 in series with c2 the simulated peak force is k v / lambda_m(k),
    k = c2 c4/(c2 + c4), and the joint's own deformation F/c4.  (20)-(22): the roller take-up (approach
    projected by cos(mu) cos(nu), its own c'4) peaks at (21), (22) with c'4."""
    pin = T.TakeUpParams(alpha_c=0.0, e=1.0, c4=c4)
    res = T.simulate(pin)
    k = pin.c2 * c4 / (pin.c2 + c4)
    assert pin.k == pytest.approx(k, rel=1e-15)
    lam = pin.lambda_m()
    F = T.impact_force(pin.v_pin, 0.0, lam, k)
    assert res.F_peak == pytest.approx(F, rel=1e-6)
    assert T.joint_deformation(F, c4) == pytest.approx(res.z_peak * k / c4, rel=1e-6)
    assert F < T.impact_force(pin.v_pin, 0.0, T.TakeUpParams(alpha_c=0.0).lambda_m(), pin.c2)  # softer joint
    mu, nu = 0.4, 0.3
    proj = math.cos(mu) * math.cos(nu)
    roller = T.TakeUpParams(alpha_c=0.0, e=1.0, c4=c4 / 2, projection=proj)
    rr = T.simulate(roller)
    kr = roller.k
    assert rr.z_peak == pytest.approx(T.z_max(roller.v_pin * proj, 0.0, roller.lambda_m()), rel=1e-6)
    assert rr.F_peak == pytest.approx(T.impact_force(roller.v_pin * proj, 0.0, roller.lambda_m(), kr), rel=1e-6)


def test_eq19_is_eq15_with_the_projected_lever():
    """(19) replaces r cos(beta) by r cos(beta) cos(mu) cos(nu) in (15): at projection 1 they coincide, and
    its first term scales with the projection."""
    p = T.TakeUpParams(alpha_c=0.0, e=1.0, beta=0.3, theta=0.1)
    C, lam, t = T.takeup_constants(p), p.lambda_m(), np.linspace(0.0, 1e-3, 7)
    np.testing.assert_array_equal(T.pin_displacement(t, C, lam, p, 1.0), T.pin_displacement(t, C, lam, p))
    d = T.pin_displacement(t, C, lam, p, 0.5) - T.pin_displacement(t, C, lam, p, 1.0)
    a = p.r * math.cos(p.beta)
    np.testing.assert_allclose(d, -0.5 * a * (C[0] + C[1] * t + C[2] * np.sin(lam * t) + C[3] * np.cos(lam * t)),
                               rtol=1e-12, atol=1e-18)


def test_fig2_velocity_trace_meets_eq10_after_a_free_impact(tmp_path):
    """The study's Fig. 2 chart (roller-centre velocity during the take-up): after a free first impact the
    roller centre moves at eq. (10)'s V3y and stays there until the next contact; the chart is written."""
    from harness.studies import takeup as S

    p = S.params_for(0.04, 0.0, S.BASE, 1.0, 0.0)
    tr = S.velocity_trace(p)
    after = (tr["t"] > tr["first_end"]) & (tr["t"] < tr["result"].history[1].onset)
    assert after.sum() > 10
    np.testing.assert_allclose(tr["v_roller"][after], tr["v3y_eq10"], rtol=1e-6)
    assert tr["v_crank_pin"][0] == pytest.approx(p.v_pin, rel=1e-12) and tr["v_roller"][0] == 0.0
    files = S.plot_velocity(tmp_path, alpha_c=(0.0,))
    assert all(f.is_file() and f.stat().st_size > 1000 for f in files)
