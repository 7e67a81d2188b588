"""Synthesis and analysis of the bed-drive crank-rocker four-bar of seed 004 (/work/shared/specs/bed_drives.md
section 2.2.2): the kinematic quality of a crank-rocker (:func:`analyse`: time ratio, swing, transmission
angles, stroke shares) and the linkage with the largest time ratio for a given swing and transmission-angle
limit (:func:`synthesise`).  The closed-form kinematics it uses are those of :mod:`fmus.physics.fourbar`.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from .base import ParameterError
from .fourbar import check_crank_rocker, kinematics, min_transmission, position


@dataclass(frozen=True)
class FourBarAnalysis:
    """Kinematic quality of a crank-rocker (crank = 1, crank turning counter-clockwise at constant speed).

    time_ratio: K_px, the working stroke's share of the cycle (working = the slower stroke, the crank turns
    through pi + theta); velocity_peak_*: B = peak of b = dpsi/dtau / psi_Sigma with tau = t / T_stroke, i.e.
    the peak rocker speed over the stroke's mean speed; accel_runup_* (C1) and accel_runout_* (C3): peaks of
    |c| = |d2psi/dtau2| / psi_Sigma before and after the velocity peak (seed 004 / spec 2.2.1 normalisation,
    each stroke by its own duration and swing).  Angles in degrees.
    """
    crank: float
    coupler: float
    frame: float
    rocker: float
    time_ratio: float
    swing_deg: float
    min_transmission_deg: float
    working_stroke_deg: float
    idle_stroke_deg: float
    velocity_peak_working: float
    velocity_peak_idle: float
    accel_runup_working: float
    accel_runout_working: float
    accel_runup_idle: float
    accel_runout_idle: float
    working_start_deg: float   # crank angle at the start of the working stroke
    idle_start_deg: float      # crank angle at the start of the idle stroke
    branch: int

    def as_dict(self) -> dict:
        return asdict(self)


def extreme_crank_angles(a, b, f, r, branch=1) -> tuple[float, float]:
    """Crank angles [rad, in [0, 2pi), ascending] of the two extreme rocker positions.

    The rocker stops (dpsi/dphi = 0) where crank and coupler are collinear: stretched out, the rocker pin D lies
    at (a + b) along the crank, folded at (b - a) opposite it.  The triangle O2-D-O5 then has sides
    (b +- a), f and r, so the cosine law gives the angle of O2->D from the frame line up to its sign; the sign is
    the one whose D lies on the assembly ``branch`` (sign(cross(D - O5, A - O5)) = branch, fmus.physics.fourbar).
    """
    angles = []
    for reach, turn in ((b + a, 0.0), (b - a, np.pi)):      # |O2 D| and the angle from O2->D to the crank
        c = (reach * reach + f * f - r * r) / (2.0 * reach * f)
        if not -1.0 <= c <= 1.0:
            raise ValueError(f"no extreme rocker position with a {reach!r} reach from the crank pivot "
                             f"(cos = {c!r}): not a crank-rocker")
        for side in (1.0, -1.0):
            theta = side * math.acos(c)                       # angle of O2->D
            d = (reach * math.cos(theta), reach * math.sin(theta))
            phi = theta - turn
            pin = (a * math.cos(phi), a * math.sin(phi))
            cross = (d[0] - f) * (pin[1]) - d[1] * (pin[0] - f)
            if cross * branch > 0.0:
                angles.append(phi % (2 * np.pi))
                break
    if len(angles) != 2:
        raise ValueError(f"expected two extreme rocker positions on branch {branch}, found {len(angles)}")
    return min(angles), max(angles)


def _peak(fun, lo, hi, n=2001):
    """Maximum of a smooth scalar function on [lo, hi]: dense sampling refined by a bounded search."""
    from scipy.optimize import minimize_scalar
    grid = np.linspace(lo, hi, n)
    vals = fun(grid)
    k = int(np.argmax(vals))
    a_, b_ = grid[max(k - 1, 0)], grid[min(k + 1, n - 1)]
    res = minimize_scalar(lambda s: -float(fun(s)), bounds=(a_, b_), method="bounded",
                          options={"xatol": 1e-12 * (hi - lo)})
    if -res.fun >= vals[k]:
        return float(res.x), float(-res.fun)
    return float(grid[k]), float(vals[k])


def _stroke(a, b, f, r, branch, start, span):
    """(swing [rad, signed], B, C1, C3) of the stroke starting at crank angle start, crank span span."""
    psi0 = float(position(start, a, b, f, r, branch)[0])
    swing = float(position(start + span, a, b, f, r, branch)[0]) - psi0

    def bee(tau):
        return kinematics(start + tau * span, a, b, f, r, branch)[1] * span / swing

    def cee(tau):
        return np.abs(kinematics(start + tau * span, a, b, f, r, branch)[2] * span * span / swing)

    tau_b, big_b = _peak(bee, 0.0, 1.0)
    c1 = _peak(cee, 0.0, tau_b)[1]
    c3 = _peak(cee, tau_b, 1.0)[1]
    return swing, big_b, c1, c3


@dataclass(frozen=True)
class StrokeAngles:
    """Where the strokes of a crank-rocker lie (crank = 1, turning counter-clockwise): :class:`FourBarAnalysis`'s
    fields of the same names, without its motion invariants (which need ``scipy.optimize``)."""
    coupler: float
    frame: float
    rocker: float
    working_stroke_deg: float
    idle_stroke_deg: float
    working_start_deg: float
    idle_start_deg: float


def _strokes(crank, coupler, frame, rocker, branch):
    """(a, b, f, r) scaled to crank = 1 and the strokes' (working start, working span, idle start, idle span) [rad]."""
    names = ("crank", "coupler", "frame", "rocker")
    check_crank_rocker(crank, coupler, frame, rocker, names)
    if branch not in (-1, 1):
        raise ParameterError("branch", branch, "must be +1 or -1")
    a, b, f, r = 1.0, coupler / crank, frame / crank, rocker / crank
    e1, e2 = extreme_crank_angles(a, b, f, r, branch)
    span1 = (e2 - e1) % (2 * np.pi)
    if span1 >= np.pi:
        w_start, w_span, i_start = e1, span1, e2
    else:
        w_start, w_span, i_start = e2, 2 * np.pi - span1, e1
    return (a, b, f, r), (w_start, w_span, i_start, 2 * np.pi - w_span)


