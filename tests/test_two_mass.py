"""Seed 000's two-mass frequency analysis (fmus.physics.two_mass) against independent computations: the roots
of the quartic characteristic equation (3) by numpy.roots, the eigenvalues of the take-up equations (5)
by numpy.linalg.eigvals, and the decoupled limit cos(beta) = 0."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fmus.physics.two_mass import seed_frequencies, two_mass_frequencies

CASES = [  # alpha_m, alpha_c, beta, theta, chi
    (0.5, 0.05, 0.0, 0.0, 0.2),
    (2.0, 0.3, 0.4, 0.2, 0.2),
    (5.0, 0.4, 1.0, -0.3, 0.2),
    (1.0, 1.0, 0.7, 0.5, 0.0),
    (0.5, 3.0, 0.2, 0.1, 0.3),
]


def quartic_frequencies(I1, I2, c1, c2, r, R3, beta, theta, chi):
    """Positive imaginary parts of the roots of p^4 + (k1^2 + k3^2) p^2 + c1 c2 (1-chi) R3^2/(I1 I2)."""
    k1 = (c1 + c2 * r * r * math.cos(beta) * math.cos(beta + theta)) / I1
    k3 = c2 * (1 - chi) * R3 * R3 / I2
    p = np.roots([1.0, 0.0, k1 + k3, 0.0, c1 * c2 * (1 - chi) * R3 * R3 / (I1 * I2)])
    assert np.max(np.abs(p.real)) < 1e-6 * np.max(np.abs(p))          # purely imaginary, eq. (4)
    w = np.sort(p.imag[p.imag > 0])
    return w[1], w[0]


@pytest.mark.parametrize("am, ac, beta, theta, chi", CASES)
def test_alpha_form_equals_roots_of_quartic(am, ac, beta, theta, chi):
    # eq (3) in SI numbers of the seed: I2 = 0.00043 kg.m2, c2 = 5e5, I1 = alpha_m I2, c1 = alpha_c c2, r = R3 = 1
    I2, c2 = 0.00043, 5.0e5
    l1, l3 = quartic_frequencies(am * I2, I2, ac * c2, c2, 1.0, 1.0, beta, theta, chi)
    f = seed_frequencies(am, ac, beta, theta, chi, c2_over_I2=c2 / I2)
    assert f.valid
    assert float(f.lambda1) == pytest.approx(l1, rel=1e-9)
    assert float(f.lambda3) == pytest.approx(l3, rel=1e-9)
    assert float(f.alpha_y) == pytest.approx(2 * l1 / l3, rel=1e-9)


@pytest.mark.parametrize("am, ac, beta, theta, chi", CASES)
def test_take_up_frequency_is_the_eigenvalue_of_eq5(am, ac, beta, theta, chi):
    # (5): I1 phi'' = -c2 r cos(b+t) (r cos b phi - R3 g), I2 g'' = c2 (1-chi) R3 (r cos b phi - R3 g)
    I2, c2, r, R3 = 0.00043, 5.0e5, 0.04, 0.12
    I1 = am * I2
    a, b = r * math.cos(beta), r * math.cos(beta + theta)
    K = np.array([[c2 * b * a / I1, -c2 * b * R3 / I1],
                  [-c2 * (1 - chi) * R3 * a / I2, c2 * (1 - chi) * R3 * R3 / I2]])   # x'' = -K x
    ev = np.sort(np.linalg.eigvals(K).real)
    assert ev[0] == pytest.approx(0.0, abs=1e-9 * ev[1])                              # rigid motion, p = 0
    f = two_mass_frequencies(I1, I2, ac * c2 * r * r, c2, r, R3, beta, theta, chi)
    assert float(f.lambda_m) == pytest.approx(math.sqrt(ev[1]), rel=1e-9)
    # and the consistent model's lambda1, lambda3 are the roots of its own quartic
    l1, l3 = quartic_frequencies(I1, I2, ac * c2 * r * r, c2, r, R3, beta, theta, chi)
    assert (float(f.lambda1), float(f.lambda3)) == pytest.approx((l1, l3), rel=1e-9)


def test_consistent_model_reduces_to_the_alpha_form():
    I2, c2 = 0.00043, 5.0e5
    f = two_mass_frequencies(0.7 * I2, I2, 0.2 * c2, c2, 1.0, 1.0, 0.3, 0.1, 0.2)
    g = seed_frequencies(0.7, 0.2, 0.3, 0.1, 0.2, c2_over_I2=c2 / I2)
    for name in ("lambda1", "lambda3", "lambda_m", "alpha_y"):
        assert float(getattr(f, name)) == pytest.approx(float(getattr(g, name)), rel=1e-12)


def test_decoupled_at_cos_beta_zero():
    # cos(beta) = 0: the crank does not move the conrod; the modes are the crank on the drive, sqrt(c1/I1),
    # and the rocker on the conrod, sqrt(c2 (1-chi)/I2) (units of sqrt(c2/I2): sqrt(ac/am), sqrt(1-chi))
    f = seed_frequencies(np.array([0.5, 2.0]), np.array([0.05, 3.0]), math.pi / 2, 0.0, 0.2)
    a = np.sqrt([0.05 / 0.5, 3.0 / 2.0])
    b = np.sqrt(0.8)
    np.testing.assert_allclose(f.lambda1, np.maximum(a, b), rtol=1e-12)
    np.testing.assert_allclose(f.lambda3, np.minimum(a, b), rtol=1e-12)
    np.testing.assert_allclose(f.lambda_m, b, rtol=1e-12)


def test_alpha_y_falls_with_alpha_c_then_rises_and_broadcasts():
    # alpha_y falls over the seed's range of alpha_c (0.05-0.3, here 0.01-1) ...
    ac = np.logspace(-2, 0, 21)
    f = seed_frequencies(1.0, ac, 0.0, 0.0)
    assert f.alpha_y.shape == ac.shape and np.all(np.diff(f.alpha_y) < 0)
    # ... but is not monotonic: once the drive mode sqrt(c1/I1) passes the conrod mode it is the higher one
    # and alpha_y grows again (cos(beta) = 0 makes this exact: alpha_y = 2 sqrt(ac / (am (1 - chi))))
    assert float(seed_frequencies(1.0, 100.0, 0.0, 0.0).alpha_y) > float(seed_frequencies(1.0, 3.0, 0.0, 0.0).alpha_y)
    assert float(seed_frequencies(1.0, 8.0, math.pi / 2, 0.0).alpha_y) == pytest.approx(2 * math.sqrt(8.0 / 0.8))
    g = seed_frequencies(np.array([[0.5], [5.0]]), ac, 0.3, 0.2)
    assert g.alpha_y.shape == (2, ac.size)


def test_complex_frequencies_are_flagged():
    # cos(beta) cos(beta + theta) = cos(0.2) cos(3.0) < -alpha_m (1-chi): lambda_m^2 < 0
    f = seed_frequencies(0.5, 0.1, 0.2, 2.8, 0.2)
    assert not bool(f.valid) and math.isnan(float(f.lambda_m)) and math.isnan(float(f.alpha_y))
