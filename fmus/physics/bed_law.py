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
half-wave c = sin(pi k / u), which starts and ends at c = 0: the four-bar's rocker reaches and leaves its
extreme positions with a finite acceleration (on the seed's branch, SEED_BRANCH, 3.1 at the working stroke's
start and 12.9 at its end), so K delta moves as (1 - k)^2 near the stroke's end, faster than a bed law whose
acceleration ends at zero ((1 - k)^3); the carrier would have to turn back (measured: b_gamma < 0 near
k = 0.95 for every run-up share 0.1-0.4; near k = 0.06 on the other branch).  The carrier's forward stroke is then

    a_gamma(k) = [alpha_S a_alpha(k) - K delta_S a_delta(k)] / ((1 + K) gamma_S),
    alpha_S = K delta_S + (1 + K) gamma_S,

with a_delta the four-bar rocker's invariant over its working stroke, and the same for b and c (the phase
of the cam rise equals the four-bar's working stroke, 216 deg 53' in the seed; the four-bar gives
216.886 deg).  The carrier must rise monotonically (b_gamma >= 0); :func:`carrier_law` refuses a run-up
share for which it does not.  The idle stroke is not constrained by printing: the seed's bed returns by a harmonic law (accelerated, no printing), and the carrier's return
law follows from it and the four-bar's idle stroke as the rise does (:func:`carrier_return_law`, law
``bed004r``).

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
from .mathns import SCALAR, namespace
from .motion_law import Law

SEED_LINKAGE = (1.0, 1.91579, 2.10526, 2.25263)   # seed 004: O2A : AD : O2O5 : DO5
SEED_RATIO = 3.0                                  # z3 / z5 (seed: i_53^b = -3)
SEED_CARRIER_SWING = math.radians(40.0)           # gamma_Sigma (seed)
# The seed's assembly branch of the four-bar for a crank turning counter-clockwise (fmus.physics.fourbar's
# sign(cross(D - O5, A - O5)) = branch).  The seed's working stroke has the small peak of the rocker's
# acceleration at its run-up and the large one at its run-out (its Fig. 2 as read from the text; our copy has
# no figures): branch -1 gives C_delta_px1 = 3.113 < C_delta_px3 = 12.884, branch +1 the mirror image
# (12.884 > 3.113).  The two branches are mirror images of one linkage: branch -1 turning counter-clockwise
# is branch +1 turning clockwise, i.e. every stroke run backwards in time (B kept, C1 and C3 exchanged).
SEED_BRANCH = -1
PI = math.pi


def bed_invariants(k, u, m=np):
    """(a, b, c) of the target bed law (module docstring) at phase share k, run-up share u."""
    w = PI / (2.0 * u)
    C = 1.0 / (2.0 / (w * w) + (1.0 - 2.0 * u) / w)
    V = C / w

    def rise(x):
        return C / (w * w) * (1.0 - m.cos(w * x)), V * m.sin(w * x), C * m.cos(w * x)

    m = m if m is SCALAR else namespace(m)
    if m.scalar:
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


def bed_invariants_jerk(k: float, u: float) -> float:
    """dc/dk of :func:`bed_invariants` at one k (its c differentiated once more): -C w sin(w k) on the run-up,
    the mirror's -C w sin(w (1 - k)) on the run-out, 0 on the uniform segment (the same segments)."""
    w = PI / (2.0 * u)
    C = 1.0 / (2.0 / (w * w) + (1.0 - 2.0 * u) / w)
    if k <= u:
        return -C * w * math.sin(w * k)
    if k >= 1.0 - u:
        return -C * w * math.sin(w * (1.0 - k))
    return 0.0


def runup_for_zone(zone_start: float, zone_end: float) -> float:
    """Largest run-up share u whose uniform segment covers the printing zone [zone_start, zone_end] given as
    shares of the bed stroke (0 < zone_start < zone_end < 1): a_alpha(u) = 1 / (2 + (1 - 2u) pi / (2u))
    <= zone_start and the same for 1 - zone_end, i.e. u <= pi / (2 (1/f - 2 + pi))."""
    if not 0.0 < zone_start < zone_end < 1.0:
        raise ValueError(f"printing zone [{zone_start!r}, {zone_end!r}] of the bed stroke: allowed "
                         f"0 < start < end < 1")
    f = min(zone_start, 1.0 - zone_end)
    return PI / (2.0 * (1.0 / f - 2.0 + PI))