def stroke_angles(crank: float, coupler: float, frame: float, rocker: float, branch: int = 1) -> StrokeAngles:
    """The strokes of :func:`analyse` (the same floats) without the motion invariants."""
    (_a, b, f, r), (w_start, w_span, i_start, i_span) = _strokes(crank, coupler, frame, rocker, branch)
    deg = math.degrees
    return StrokeAngles(coupler=b, frame=f, rocker=r, working_stroke_deg=deg(w_span), idle_stroke_deg=deg(i_span),
                        working_start_deg=deg(w_start) % 360.0, idle_start_deg=deg(i_start) % 360.0)


def analyse(crank: float, coupler: float, frame: float, rocker: float, branch: int = 1) -> FourBarAnalysis:
    """Time ratio, swing, transmission and the motion invariants B, C1, C3 of both strokes.

    The link lengths are scaled to crank = 1.  The crank turns counter-clockwise; the working stroke is the
    slower one (the larger crank angle between the extreme rocker positions).  Raises ParameterError for a
    linkage that is not a Grashof crank-rocker.
    """
    (a, b, f, r), (w_start, w_span, i_start, i_span) = _strokes(crank, coupler, frame, rocker, branch)
    sw_w, bw, c1w, c3w = _stroke(a, b, f, r, branch, w_start, w_span)
    _, bi, c1i, c3i = _stroke(a, b, f, r, branch, i_start, i_span)
    deg = math.degrees
    return FourBarAnalysis(
        crank=1.0, coupler=b, frame=f, rocker=r, time_ratio=w_span / (2 * np.pi), swing_deg=abs(deg(sw_w)),
        min_transmission_deg=deg(min_transmission(a, b, f, r)), working_stroke_deg=deg(w_span),
        idle_stroke_deg=deg(i_span), velocity_peak_working=bw, velocity_peak_idle=bi,
        accel_runup_working=c1w, accel_runout_working=c3w, accel_runup_idle=c1i, accel_runout_idle=c3i,
        working_start_deg=deg(w_start) % 360.0, idle_start_deg=deg(i_start) % 360.0, branch=branch)


def _family(swing: float, theta: float, s):
    """Crank-rockers with rocker swing ``swing`` and extreme crank angles pi +/- theta (classical synthesis
    from two extreme positions): O5 at the origin, rocker = 1, extreme pins D1, D2 on the unit circle; the
    crank pivot O2 lies on a circle through D1, D2 from which the chord D1D2 is seen under theta (both
    circles, index by the sign of s: s in (0, 1) one circle, (-1, 0) the other; |s| runs along the arc).
    Returns arrays (a, b, f, r=1) (nan where the point gives no crank-rocker)."""
    s = np.atleast_1d(np.asarray(s, dtype=float))
    h, m = math.sin(swing / 2), math.cos(swing / 2)
    radius = h / math.sin(theta)
    sigma = np.where(s >= 0.0, 1.0, -1.0)
    cy = m + sigma * radius * math.cos(theta)
    # arc on the centre side of the chord: angle about the centre from -(pi - theta) .. +(pi - theta)
    # measured from the direction "away from the chord" (sigma * y)
    ang = (2.0 * np.abs(s) - 1.0) * (np.pi - theta)
    ox = radius * np.sin(ang)
    oy = cy + sigma * radius * np.cos(ang)
    d1 = np.hypot(ox + h, oy - m)
    d2 = np.hypot(ox - h, oy - m)
    a = 0.5 * np.abs(d1 - d2)
    b = 0.5 * (d1 + d2)
    f = np.hypot(ox, oy)
    # both extremes must belong to one assembly branch: sign(cross(D - O5, A - O5)) equal at D1 and D2
    # (D farther from O2 = extended, A between O2 and D; nearer = folded, A beyond O2)
    far1 = d1 >= d2
    with np.errstate(invalid="ignore", divide="ignore"):
        sgn1 = np.where(far1, 1.0, -1.0)
        ax1, ay1 = ox + sgn1 * a * (-h - ox) / d1, oy + sgn1 * a * (m - oy) / d1
        ax2, ay2 = ox - sgn1 * a * (h - ox) / d2, oy - sgn1 * a * (m - oy) / d2
        c1 = -h * ay1 - m * ax1
        c2 = h * ay2 - m * ax2
    bad = ~(c1 * c2 > 0.0)
    a = np.where(bad, np.nan, a)
    return a, b, f, np.ones_like(a)


