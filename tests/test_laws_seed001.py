"""Seed 001's named laws of periodic motion (issue 31): the harmonic-group laws 1,3 / 1,4 / 1,5 from the seed's own
formula, and the laws it names without one refused with what the seed says of them."""
import math

import numpy as np
import pytest

from fmus.physics import laws as L

K = np.linspace(0.0, 1.0, 100001)


@pytest.mark.parametrize("name, n", [("1,3", 1.3), ("1,4", 1.4), ("1,5", 1.5)])
def test_seed_harmonic_laws_are_the_seeds_formula_with_n_from_the_name(name, n):
    """The seed: harmonic laws follow eps_k = C[1 - (2k)^n], C the acceleration peak, n the power coefficient;
    the law's name gives n.  C is fixed by the boundary values a(0) = 0, a(1) = 1, b(0) = b(1) = 0 alone: it is
    derived here by integrating the seed's formula twice, not taken from the code."""
    law = L.get_law(name)
    a, b, c = law(K)
    half = K <= 0.5
    # the boundary values
    assert a[0] == 0.0 and a[-1] == pytest.approx(1.0, abs=1e-12)
    assert b[0] == pytest.approx(0.0, abs=1e-12) and b[-1] == pytest.approx(0.0, abs=1e-12)
    # C from a(1/2) = 1/2 (point symmetry) with the seed's shape: a(1/2) = C * int_0^1/2 int_0^k [1-(2u)^n] du dk
    shape = 1.0 - (2.0 * K[half]) ** n
    h = K[1] - K[0]
    v = np.concatenate([[0.0], np.cumsum(0.5 * (shape[1:] + shape[:-1])) * h])
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1])) * h])
    C = 0.5 / s[-1]
    assert c[0] == pytest.approx(C, rel=1e-6)
    assert np.allclose(c[half], C * shape, rtol=0, atol=1e-6 * C)           # the seed's formula itself
    # point symmetry about k = 1/2, and the acceleration changes sign there
    assert np.allclose(a + a[::-1], 1.0, atol=1e-12) and np.allclose(c, -c[::-1], atol=1e-9)
    assert abs(float(law(np.array([0.5]))[2][0])) < 1e-12
    # the dimensionless coefficients: C_a = C, C_v = b(1/2)
    cv, ca = law.coefficients()
    assert ca == pytest.approx(C, rel=1e-6) and cv == pytest.approx(C * v[-1], rel=1e-6)
    # harmonic group: a finite acceleration at the start (the seed's Fig. 4 curves start at their peak)
    assert c[0] == pytest.approx(ca, rel=1e-9)


def test_seed_harmonic_laws_order_by_n():
    """A smaller n is a sharper acceleration peak: 1,3 peaks above 1,4 above 1,5, all between the constant-
    acceleration law (C = 4) and the linear one (n = 1, C = 6)."""
    peaks = [L.get_law(n).coefficients()[1] for n in ("1,3", "1,4", "1,5")]
    assert 6.0 > peaks[0] > peaks[1] > peaks[2] > 4.0


@pytest.mark.parametrize("name, group", [("2,12", "cycloidal"), ("3,8", "polydynamic"), ("Ш", "cycloidal"),
                                         ("Shuna", "cycloidal"), ("Pd 3,8", "polydynamic")])
def test_laws_the_seed_names_without_a_formula_are_refused_saying_so(name, group):
    with pytest.raises(ValueError, match=f"named by seed 001 without a formula: {group} group"):
        L.get_law(name)


def test_the_components_law_indices_do_not_move():
    """The seed's laws are for the synthesis tools: the FMUs' Integer law index keeps its meaning."""
    assert L.LAW_NAMES[:9] == ("K0", "C0", "0000", "power", "polydynamic", "4567", "P6", "composite", "bed004")
    assert set(L.SEED_HARMONIC) <= set(L.KNOWN_LAWS)
    assert math.isclose(L.get_law("1,5").coefficients()[1], L.get_law("power", n=1.5).coefficients()[1])