def equal_peak_runup(time_ratio: float) -> float:
    """Run-up share u for which the bed's whole cycle has equal acceleration peaks: the working stroke's quarter
    waves (peak C(u) / T_px^2 at the extreme positions) join the idle stroke's harmonic half-wave (peak
    (pi^2 / 2) / T_xx^2) with no jump, C(u) = (pi^2 / 2) (K_px / (1 - K_px))^2.  One reading of the seed's
    "conjugate harmonics with equal peaks" over the whole cycle; it fixes u by K_px alone (0.1564 for the
    seed's four-bar), but then a larger K_px gives a longer uniform segment, against the seed's statement that
    raising K_px shortens it, so bed_drive does not use it (docs/seeds.md)."""
    from scipy.optimize import brentq
    if not 0.0 < time_ratio < 1.0:
        raise ValueError(f"time ratio K_px = {time_ratio!r}: allowed 0 < K_px < 1")
    target = PI * PI / 2.0 * (time_ratio / (1.0 - time_ratio)) ** 2

    def peak(u):
        w = PI / (2.0 * u)
        return 1.0 / (2.0 / (w * w) + (1.0 - 2.0 * u) / w)
    lo, hi = 1e-6, 0.5 - 1e-12
    if not peak(hi) <= target <= peak(lo):
        raise ValueError(f"time ratio K_px = {time_ratio!r}: no run-up share in (0, 0.5) gives equal peaks")
    return brentq(lambda u: peak(u) - target, lo, hi, xtol=1e-15)


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
        """(a_delta, b_delta, c_delta) at phase share k (``m``: the namespace, mathns.namespace)."""
        m = m if m is SCALAR else namespace(m)
        phi = self.start + k * self.span
        psi, v, acc, _ = fourbar.kinematics(phi if m.scalar else np.asarray(phi, dtype=float), self.a, self.b,
                                            self.f, self.r, self.branch, m, mu=False)
        return ((psi - self.psi0) / self.swing, v * self.span / self.swing, acc * self.span ** 2 / self.swing)

    def jerk(self, k: float) -> float:
        """dc_delta/dk at one k: the rocker's j = d3psi/dphi3 from the loop closure a e^(i phi) + b e^(i th) =
        f + r e^(i psi) differentiated three times (real part after multiplying by e^(-i th)):
        j = v^3 + (3 r v acc cos(th - psi) - a sin(th - phi) - 3 b vc acc_c) / (r sin(th - psi)), with the
        coupler's vc = a sin(psi - phi) / (b sin(th - psi)) and acc_c = (r acc cos(th - psi) + r v^2 sin(th - psi)
        - a sin(th - phi)) / b (the imaginary part of the second derivative); psi, v, acc are kinematics'
        and th fourbar.position's (fourbar.py gives no third derivative)."""
        a, b, r = self.a, self.b, self.r
        phi = self.start + k * self.span
        psi, v, acc, _ = fourbar.kinematics(phi, a, b, self.f, r, self.branch, SCALAR, mu=False)
        th = float(fourbar.position(phi, a, b, self.f, r, self.branch)[1])
        s_cr, c_cr, s_ta = math.sin(th - psi), math.cos(th - psi), math.sin(th - phi)
        vc = a * math.sin(psi - phi) / (b * s_cr)
        acc_c = (r * acc * c_cr + r * v * v * s_cr - a * s_ta) / b
        jerk = v ** 3 + (3.0 * r * v * acc * c_cr - a * s_ta - 3.0 * b * vc * acc_c) / (r * s_cr)
        return jerk * self.span ** 3 / self.swing


@lru_cache(maxsize=16)
def working_stroke(linkage=SEED_LINKAGE, branch: int = SEED_BRANCH) -> FourBarStroke:
    """The four-bar rocker over its working stroke (the slower one), crank turning counter-clockwise."""
    return _stroke(linkage, branch, idle=False)


@lru_cache(maxsize=16)
def idle_stroke(linkage=SEED_LINKAGE, branch: int = SEED_BRANCH) -> FourBarStroke:
    """The four-bar rocker over its idle (return) stroke; its invariants a run 0 -> 1 as the rocker returns."""
    return _stroke(linkage, branch, idle=True)