def _best_transmission(swing, theta, n=721):
    """max over the family of min_transmission (crank-rockers only) and the maximising parameter s."""
    from scipy.optimize import minimize_scalar

    def mu_of(s):
        a, b, f, r = _family(swing, theta, s)
        out = np.full(a.shape, -1.0)
        for k in range(a.size):
            ak, bk, fk = a[k], b[k], f[k]
            if not (ak > 1e-9 and ak < min(bk, fk, 1.0)):
                continue
            longest = max(bk, fk, 1.0)
            if not ak + longest < bk + fk + 1.0 - longest:
                continue
            out[k] = min_transmission(ak, bk, fk, 1.0)
        return out

    best = (-1.0, None)
    for lo, hi in ((1e-6, 1.0 - 1e-6), (-1.0 + 1e-6, -1e-6)):
        grid = np.linspace(lo, hi, n)
        vals = mu_of(grid)
        k = int(np.argmax(vals))
        if vals[k] < 0.0:
            continue
        a_, b_ = grid[max(k - 1, 0)], grid[min(k + 1, n - 1)]
        res = minimize_scalar(lambda s: -float(mu_of(s)[0]), bounds=(a_, b_), method="bounded",
                              options={"xatol": 1e-13})
        val, sx = (-res.fun, res.x) if -res.fun >= vals[k] else (vals[k], grid[k])
        if val > best[0]:
            best = (float(val), float(sx))
    return best


def synthesise(swing_deg: float, min_transmission_deg: float, branch: int = 1) -> FourBarAnalysis:
    """Crank-rocker (crank = 1) by the two extreme positions with the largest time ratio the limit allows.

    Exact formulation (ambiguity 17 of the spec; the source gives no algorithm):
        maximise theta (K_px = (pi + theta) / (2 pi))
        subject to  rocker swing = swing_deg  and  min over the crank turn of min(mu, 180 - mu) >= limit.
    The swing is met exactly by construction (:func:`_family`: for a given theta the crank pivot lies on the
    circle through the two extreme rocker-pin positions); for each theta the best transmission angle over that
    one-parameter family, M(theta), is found by dense sampling and a bounded search; M decreases with theta
    and the answer is the root of M(theta) = limit (Brent).  For swing 60 deg, limit 30 deg this gives
    coupler 1.9518, frame 2.1229, rocker 2.2458, K_px = 0.5986, against the published 1.91579, 2.10526,
    2.25263 (within 1.9 %, 0.8 %, 0.3 %); the published linkage has min transmission 29.35 deg, i.e. it
    slightly violates the stated 30 deg (a graphical design: 19 : 36.4 : 40 : 42.8 mm), so no strict
    formulation can return it exactly.
    The lengths do not depend on the assembly branch; ``branch`` only orients the invariants of the result
    (branch -1 is the mirror image: every stroke run backwards, C1 and C3 exchanged; seed 004's is -1,
    fmus.physics.bed_law.SEED_BRANCH).
    Raises ParameterError if the inputs are out of range or no crank-rocker meets them.
    """
    from scipy.optimize import brentq
    if branch not in (-1, 1):
        raise ParameterError("branch", branch, "must be +1 or -1")
    if not 0.0 < swing_deg < 180.0:
        raise ParameterError("swing", swing_deg, "must be in (0, 180) deg")
    if not 0.0 < min_transmission_deg < 90.0:
        raise ParameterError("min_transmission", min_transmission_deg, "must be in (0, 90) deg")
    swing, lim = math.radians(swing_deg), math.radians(min_transmission_deg)

    def excess(theta):
        return _best_transmission(swing, theta)[0] - lim

    thetas = np.linspace(1e-4, math.pi / 2 - 1e-3, 60)
    vals = [excess(t) for t in thetas]
    if vals[0] < 0.0:
        raise ParameterError("min_transmission", min_transmission_deg,
                             f"no crank-rocker with swing {swing_deg:g} deg reaches this transmission angle")
    k = next((i for i, v in enumerate(vals) if v < 0.0), None)
    if k is None:
        raise ParameterError("min_transmission", min_transmission_deg,
                             "the limit does not bound the time ratio (theta reaches 90 deg)")
    theta = brentq(excess, thetas[k - 1], thetas[k], xtol=1e-13)
    s = _best_transmission(swing, theta)[1]
    a, b, f, r = (float(v[0]) for v in _family(swing, theta, s))
    return analyse(1.0, b / a, f / a, r / a, branch=branch)
