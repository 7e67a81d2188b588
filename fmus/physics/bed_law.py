"""Seed 004: the carrier (cam) law synthesised for a bed that moves uniformly through the printing zone.

The bed pinion z5 sums the four-bar rocker (ring z3) and the cam-driven carrier b through the James
differential (bed_drives.md 2.2.3): alpha5 = K delta + (1 + K) gamma, K = z3/z5 = 3 (seed: i_53^b = -3),
both angles measured from the common starting extreme position in their adding sense.  The seed's point
(its requirements from Tyurin, bed_drives.md 1.2): a bed law with a uniform-velocity segment while printing
and an acceleration diagram of conjugate harmonic segments with equal peaks.  The carrier law is therefore
not chosen freely: given the four-bar's delta(phi), the cam must supply (bed_drives.md 2.2.6)

    gamma(phi) = [alpha5(phi) - K delta(phi)] / (1 + K).

The target bed law over the working stroke, in Tir's normalised form (k = phase share 0..1, swing 1), with
run-up share u (the run-out mirrors it, so the two acceleration peaks are equal), w = pi / (2 u):

    run-up   0 <= k <= u:      c = C cos(w k),  b = (C / w) sin(w k),  a = (C / w^2) (1 - cos(w k))
    uniform  u <= k <= 1 - u:  b = V = C / w    (the printing zone), c = 0
    run-out  1 - u <= k <= 1:  mirror image, a(k) = 1 - a(1 - k), b(k) = b(1 - k), c(k) = -c(1 - k)
    C = 1 / (2 / w^2 + (1 - 2 u) / w)   (a(1) = 1)

Each run-up and run-out is a quarter-wave of a harmonic acceleration, largest at the stroke's ends and
zero where the uniform segment begins and ends (conjugate harmonic segments with equal peaks).  Why not the
half-wave c = sin(pi k / u), which starts at c = 0: the four-bar's rocker starts its working stroke with a
finite acceleration (its run-up invariant C1 = 12.9), so K delta grows as k^2 from the extreme position,
faster than a bed law whose acceleration starts at zero (k^3); the carrier would have to turn back first
(measured: b_gamma < 0 near k = 0.06 for every run-up share 0.1-0.4).  The carrier's forward stroke is then

    a_gamma(k) = [alpha_S a_alpha(k) - K delta_S a_delta(k)] / ((1 + K) gamma_S),
    alpha_S = K delta_S + (1 + K) gamma_S,

with a_delta the four-bar rocker's invariant over its working stroke, and the same for b and c (the phase
of the cam rise equals the four-bar's working stroke, 216 deg 53' in the seed; the four-bar gives
216.886 deg).  The carrier must rise monotonically (b_gamma >= 0); :func:`carrier_law` refuses a run-up
share for which it does not.  The idle stroke is not constrained by printing: the cam's return phase keeps
its own law.

:func:`runup_for_zone` chooses u: the largest run-up share (the smallest bed acceleration) whose uniform
segment still covers a printing zone given as shares of the bed stroke.

Invariants B (velocity peak), C1 (acceleration peak before the velocity peak, run-up) and C3 (after it,
run-out) are the seed's, bed_drives.md 2.2.1: each stroke normalised by its own duration and swing.
Pure numpy; no FMI import.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from . import fourbar, fourbar_synthesis
from .laws import Law

SEED_LINKAGE = (1.0, 1.91579, 2.10526, 2.25263)   # seed 004: O2A : AD : O2O5 : DO5
SEED_RATIO = 3.0                                  # z3 / z5 (seed: i_53^b = -3)
SEED_CARRIER_SWING = math.radians(40.0)           # gamma_Sigma (seed)
PI = math.pi


def bed_invariants(k, u, m=np):
    """(a, b, c) of the target bed law (module docstring) at phase share k, run-up share u."""
    w = PI / (2.0 * u)
    C = 1.0 / (2.0 / (w * w) + (1.0 - 2.0 * u) / w)
    V = C / w

    def rise(x):
        return C / (w * w) * (1.0 - m.cos(w * x)), V * m.sin(w * x), C * m.cos(w * x)

    if m is math:
        if k <= u:
            return rise(k)
        if k >= 1.0 - u:
            a, b, c = rise(1.0 - k)
            return 1.0 - a, b, -c
        return C / (w * w) + V * (k - u), V, 0.0
    k = np.asarray(k, dtype=float)
    a = C / (w * w) + V * (k - u)
    b = np.full_like(k, V)
    c = np.zeros_like(k)
    lo, hi = k <= u, k >= 1.0 - u
    ra, rb, rc = rise(np.where(lo, k, 0.0))
    fa, fb, fc = rise(np.where(hi, 1.0 - k, 0.0))
    a = np.where(lo, ra, np.where(hi, 1.0 - fa, a))
    b = np.where(lo, rb, np.where(hi, fb, b))
    c = np.where(lo, rc, np.where(hi, -fc, c))
    return a, b, c


def runup_for_zone(zone_start: float, zone_end: float) -> float:
    """Largest run-up share u whose uniform segment covers the printing zone [zone_start, zone_end] given as
    shares of the bed stroke (0 < zone_start < zone_end < 1): a_alpha(u) = 1 / (2 + (1 - 2u) pi / (2u))
    <= zone_start and the same for 1 - zone_end, i.e. u <= pi / (2 (1/f - 2 + pi))."""
    if not 0.0 < zone_start < zone_end < 1.0:
        raise ValueError(f"printing zone [{zone_start!r}, {zone_end!r}] of the bed stroke: allowed "
                         f"0 < start < end < 1")
    f = min(zone_start, 1.0 - zone_end)
    return PI / (2.0 * (1.0 / f - 2.0 + PI))


@dataclass(frozen=True)
class FourBarStroke:
    """The four-bar rocker over its working stroke: crank angle start, crank span, swing (rad, signed)."""
    a: float
    b: float
    f: float
    r: float
    branch: int
    start: float
    span: float
    swing: float
    psi0: float            # rocker angle at the stroke's start

    def invariants(self, k, m=np):
        """(a_delta, b_delta, c_delta) at phase share k."""
        phi = self.start + k * self.span
        if m is math:
            psi, v, acc, _ = fourbar.kinematics_scalar(phi, self.a, self.b, self.f, self.r, self.branch)
        else:
            psi, v, acc, _ = fourbar.kinematics(np.asarray(phi, dtype=float), self.a, self.b, self.f, self.r,
                                                self.branch)
        return ((psi - self.psi0) / self.swing, v * self.span / self.swing, acc * self.span ** 2 / self.swing)


@lru_cache(maxsize=16)
def working_stroke(linkage=SEED_LINKAGE, branch: int = 1) -> FourBarStroke:
    an = fourbar_synthesis.analyse(*linkage, branch=branch)
    a, b, f, r = 1.0, an.coupler, an.frame, an.rocker
    start, span = math.radians(an.working_start_deg), math.radians(an.working_stroke_deg)
    psi0 = float(fourbar.position(start, a, b, f, r, branch)[0])
    swing = float(fourbar.position(start + span, a, b, f, r, branch)[0]) - psi0
    return FourBarStroke(a, b, f, r, branch, start, span, swing, psi0)


@dataclass(frozen=True)
class CarrierLaw:
    """The synthesised carrier law (forward stroke) and the data it was made from."""
    law: Law
    runup: float           # u, bed run-up share of the working stroke
    ratio: float           # K = z3 / z5
    delta_swing: float     # rad, |four-bar rocker swing|
    gamma_swing: float     # rad, carrier swing
    alpha_swing: float     # rad, bed pinion swing K delta_S + (1 + K) gamma_S
    phase: float           # rad, crank angle of the working stroke (cam rise phase)


def carrier_law(runup: float, ratio: float = SEED_RATIO, gamma_swing: float = SEED_CARRIER_SWING,
                linkage=SEED_LINKAGE, branch: int = 1, check_points: int = 4001) -> CarrierLaw:
    """The carrier's forward-stroke law that makes alpha5 the uniform-zone bed law of run-up share ``runup``."""
    if not 0.0 < runup < 0.5:
        raise ValueError(f"bed run-up share runup = {runup!r}: allowed 0 < runup < 0.5")
    st = working_stroke(tuple(linkage), branch)
    dS = abs(st.swing)
    K = float(ratio)
    aS = K * dS + (1.0 + K) * gamma_swing
    wd, wa = K * dS / ((1.0 + K) * gamma_swing), aS / ((1.0 + K) * gamma_swing)

    def piece(k, m):
        ba, bb, bc = bed_invariants(k, runup, m)
        da, db, dc = st.invariants(k, m)
        return wa * ba - wd * da, wa * bb - wd * db, wa * bc - wd * dc

    law = Law("bed004", f"seed 004 carrier law for a uniform bed (run-up share {runup:g}, K = {K:g})",
              ((1.0, piece),), (("runup", runup),))
    k = np.linspace(0.0, 1.0, check_points)
    _, b, _ = law(k)
    if np.min(b) < -1e-12:
        bad = float(k[int(np.argmin(b))])
        raise ValueError(f"bed run-up share runup = {runup:g}: the carrier would turn back at k = {bad:.3f} "
                         f"(b_gamma = {float(np.min(b)):.3g} < 0); allowed: a run-up share that keeps b_gamma >= 0")
    return CarrierLaw(law, runup, K, dS, gamma_swing, aS, st.span)