def _stroke(linkage, branch, idle):
    an = fourbar_synthesis.stroke_angles(*linkage, branch=branch)
    a, b, f, r = 1.0, an.coupler, an.frame, an.rocker
    start = math.radians(an.idle_start_deg if idle else an.working_start_deg)
    span = math.radians(an.idle_stroke_deg if idle else an.working_stroke_deg)
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
                linkage=SEED_LINKAGE, branch: int = SEED_BRANCH, check_points: int = 4001) -> CarrierLaw:
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

    def piece_jerk(k, m):
        return wa * bed_invariants_jerk(k, runup) - wd * st.jerk(k)

    law = Law("bed004", f"seed 004 carrier law for a uniform bed (run-up share {runup:g}, K = {K:g})",
              ((1.0, piece),), (("runup", runup),), (piece_jerk,))
    k = np.linspace(0.0, 1.0, check_points)
    _, b, _ = law(k)
    if np.min(b) < -1e-12:
        bad = float(k[int(np.argmin(b))])
        raise ValueError(f"bed run-up share runup = {runup:g}: the carrier would turn back at k = {bad:.3f} "
                         f"(b_gamma = {float(np.min(b)):.3g} < 0); allowed: a run-up share that keeps b_gamma >= 0")
    return CarrierLaw(law, runup, K, dS, gamma_swing, aS, st.span)


def bed_idle_invariants(k, m=np):
    """(a, b, c) of the bed's idle stroke at phase share k (a: share of the return travelled): the harmonic law
    K0, c = (pi^2 / 2) cos(pi k).  The seed (after Tyurin, bed_drives.md 1.2) asks of the idle stroke only that
    it be accelerated and that the acceleration diagram be made of harmonic segments; nothing is printed there
    (no uniform segment), so the stroke is one harmonic half-wave, the K0 law, run in the idle stroke's time."""
    return (1.0 - m.cos(PI * k)) / 2.0, PI / 2.0 * m.sin(PI * k), PI * PI / 2.0 * m.cos(PI * k)


def carrier_return_law(ratio: float = SEED_RATIO, gamma_swing: float = SEED_CARRIER_SWING, linkage=SEED_LINKAGE,
                       branch: int = SEED_BRANCH, check_points: int = 4001) -> Law:
    """The carrier's idle-stroke (cam return) law that, summed with the four-bar's idle stroke through the
    differential, returns the bed by the harmonic law of :func:`bed_idle_invariants`:

        a_gamma(k) = [alpha_S a_alpha(k) - K delta_S a_delta(k)] / ((1 + K) gamma_S)

    over the idle stroke (k = its phase share, a = the share of each return travelled; the cam's return phase
    equals the four-bar's idle stroke, 143 deg 07' in the seed).  The seed's Fig. 2 adds the carrier's
    velocity to the four-bar's over the whole cycle to make the bed's law, so the carrier's return follows from
    the bed's idle law as its rise does from the working stroke's; the former return law, the harmonic K0 on
    the carrier itself, gave the bed a return that is neither harmonic nor the seed's.  Raises ValueError if
    the carrier would turn back (b_gamma < 0)."""
    st = idle_stroke(tuple(linkage), branch)
    dS, K = abs(st.swing), float(ratio)
    aS = K * dS + (1.0 + K) * gamma_swing
    wd, wa = K * dS / ((1.0 + K) * gamma_swing), aS / ((1.0 + K) * gamma_swing)

    def piece(k, m):
        ba, bb, bc = bed_idle_invariants(k, m)
        da, db, dc = st.invariants(k, m)
        return wa * ba - wd * da, wa * bb - wd * db, wa * bc - wd * dc

    def piece_jerk(k, m):
        return wa * (-PI ** 3 / 2.0) * math.sin(PI * k) - wd * st.jerk(k)     # bed_idle_invariants' c, differentiated

    law = Law("bed004r", f"seed 004 carrier return law for a harmonic bed return (K = {K:g})", ((1.0, piece),),
              (), (piece_jerk,))
    k = np.linspace(0.0, 1.0, check_points)
    _, b, _ = law(k)
    if np.min(b) < -1e-9:
        raise ValueError(f"the carrier would turn back on its return at k = {float(k[int(np.argmin(b))]):.3f} "
                         f"(b_gamma = {float(np.min(b)):.3g} < 0) with this four-bar and ratio")
    return law


def stroke_invariants(law: Law, n: int = 20001) -> dict:
    """B = max b, C1 = max |c| before the velocity peak (run-up), C3 = max |c| after it (run-out)."""
    k = np.linspace(0.0, 1.0, n)
    _, b, c = law(k)
    i = int(np.argmax(b))
    return {"B": float(b[i]), "C1": float(np.max(np.abs(c[: i + 1]))), "C3": float(np.max(np.abs(c[i:]))),
            "k_B": float(k[i])}
