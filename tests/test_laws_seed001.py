"""Seed 001's named laws of periodic motion (issue 31).  Its names "1,3", "1,4", "1,5", "2,12", "3,8" are catalogue
codes "group, number" of Tir & Senyk [10] (1 harmonic, 2 cycloidal, 3 polydynamic), "Ш" is Shun's law: the seed
defines none of them and our copy has no [10], so each is refused by name with what the seed says of its group.
The one formula the seed prints, the rocker's acceleration "of the type" eps = C[1 - (2k)^n], is the power-type
law 'power' with its own n, tested here under that name."""
import math

import numpy as np
import pytest

from fmus.physics import laws as L

K = np.linspace(0.0, 1.0, 100001)


@pytest.mark.parametrize("name, number", [("1,3", 3), ("1,4", 4), ("1,5", 5), ("1.5", 5)])
def test_the_seeds_harmonic_catalogue_laws_are_refused_by_name(name, number):
    """Refused in one line naming the law, its catalogue group and number, and that there is no stand-in (the
    previous reading built them as the power family with n read from the name)."""
    with pytest.raises(ValueError) as e:
        L.get_law(name)
    msg = str(e.value)
    assert "\n" not in msg
    assert f"catalogue law {number} of the harmonic group of Tir & Senyk [10]" in msg
    assert "seed 001 names but does not define" in msg and "no stand-in" in msg
    assert "smooth cam profile" in msg                      # what the seed says of the harmonic group
    assert name.replace(".", ",") not in L.KNOWN_LAWS


@pytest.mark.parametrize("name, group, number", [("2,12", "cycloidal", 12), ("3,8", "polydynamic", 8),
                                                 ("Pd 3,8", "polydynamic", 8)])
def test_the_seeds_other_catalogue_laws_are_refused_by_name(name, group, number):
    with pytest.raises(ValueError, match=rf"catalogue law {number} of the {group} group of Tir & Senyk \[10\].*"
                                         r"does not define.*no stand-in"):
        L.get_law(name)


@pytest.mark.parametrize("name", ["Ш", "Shuna", "Sh"])
def test_shuns_law_is_refused_by_name(name):
    with pytest.raises(ValueError, match=r"'Ш' is a law of the cycloidal group, which seed 001 names but does not "
                                         r"define .*no stand-in.*Shun"):
        L.get_law(name)


@pytest.mark.parametrize("n", [0.8, 1.3, 1.5, 2.0, 3.5])
def test_the_power_type_law_is_the_seeds_form_with_its_own_n(n):
    """The seed's form eps_k = C[1 - (2k)^n], C the acceleration peak, n the power coefficient, completed point-
    symmetrically about k = 1/2.  C is fixed by the boundary values a(0) = 0, a(1) = 1, b(0) = b(1) = 0 alone: it is
    derived here by integrating the seed's formula twice, not taken from the code."""
    law = L.get_law("power", n=n)
    a, b, c = law(K)
    half = K <= 0.5
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
    assert np.allclose(a + a[::-1], 1.0, atol=1e-12) and np.allclose(c, -c[::-1], atol=1e-9)
    assert abs(float(law(np.array([0.5]))[2][0])) < 1e-12
    cv, ca = law.coefficients()
    assert ca == pytest.approx(C, rel=1e-6) and cv == pytest.approx(C * v[-1], rel=1e-6)
    assert law.name == "power" and law.params == (("n", n),) and "C[1-(2k)^n]" in law.doc


def test_the_power_type_peak_falls_with_n():
    """A smaller n is a sharper acceleration peak; n = 1 is the linear acceleration (C = 6), large n tends to the
    constant acceleration (C = 4)."""
    peaks = [L.get_law("power", n=n).coefficients()[1] for n in (1.0, 1.3, 1.5, 2.0, 8.0)]
    assert peaks[0] == pytest.approx(6.0, rel=1e-9)
    assert all(p > q for p, q in zip(peaks, peaks[1:])) and peaks[-1] > 4.0


def test_the_components_law_indices_do_not_move():
    """The seed's names are refused for the synthesis tools only: the FMUs' Integer law index keeps its meaning."""
    assert L.LAW_NAMES[:9] == ("K0", "C0", "0000", "power", "polydynamic", "4567", "P6", "composite", "bed004")
    assert not set(L.SEED_UNDEFINED) & set(L.KNOWN_LAWS)
    assert math.isclose(L.power_constant(1.5), L.get_law("power", n=1.5).coefficients()[1], rel_tol=1e-9)