def stroke_invariants(law: Law, n: int = 20001) -> dict:
    """B = max b, C1 = max |c| before the velocity peak (run-up), C3 = max |c| after it (run-out)."""
    k = np.linspace(0.0, 1.0, n)
    _, b, c = law(k)
    i = int(np.argmax(b))
    return {"B": float(b[i]), "C1": float(np.max(np.abs(c[: i + 1]))), "C3": float(np.max(np.abs(c[i:]))),
            "k_B": float(k[i])}


# --------------------------------------------------------------------------------------------------------------
# cam geometry for a maximum pressure angle (the disc cam of fmus.physics.cam_rocker, mechanism 1)
# --------------------------------------------------------------------------------------------------------------

SEED_R0_OVER_S = 0.95                              # r0 / S (seed; S read as the roller's arc, arm * swing)
SEED_PRESSURE_MAX = math.radians(28.0)             # the seed's maximum pressure angle


def max_pressure_angle(runup: float, cam_distance: float, follower_arm: float, base_radius: float,
                       law_return: int = 0, points: int = 721) -> float:
    """Largest pressure angle [rad] over a turn of the disc cam (CamRocker mechanism 1, its own geometry:
    fmus.physics.cam_rocker) driving the carrier by the bed004 law on the rise and law ``law_return`` (index
    of fmus.physics.laws.LAW_NAMES, default K0) on the return, seed phases and swing."""
    from .cam_rocker import CamRockerModel, CamRockerParams
    from .laws import LAW_NAMES

    p = CamRockerParams(mechanism=1, law=LAW_NAMES.index("bed004"), law_return=law_return, law_km=runup,
                        cam_distance=cam_distance, follower_arm=follower_arm, cam_base_radius=base_radius,
                        swing=SEED_CARRIER_SWING)
    p.check()
    m = CamRockerModel(p)
    return max(m.geometry(float(f))[0] for f in np.linspace(0.0, 2 * PI, points, endpoint=False))


