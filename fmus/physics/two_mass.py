"""Seed 000's frequency analysis of the two-mass drive with a clearance (feeder.md section 2.5).

The seed models the feeder drive as two masses: the crank side I1, tied to the nominal drive rotation
omega0*t by the drive stiffness c1, and the rocker I2, tied to the crank by the conrod (pin) stiffness c2.
Its characteristic equation (3)

    p^4 + (k1^2 + k3^2) p^2 + c1 c2 (1 - chi) / (I1 I2) = 0,
    k1^2 = (c1 + c2 cos(beta) cos(beta + theta)) / I1,   k3^2 = c2 (1 - chi) / I2

has the roots +-i*lambda1 and +-i*lambda3 (eqs (8)-(9), lambda1 > lambda3), and the take-up of the
clearance with the drive term dropped, eqs (5)-(7), has the single frequency lambda_m.  The seed's ratio
alpha_y = 2*lambda1/lambda3 is "the ratio of the natural-oscillation period to the clearance take-up
duration": (2 pi/lambda3) / (pi/lambda1).  S0-3 (classical impact possible for alpha_c < 0.3...0.4) comes
from evaluating it over alpha_m, alpha_c, beta, theta with chi = 0.2; the seed does not state the alpha_y
threshold (feeder.md [A]).

Two forms:

* :func:`seed_frequencies` -- the printed alpha-form (8), (9), (7): alpha_c = c1/c2, alpha_m = I1/I2, the
  normalised model r = R3 = 1; frequencies in units of sqrt(c2/I2) unless ``c2_over_I2`` is given (the
  seed evaluates c2/I2 with its SI numbers, N/m over kg.m2, feeder.md "units caveat").
* :func:`two_mass_frequencies` -- the dimensionally consistent model of feeder.md section 2.5 [T]:
  crank radius r and stone radius R3 restored, c1 in N.m/rad, c2 in N/m, inertias in kg.m2,
  conrod deformation q = r cos(beta) phi1 - R3 gamma [m].

Both return NaN (and ``valid`` False) where a frequency would be complex: cos(beta) cos(beta + theta) < 0
can make the discriminant or a squared frequency negative (feeder.md: flag, do not take complex roots).
Pure numpy, broadcasting over array arguments.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Frequencies:
    lambda1: np.ndarray   # higher natural frequency of the two-mass drive [rad/s or units of sqrt(c2/I2)]
    lambda3: np.ndarray   # lower natural frequency (the drive's slow mode)
    lambda_m: np.ndarray  # clearance take-up frequency, eq. (7)
    alpha_y: np.ndarray   # 2 lambda1 / lambda3: slow-mode period over take-up duration
    valid: np.ndarray     # False where a frequency would be complex


def _roots(s, p, lm2, scale) -> Frequencies:
    """Frequencies from the quadratic in lambda^2: x^2 - s x + p = 0 (s = sum, p = product of the two
    squared frequencies) and the squared take-up frequency lm2, all times scale^2."""
    s, p, lm2 = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (s, p, lm2)))
    disc = 0.25 * s * s - p
    root = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
    hi, lo = 0.5 * s + root, 0.5 * s - root
    ok = (disc >= 0.0) & (lo > 0.0) & (lm2 > 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        l1 = np.where(ok, np.sqrt(np.where(ok, hi, 1.0)), np.nan) * scale
        l3 = np.where(ok, np.sqrt(np.where(ok, lo, 1.0)), np.nan) * scale
        lm = np.where(ok, np.sqrt(np.where(ok, lm2, 1.0)), np.nan) * scale
        ay = 2.0 * l1 / l3
    return Frequencies(l1, l3, lm, ay, ok)


def seed_frequencies(alpha_m, alpha_c, beta, theta, chi=0.2, c2_over_I2=1.0) -> Frequencies:
    """Seed 000 eqs (8), (9) and (7) in its alpha-form; angles in rad.

    A1 = [alpha_c + alpha_m (1 - chi) + cos(beta) cos(beta + theta)] / (2 alpha_m),
    B1 = alpha_c (1 - chi) / alpha_m,  lambda1,3 = sqrt(c2/I2) sqrt(A1 +- sqrt(A1^2 - B1)),
    lambda_m = sqrt(c2/I2) sqrt([alpha_m (1 - chi) + cos(beta) cos(beta + theta)] / alpha_m)."""
    am, ac, chi = (np.asarray(v, dtype=float) for v in (alpha_m, alpha_c, chi))
    cc = np.cos(beta) * np.cos(np.asarray(beta) + theta)
    a1 = (ac + am * (1.0 - chi) + cc) / (2.0 * am)
    b1 = ac * (1.0 - chi) / am
    return _roots(2.0 * a1, b1, (am * (1.0 - chi) + cc) / am, np.sqrt(c2_over_I2))


def two_mass_frequencies(I1, I2, c1, c2, r, R3, beta, theta, chi=0.2) -> Frequencies:
    """The dimensionally consistent two-mass model (feeder.md 2.5 [T]), frequencies in rad/s:

    I1 phi1'' = c1 (omega0 t - phi1) - c2 r cos(beta + theta) q,   I2 gamma'' = c2 (1 - chi) R3 q,
    q = r cos(beta) phi1 - R3 gamma;  take-up (c1 term dropped): lambda_m^2 = c2 [r^2 cos(beta)
    cos(beta + theta) / I1 + (1 - chi) R3^2 / I2]."""
    I1, I2, c1, c2, r, R3, chi = (np.asarray(v, dtype=float) for v in (I1, I2, c1, c2, r, R3, chi))
    cc = np.cos(beta) * np.cos(np.asarray(beta) + theta)
    k1 = (c1 + c2 * r * r * cc) / I1
    k3 = c2 * (1.0 - chi) * R3 * R3 / I2
    return _roots(k1 + k3, c1 * k3 / I1, c2 * (r * r * cc / I1 + (1.0 - chi) * R3 * R3 / I2), 1.0)
