"""Seed 000's take-up model (fmus.physics.takeup) against closed forms: a free two-body impact gives Newton's
restitution and the central-impact velocities of eqs (10), (11); an undamped take-up peaks at eq. (17)'s
z_max and eq. (18)'s force and lasts half a period of eq. (7)'s lambda_m; the damped peak is the
Kelvin-Voigt closed form; the roller's take-up scales by eq. (23); the contact equations have the natural
frequencies of eqs (8)-(9); alpha_c = c1/(c2 R3^2) turns the consistent model into the seed's alpha-form."""
from __future__ import annotations

import math

import numpy as np
import pytest

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
    z = T.damping_ratio(e)
    wn = p.lambda_m()
    wd = wn * math.sqrt(1 - z * z)
    tp = math.atan2(math.sqrt(1 - z * z), z) / wd
    assert res.z_peak == pytest.approx(p.v_in / wd * math.exp(-z * wn * tp) * math.sin(wd * tp), rel=1e-5)
    assert res.z_peak < T.z_max(p.v_pin, 0.0, wn)          # eq (17) is the undamped bound
    assert T.restitution_of(z) == pytest.approx(e, rel=1e-12)


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
    rhs, _ = T._rhs_factory(p, 0.0)
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
    with pytest.raises(ValueError, match=r"cos\(beta\) cos\(beta \+ theta\)"):
        T.simulate(T.TakeUpParams(beta=math.pi / 2))
    with pytest.raises(ValueError, match=r"approach speed"):
        T.simulate(T.TakeUpParams(V3=1.0))


def test_lambda_m_is_two_mass_eq7():
    p = T.TakeUpParams(alpha_c=0.3, alpha_m=2.0, beta=0.4, theta=0.1)
    assert p.lambda_m() == pytest.approx(float(p.frequencies().lambda_m), rel=1e-12)


def test_study_map_and_summary(tmp_path):
    from harness.studies import takeup as S

    feeder = {"v_median": 0.01, "F_min": 1.0}
    df = S.run_map(150.0, feeder, alpha_c=(0.0, 0.3, 3.0), alpha_m=(1.0,), restitution=(0.2,), beta_deg=(0.0,),
                   geometries={"seed r=R3": 0.04})
    assert set(df["case"]) == {"seed", "feeder", "feeder held"}
    seed = df[df["case"] == "seed"].set_index("alpha_c")
    assert bool(seed.loc[0.0, "classical"])                       # free impact
    assert (df[df["case"] == "feeder held"]["classical"] == False).all()   # noqa: E712  held: never opens
    summ = S.summarise(df)
    row = summ[summ["case"] == "seed"].iloc[0]
    non = seed.index[~seed["classical"].astype(bool)]
    assert (math.isnan(row["first_nonclassical"]) if len(non) == 0 else row["first_nonclassical"] == non.min())
    with pytest.raises(FileNotFoundError, match="feeder clearance sweep"):
        S.feeder_takeups(tmp_path / "missing.csv")