@dataclass(frozen=True)
class CamDesign:
    follower_arm: float     # m
    cam_distance: float     # m
    base_radius: float      # m
    r0_over_S: float
    pressure_max: float     # rad
    best_at_seed_ratio: float   # rad: the smallest max pressure angle reachable with r0/S = 0.95


def _best_distance(runup, arm, r0, law_return):
    """(max pressure angle, cam distance) minimised over the admissible centre distance for arm and r0."""
    from scipy.optimize import minimize_scalar

    lo, hi = abs(arm - r0) * 1.0001, (arm + r0) * 0.9999

    def f(a):
        try:
            return max_pressure_angle(runup, a, arm, r0, law_return)
        except Exception:
            return PI
    grid = np.linspace(lo, hi, 25)
    vals = [f(a) for a in grid]
    i = int(np.argmin(vals))
    res = minimize_scalar(f, bounds=(grid[max(i - 1, 0)], grid[min(i + 1, 24)]), method="bounded",
                          options={"xatol": 1e-5 * arm})
    return (float(res.fun), float(res.x)) if res.fun <= vals[i] else (float(vals[i]), float(grid[i]))


def design_cam(runup: float, pressure_max: float = SEED_PRESSURE_MAX, arm: float = 0.1,
               r0_over_S: float = SEED_R0_OVER_S, law_return: int = 0) -> CamDesign:
    """Cam geometry for the bed004 carrier law whose largest pressure angle is at most ``pressure_max``.
    First the seed's r0/S with the centre distance that minimises the largest pressure angle; if that stays
    above the target, the smallest r0/S (bisection, to 1e-4) for which some centre distance meets it."""
    S = arm * SEED_CARRIER_SWING
    best, a = _best_distance(runup, arm, r0_over_S * S, law_return)
    if best <= pressure_max:
        return CamDesign(arm, a, r0_over_S * S, r0_over_S, best, best)
    lo, hi = r0_over_S, 4.0 * r0_over_S
    th_hi, a_hi = _best_distance(runup, arm, hi * S, law_return)
    if th_hi > pressure_max:
        raise ValueError(f"no cam with r0/S <= {hi:g} keeps the pressure angle below "
                         f"{math.degrees(pressure_max):g} deg (best {math.degrees(th_hi):.2f} deg)")
    while hi - lo > 1e-4:
        mid = 0.5 * (lo + hi)
        th, am = _best_distance(runup, arm, mid * S, law_return)
        if th <= pressure_max:
            hi, th_hi, a_hi = mid, th, am
        else:
            lo = mid
    return CamDesign(arm, a_hi, hi * S, hi, th_hi, best)


