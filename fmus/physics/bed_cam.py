"""Seed 004's disc cam for the carrier law of fmus.physics.bed_law: its largest pressure angle, the geometry
that keeps it below a limit (the seed's 28 deg with r0/S = 0.95) and the smallest radius of curvature of its
pitch curve.  The cam is CamRocker's mechanism 1 (fmus.physics.cam_rocker) driven by the bed004 law of the
registry (fmus.physics.laws).

Apart from bed_law because it needs the cam model and the registry, which themselves need bed_law's carrier
law: in one module they made the import circle laws -> bed_law -> cam_rocker -> laws.
Pure numpy/scipy; no FMI import.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .bed_law import PI, SEED_CARRIER_SWING
from .cam_rocker import CamRockerModel, CamRockerParams
from .laws import LAW_NAMES

SEED_R0_OVER_S = 0.95                              # r0 / S (seed; S read as the roller's arc, arm * swing)
SEED_PRESSURE_MAX = math.radians(28.0)             # the seed's maximum pressure angle
SEED_RETURN = LAW_NAMES.index("bed004r")           # the carrier's return law for the seed's harmonic bed return


def max_pressure_angle(runup: float, cam_distance: float, follower_arm: float, base_radius: float,
                       law_return: int = SEED_RETURN, points: int = 721) -> float:
    """Largest pressure angle [rad] over a turn of the disc cam (CamRocker mechanism 1, its own geometry:
    fmus.physics.cam_rocker) driving the carrier by the bed004 law on the rise and law ``law_return`` (index
    of fmus.physics.laws.LAW_NAMES, default K0) on the return, seed phases and swing."""
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

    @property
    def roller_radius(self) -> float:
        """Roller radius [m] that makes the seed's r0/S hold for the working profile: the seed's r0 read as the
        smallest radius vector of the cam's profile, the pitch curve's base radius less the roller's (the seed
        gives no roller).  0 when the seed's ratio already holds on the pitch curve."""
        return max(0.0, self.base_radius - SEED_R0_OVER_S * self.follower_arm * SEED_CARRIER_SWING)


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
               r0_over_S: float = SEED_R0_OVER_S, law_return: int = SEED_RETURN) -> CamDesign:
    """Cam geometry for the bed004 carrier law (return law ``law_return``, default the seed's bed004r) whose
    largest pressure angle is at most ``pressure_max``.  First the seed's r0/S with the centre distance that
    minimises the largest pressure angle; if that stays above the target, the smallest r0/S of the pitch curve
    (bisection, to 1e-4) for which some centre distance meets it.  Both of the seed's numbers then hold with
    r0 read as the working profile's radius vector and the roller of :attr:`CamDesign.roller_radius`."""
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
                        law_return: int = SEED_RETURN, points: int = 7200) -> float:
    """Smallest radius of curvature [m] of the cam's pitch curve (the roller centre seen from the turning
    cam; CamRocker mechanism 1: roller centre (a - l cos psi, l sin psi), psi = psi0 + G(phi), the cam turning
    counter-clockwise at phi), from closed-form derivatives of G: the value of smallest magnitude, positive on
    a convex stretch (the base circle has +r0), negative on a concave one.  The
    seed's r_min/S compares it with the stroke S = arm * swing (the roller radius is not given, so the
    working profile's curvature, pitch radius minus roller radius on the convex side, is not computed)."""
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