def pitch_curvature_min(runup: float, cam_distance: float, follower_arm: float, base_radius: float,
                        law_return: int = 0, points: int = 7200) -> float:
    """Smallest radius of curvature [m] of the cam's pitch curve (the roller centre seen from the turning
    cam; CamRocker mechanism 1: roller centre (a - l cos psi, l sin psi), psi = psi0 + G(phi), the cam turning
    counter-clockwise at phi), from closed-form derivatives of G: the value of smallest magnitude, positive on
    a convex stretch (the base circle has +r0), negative on a concave one.  The
    seed's r_min/S compares it with the stroke S = arm * swing (the roller radius is not given, so the
    working profile's curvature, pitch radius minus roller radius on the convex side, is not computed)."""
    from .cam_rocker import CamRockerModel, CamRockerParams
    from .laws import LAW_NAMES

    p = CamRockerParams(mechanism=1, law=LAW_NAMES.index("bed004"), law_return=law_return, law_km=runup,
                        cam_distance=cam_distance, follower_arm=follower_arm, cam_base_radius=base_radius,
                        swing=SEED_CARRIER_SWING)
    p.check()
    m = CamRockerModel(p)
    phi = np.linspace(0.0, 2 * PI, points, endpoint=False)
    G = np.array([m.kinematics(float(f)) for f in phi])
    a, l, psi0 = cam_distance, follower_arm, m.psi0
    psi, d1, d2 = psi0 + G[:, 0], G[:, 1], G[:, 2]
    # fixed frame: C = (a - l cos psi, l sin psi); cam frame: X = R(-phi) C
    cx, cy = a - l * np.cos(psi), l * np.sin(psi)
    cx1, cy1 = l * np.sin(psi) * d1, l * np.cos(psi) * d1
    cx2 = l * (np.cos(psi) * d1 ** 2 + np.sin(psi) * d2)
    cy2 = l * (-np.sin(psi) * d1 ** 2 + np.cos(psi) * d2)
    c, s = np.cos(phi), np.sin(phi)
    # X = (c cx + s cy, -s cx + c cy); derivatives by the product rule
    x1 = c * cx1 + s * cy1 + (-s * cx + c * cy)
    y1 = -s * cx1 + c * cy1 + (-c * cx - s * cy)
    x2 = c * cx2 + s * cy2 + 2 * (-s * cx1 + c * cy1) + (-c * cx - s * cy)
    y2 = -s * cx2 + c * cy2 + 2 * (-c * cx1 - s * cy1) + (s * cx - c * cy)
    # the cam turns counter-clockwise, so its pitch curve is traversed clockwise: convex = negative signed
    # curvature; the sign is flipped so that the base circle has +r0
    k = -(x1 * y2 - y1 * x2) / np.hypot(x1, y1) ** 3
    rho = 1.0 / k
    i = int(np.argmin(np.abs(rho)))
    return float(rho[i])
