"""Centroid-profile (groove) synthesis of the lever cam-slotted-link mechanism (LCSM), feeder.md §2.3-2.4.

Frame F2: origin at the kulisa pivot O2, x-axis from the crank pivot O1 to O2 (O1 = (-L, 0)), angles
counter-clockwise; the crank turns counter-clockwise (phi increasing).  All lengths are divided by the crank
radius r: lambda1 = L/r, lambda2 = conrod/r, lambda3 = rocker (kulisa) length of the base four-bar / r.
For every crank angle phi the kulisa must stand at the prescribed angle gamma_b(phi); the stone pin B lies on
the kulisa ray and at distance lambda2 from the crank pin A = (-lambda1 + cos phi, sin phi):

  (K6)  N = lambda1 sin g + sin(phi - g)       (signed distance of A from the kulisa line)
        mu = arcsin(N / lambda2)                (angle between conrod and slot); existence: |N| <= lambda2
  (K7)  delta1 = g - mu
  (K8)  rho_i = cos(phi - g) - lambda1 cos g + lambda2 cos mu    (singularity-free form, cos mu >= 0)
  (K9)  rho = r rho_i,  B = rho (cos g, sin g).

Derivatives with respect to phi are closed forms (chain rule with g' = dgamma/dphi, g'' from the law), so the
curvature, cusp and pressure-angle checks need no numerical differentiation:
  Q = lambda2 cos mu = sqrt(lambda2^2 - N^2), Q' = -N N'/Q, Q'' = -(N'^2 + N N'')/Q - N^2 N'^2/Q^3,
  B' = rho' u + rho g' n,  B'' = (rho'' - rho g'^2) u + (2 rho' g' + rho g'') n   (u along the slot, n = u rotated +90 deg).

Choices where the spec is open (documented in fmus/docs/cam_rocker/index.md as well):
* Reference geometry: the kulisa law takes the swing and the extreme positions of the BASE four-bar of the same
  lambda1, lambda2, lambda3 (crank 1, conrod lambda2, frame lambda1, rocker lambda3; :func:`base_design`).
  The forward stroke starts at its folded dead centre (crank and conrod overlapping) and ends at the extended
  one; the phase angles are its forward/return crank angles, each shortened by half the dwell, which is
  centred on the extended dead centre.  So for the base four-bar's own law the groove is the circle
  rho = lambda3 (the spec's check), and (K6)/(K8) decide which lambda2 admit a kinematic connection.
* Assembly mode: ``assembly = +1`` takes the "+" sign of gamma_b = atan2(A) +/- arccos(...) (default).
* Which stroke: both; forward and return branches are returned separately (``Profile.forward``).
* Pressure angle: ``theta`` = angle between the conrod (the two-force member pushing the stone) and the
  groove tangent (the velocity of B): cos theta = |rho' cos mu - rho g' sin mu| / |B'|.  For the base
  four-bar (rho' = 0) it is 90 deg - |mu|, the complement of the transmission angle.  The spec's suggestion
  ``nu`` (angle between the profile normal and the slot, cos nu = |rho g'|/|B'|) is returned too.
* Limits: the allowable pressure angle default is 60 deg = 90 deg - mu_min with mu_min = 30 deg, the minimum
  transmission angle used by seed 004's four-bar synthesis (the feeder papers give no value); the roller
  radius default is 0 (pure cusp check; undercut with a real roller is checked when one is given).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .laws import DwellCycle, Law, TWO_PI
from .mathns import SCALAR

DEFAULT_MAX_PRESSURE = math.radians(60.0)
CRITERIA = ("connection", "radius", "cusp", "undercut", "pressure")


# -- base four-bar -------------------------------------------------------------------------------------------
def base_fourbar_angle(phi, lam1: float, lam2: float, lam3: float, assembly: int = 1):
    """Kulisa angle gamma_b of the base four-bar (fixed rocker length lam3), in [0, 2pi)."""
    phi = np.asarray(phi, dtype=float)
    ax, ay = -lam1 + np.cos(phi), np.sin(phi)
    d = np.hypot(ax, ay)
    cos_arg = (lam3 ** 2 + d ** 2 - lam2 ** 2) / (2.0 * lam3 * d)
    if np.any(np.abs(cos_arg) > 1.0 + 1e-12):
        raise ValueError(f"base four-bar lambda1={lam1}, lambda2={lam2}, lambda3={lam3} cannot be assembled at every crank angle")
    return np.mod(np.arctan2(ay, ax) + assembly * np.arccos(np.clip(cos_arg, -1.0, 1.0)), TWO_PI)


def grashof_crank_rocker(lam1: float, lam2: float, lam3: float) -> bool:
    return 1.0 + max(lam1, lam2, lam3) <= lam1 + lam2 + lam3 - max(lam1, lam2, lam3) + 1e-12 and \
        min(lam1, lam2, lam3) >= 1.0


def fourbar_extremes(lam1: float, lam2: float, lam3: float, assembly: int = 1) -> dict:
    """Crank and kulisa angles of the folded (|O1B| = lam2-1) and extended (|O1B| = lam2+1) extremes."""
    if not grashof_crank_rocker(lam1, lam2, lam3):
        raise ValueError(f"base four-bar lambda1={lam1}, lambda2={lam2}, lambda3={lam3} is not a Grashof crank-rocker")
    out = {}
    for name, d, flip in (("folded", lam2 - 1.0, math.pi), ("extended", lam2 + 1.0, 0.0)):
        alpha = math.acos(max(-1.0, min(1.0, (lam1 ** 2 + d ** 2 - lam3 ** 2) / (2.0 * lam1 * d))))
        best = None
        for sgn in (1.0, -1.0):
            bx, by = -lam1 + d * math.cos(sgn * alpha), d * math.sin(sgn * alpha)
            g = math.atan2(by, bx) % TWO_PI
            phi = (sgn * alpha + flip) % TWO_PI
            err = abs(math.remainder(float(base_fourbar_angle(phi, lam1, lam2, lam3, assembly)) - g, TWO_PI))
            if best is None or err < best[0]:
                best = (err, phi, g)
        out[name] = (best[1], best[2])
    return out


@dataclass(frozen=True)
class KulisaLaw:
    """gamma_b(phi) = gamma_start + direction * swing * s(phi), s from a dwell cycle (0 -> 1 -> 0)."""
    cycle: DwellCycle
    gamma_start: float
    direction: float
    swing: float

    def at(self, phi, m=None):
        """(gamma_b, its first and second derivatives) at crank angle(s) phi (``m``: the namespace,
        mathns.namespace; numpy by default)."""
        s, s1, s2 = self.cycle.at(phi, m)
        k = self.direction * self.swing
        return self.gamma_start + k * s, k * s1, k * s2

    __call__ = at   # also law(phi, m); hot paths call .at (calling an instance costs ~100 ns more)

    def jerk(self, phi: float) -> float:
        """d3gamma_b/dphi3 at one crank angle (the cycle's DwellCycle.jerk, scaled as the law)."""
        return self.direction * self.swing * self.cycle.jerk(phi)


def base_design(lam1: float, lam2: float, lam3: float, assembly: int = 1) -> dict:
    """The base four-bar (same lambda1, lambda2, lambda3) whose extremes fix the kulisa law (module doc)."""
    ext = fourbar_extremes(lam1, lam2, lam3, assembly)
    (pf, gf), (pe, ge) = ext["folded"], ext["extended"]
    dg = math.remainder(ge - gf, TWO_PI)
    phase_f = (pe - pf) % TWO_PI
    return dict(phi_start=pf, gamma_start=gf, gamma_end=gf + dg, direction=math.copysign(1.0, dg),
                swing=abs(dg), phase_forward=phase_f, phase_return=TWO_PI - phase_f)


def kulisa_law(lam1: float, lam2: float, lam3: float, forward: Law, ret: Law | None = None, dwell: float = 0.0,
               assembly: int = 1) -> KulisaLaw:
    """The prescribed kulisa law: swing and extreme positions of the base four-bar, the dwell centred on its
    extended dead-centre position, the forward stroke starting at its folded dead centre."""
    ref = base_design(lam1, lam2, lam3, assembly)
    pf, pr = ref["phase_forward"] - 0.5 * dwell, ref["phase_return"] - 0.5 * dwell
    if not (pf > 0.0 and pr > 0.0):
        raise ValueError(f"dwell = {dwell!r} rad leaves no forward/return phase "
                         f"(base four-bar phases {ref['phase_forward']:.4f}, {ref['phase_return']:.4f} rad)")
    cyc = DwellCycle(forward, forward if ret is None else ret, pf, pr, dwell, ref["phi_start"])
    return KulisaLaw(cyc, ref["gamma_start"], ref["direction"], ref["swing"])


def base_return_law(lam1: float, lam2: float, lam3: float, assembly: int = 1) -> Law:
    """The base four-bar's own return stroke as a normalised law: a(k) = (gamma_end - gamma(phi))/(gamma_end -
    gamma_start) with phi = phi_extended + k * phase_return.  A kulisa that returns by it keeps the stone at
    rho = lambda3, so the return-stroke profile is the arc of radius lambda3 whatever lambda2 is: the seed's
    "the character and the parameters of the profile on the return stroke are the same for all lambda2".
    Derivatives by central differences of the closed-form angle (h = 1e-4 rad: b to 1e-8, c to 1e-6)."""
    ref = base_design(lam1, lam2, lam3, assembly)
    pe, P = ref["phi_start"] + ref["phase_forward"], ref["phase_return"]
    g_end, span = ref["gamma_end"], ref["gamma_end"] - ref["gamma_start"]
    h = 1e-4

    def angle(phi):
        g = base_fourbar_angle(phi, lam1, lam2, lam3, assembly)
        return g_end + np.remainder(g - g_end + math.pi, TWO_PI) - math.pi

    def piece(k, m):
        phi = pe + np.asarray(k, dtype=float) * P
        g, gp, gm = angle(phi), angle(phi + h), angle(phi - h)
        a = (g_end - g) / span
        b = -(gp - gm) / (2.0 * h) * P / span
        c = -(gp - 2.0 * g + gm) / (h * h) * P * P / span
        return (float(a), float(b), float(c)) if m.scalar else (a, b, c)

    return Law("base", f"the base four-bar's own return stroke (lambda1={lam1:g}, lambda2={lam2:g}, "
               f"lambda3={lam3:g})", ((1.0, piece),))


def kulisa_law_base_return(lam1: float, lam2: float, lam3: float, forward: Law, dwell: float = 0.0,
                           assembly: int = 1) -> KulisaLaw:
    """The kulisa follows ``forward`` from the folded dead centre, dwells ``dwell`` rad before the extended one,
    and returns as the base four-bar does (:func:`base_return_law`): the roller leaves the groove's law on the
    return stroke."""
    ref = base_design(lam1, lam2, lam3, assembly)
    pf = ref["phase_forward"] - dwell
    if not pf > 0.0:
        raise ValueError(f"dwell = {dwell!r} rad leaves no forward phase (base four-bar's {ref['phase_forward']:.4f} rad)")
    cyc = DwellCycle(forward, base_return_law(lam1, lam2, lam3, assembly), pf, ref["phase_return"], dwell,
                     ref["phi_start"])
    return KulisaLaw(cyc, ref["gamma_start"], ref["direction"], ref["swing"])


def base_branch(lam1: float, lam2: float, lam3: float, assembly: int = 1) -> int:
    """Root of (K8) the base four-bar takes at its folded dead centre: +1 (cos mu >= 0) or -1."""
    pf, gf = fourbar_extremes(lam1, lam2, lam3, assembly)["folded"]
    au = math.cos(pf - gf) - lam1 * math.cos(gf)
    return 1 if lam3 - au >= 0.0 else -1


# -- synthesis -----------------------------------------------------------------------------------------------
@dataclass
class Profile:
    """Synthesised centroid profile over a crank-angle grid (dimensionless, lengths / r)."""
    phi: np.ndarray
    gamma: np.ndarray
    lam1: float
    lam2: float
    N: np.ndarray = field(repr=False)
    exists: np.ndarray = field(repr=False)      # kinematic connection |N| <= lam2 at each point
    mu: np.ndarray = field(repr=False)
    rho: np.ndarray = field(repr=False)         # rho_i
    drho: np.ndarray = field(repr=False)
    B: np.ndarray = field(repr=False)           # (n, 2) profile points in F2
    dB: np.ndarray = field(repr=False)
    speed: np.ndarray = field(repr=False)       # |B'|
    curvature: np.ndarray = field(repr=False)   # signed, 1/(length/r)
    theta: np.ndarray = field(repr=False)       # pressure angle conrod vs groove tangent [rad]
    nu: np.ndarray = field(repr=False)          # angle profile normal vs slot [rad]
    forward: np.ndarray = field(repr=False)     # True on the forward stroke (s' > 0)
    moving: np.ndarray = field(repr=False)      # True where the kulisa moves (g' != 0)


def synthesize(phi, g, g1, g2, lam1: float, lam2: float, branch: int = 1) -> Profile:
    """Centroid profile for kulisa angles g(phi) with derivatives g1 = dg/dphi, g2 = d2g/dphi2 (arrays)."""
    phi, g, g1, g2 = (np.asarray(v, dtype=float) for v in (phi, g, g1, g2))
    sg, cg = np.sin(g), np.cos(g)
    d = phi - g
    sd, cd = np.sin(d), np.cos(d)
    N = lam1 * sg + sd
    exists = np.abs(N) <= lam2
    Q2 = np.maximum(lam2 ** 2 - N ** 2, 0.0)
    Q = np.sqrt(Q2)
    Q = branch * Q
    mu = np.arctan2(N, Q)
    one = 1.0 - g1
    N1 = lam1 * cg * g1 + cd * one
    N2 = -lam1 * sg * g1 ** 2 + lam1 * cg * g2 - sd * one ** 2 - cd * g2
    with np.errstate(divide="ignore", invalid="ignore"):
        Q1 = -N * N1 / Q
        Qd2 = -(N1 ** 2 + N * N2) / Q - N ** 2 * N1 ** 2 / Q ** 3
    rho = cd - lam1 * cg + Q
    r1 = -sd * one + lam1 * sg * g1 + Q1
    r2 = -cd * one ** 2 + sd * g2 + lam1 * cg * g1 ** 2 + lam1 * sg * g2 + Qd2
    ut, nt = r1, rho * g1                     # B' in the (u, n) basis
    uc, nc = r2 - rho * g1 ** 2, 2.0 * r1 * g1 + rho * g2
    speed = np.hypot(ut, nt)
    with np.errstate(divide="ignore", invalid="ignore"):
        curvature = (ut * nc - nt * uc) / speed ** 3
        theta = np.arccos(np.clip(np.abs(ut * np.cos(mu) - nt * np.sin(mu)) / np.abs(nt), 0.0, 1.0))
        nu = np.arccos(np.clip(np.abs(nt) / speed, 0.0, 1.0))
    B = np.stack([rho * cg, rho * sg], axis=-1)
    dB = np.stack([ut * cg - nt * sg, ut * sg + nt * cg], axis=-1)
    return Profile(phi, g, lam1, lam2, N, exists, mu, rho, r1, B, dB, speed, curvature, theta, nu,
                   g1 > 0.0 if np.mean(g1) >= 0 else g1 < 0.0, g1 != 0.0)


def synthesize_law(law: KulisaLaw, lam1: float, lam2: float, n: int = 7200, branch: int = 1) -> Profile:
    phi = law.cycle.phi_start + np.linspace(0.0, TWO_PI, n, endpoint=False)
    g, g1, g2 = law(phi)
    p = synthesize(phi, g, g1, g2, lam1, lam2, branch)
    s1 = law.cycle(phi)[1]
    p.forward = s1 > 0.0
    return p


def stone_radius_scalar(phi: float, g: float, lam1: float, lam2: float, branch: int = 1) -> float:
    """rho_i (K8, singularity-free form) at one point, with math; NaN when the connection is broken."""
    N = lam1 * math.sin(g) + math.sin(phi - g)
    q2 = lam2 * lam2 - N * N
    if q2 < 0.0:
        return math.nan
    return math.cos(phi - g) - lam1 * math.cos(g) + branch * math.sqrt(q2)


def stone_radius_rate_scalar(phi: float, g: float, g1: float, lam1: float, lam2: float,
                             branch: int = 1, m=SCALAR) -> tuple[float, float]:
    """(rho_i, drho_i/dphi) at one point (g1 = dG/dphi): rho_i as :func:`stone_radius_scalar` computes it (the
    same operations), its rate as :func:`stone_scalar`'s; (NaN, NaN) when the connection is broken.  ``m``: the
    math namespace (fmus.physics.mathns; VECTOR: arrays over a batch of variants)."""
    sg, sd = m.sin(g), m.sin(phi - g)
    N = lam1 * sg + sd
    q2 = lam2 * lam2 - N * N
    if m.scalar and q2 < 0.0:
        return math.nan, math.nan
    cd, cg = m.cos(phi - g), m.cos(g)
    N1 = lam1 * cg * g1 + cd * (1.0 - g1)
    if m.scalar:
        Q = branch * math.sqrt(q2)
        Q1 = -N * N1 / Q if Q != 0.0 else math.copysign(math.inf, -N * N1)
        return cd - lam1 * cg + Q, -sd * (1.0 - g1) + lam1 * sg * g1 + Q1
    broken = q2 < 0.0
    Q = branch * m.sqrt(m.where(broken, 0.0, q2))
    Q1 = m.where(Q != 0.0, -N * N1 / m.where(Q != 0.0, Q, 1.0), m.copysign(math.inf, -N * N1))
    return (m.where(broken, math.nan, cd - lam1 * cg + Q),
            m.where(broken, math.nan, -sd * (1.0 - g1) + lam1 * sg * g1 + Q1))


def _stone_terms(phi: float, g: float, g1: float, lam1: float, lam2: float, branch: int, m=SCALAR) -> tuple:
    """The terms :func:`stone_scalar` and :func:`stone_slopes_scalar` share: sin and cos of G and of phi - G,
    N = lambda1 sin G + sin(phi - G), Q = +-sqrt(lambda2^2 - N^2) (0 at the groove's reach), 1 - G', N'."""
    sg, cg = m.sin(g), m.cos(g)
    sd, cd = m.sin(phi - g), m.cos(phi - g)
    N = lam1 * sg + sd
    Q = branch * m.sqrt(m.maximum(lam2 * lam2 - N * N, 0.0))
    one = 1.0 - g1
    return sg, cg, sd, cd, N, Q, one, lam1 * cg * g1 + cd * one


def stone_scalar(phi: float, g: float, g1: float, lam1: float, lam2: float, branch: int = 1,
                 m=SCALAR) -> tuple[float, float, float]:
    """(rho_i, drho_i/dphi, pressure angle theta) at one point, with math (per-step outputs); ``m``: the math
    namespace (fmus.physics.mathns; VECTOR: arrays over a batch of variants)."""
    sg, cg, sd, cd, N, Q, one, N1 = _stone_terms(phi, g, g1, lam1, lam2, branch, m)
    if m.scalar:
        Q1 = -N * N1 / Q if Q != 0.0 else math.copysign(math.inf, -N * N1)
    else:
        Q1 = m.where(Q != 0.0, -N * N1 / m.where(Q != 0.0, Q, 1.0), m.copysign(math.inf, -N * N1))
    rho = cd - lam1 * cg + Q
    r1 = -sd * one + lam1 * sg * g1 + Q1
    nt = rho * g1
    sm = N / lam2
    cm = Q / lam2
    if m.scalar:
        sp = math.hypot(r1, nt)
        if not math.isfinite(sp) or sp == 0.0:
            return rho, r1, 0.0
        if nt == 0.0:
            return rho, r1, 0.0
        return rho, r1, math.acos(min(1.0, abs(r1 * cm - nt * sm) / abs(nt)))
    # hypot(r1, nt) is not finite exactly where r1 or nt is not, 0 exactly where both are 0
    none = ~(np.isfinite(r1) & np.isfinite(nt)) | ((r1 == 0.0) & (nt == 0.0)) | (nt == 0.0)
    z = m.minimum(1.0, abs(r1 * cm - nt * sm) / abs(m.where(none, 1.0, nt)))
    return rho, r1, m.where(none, 0.0, m.acos(m.where(none, 1.0, z)))


def stone_slopes_scalar(phi: float, g: float, g1: float, g2: float, lam1: float, lam2: float,
                        branch: int = 1) -> tuple[float, float]:
    """(d2rho_i/dphi2, d theta/dphi) at one point (g2 = d2G/dphi2): the slopes of :func:`stone_scalar`'s rate and
    pressure angle, for a component's directional derivatives.  rho'' is :func:`synthesize`'s r2 (Q'' from N''),
    and theta = arccos(z), z = |rho' cos mu - nt sin mu| / |nt| (nt = rho g', sin mu = N / lambda2,
    cos mu = Q / lambda2) differentiated: theta' = -z' / sqrt(1 - z^2), 0 where stone_scalar clips z to 1 or
    gives theta = 0 (nt = 0, a stone at rest or at its groove's reach)."""
    sg, cg, sd, cd, N, Q, one, N1 = _stone_terms(phi, g, g1, lam1, lam2, branch)
    if Q == 0.0:
        return math.nan, 0.0
    N2 = -lam1 * sg * g1 ** 2 + lam1 * cg * g2 - sd * one ** 2 - cd * g2
    Q1 = -N * N1 / Q
    Q2 = -(N1 ** 2 + N * N2) / Q - N ** 2 * N1 ** 2 / Q ** 3
    rho = cd - lam1 * cg + Q
    r1 = -sd * one + lam1 * sg * g1 + Q1
    r2 = -cd * one ** 2 + sd * g2 + lam1 * cg * g1 ** 2 + lam1 * sg * g2 + Q2
    nt, nt1 = rho * g1, r1 * g1 + rho * g2
    if nt == 0.0:
        return r2, 0.0
    a = (r1 * Q - nt * N) / lam2
    a1 = (r2 * Q + r1 * Q1 - nt1 * N - nt * N1) / lam2
    z = abs(a) / abs(nt)
    if z >= 1.0:
        return r2, 0.0
    z1 = math.copysign(1.0, a) * a1 / abs(nt) - abs(a) * math.copysign(1.0, nt) * nt1 / (nt * nt)
    return r2, -z1 / math.sqrt(1.0 - z * z)


# -- checks --------------------------------------------------------------------------------------------------
def cusps(p: Profile) -> np.ndarray:
    """Indices i where the tangent reverses between grid points i and i+1 inside one stroke (a cusp of a branch).

    The stone stops and turns back at the ends of every stroke (kulisa dead centres, dwell ends): those
    turning points join the forward and return branches and are not counted; each branch is checked on its
    own, as the spec stores them separately.
    """
    t = p.dB / np.where(p.speed > 0.0, p.speed, 1.0)[:, None]
    nxt = np.roll(np.arange(len(p.phi)), -1)
    dots = np.sum(t * t[nxt], axis=1)
    inside = p.moving & p.moving[nxt] & (p.forward == p.forward[nxt])
    return np.nonzero((dots < 0.0) & inside)[0]


def away_from_branch_ends(p: Profile, length: float) -> np.ndarray:
    """True at the points farther than ``length`` (in units of r) along the centroid from both ends of their
    branch.  A branch is a run of points of one stroke (forward or return) where the kulisa moves; its ends are
    the stone's turning points at the dead centres and the dwells."""
    n = len(p.phi)
    key = np.where(p.moving, np.where(p.forward, 1, 2), 0)
    starts = np.nonzero(key != np.roll(key, 1))[0]
    ds = p.speed * np.abs(np.gradient(p.phi))
    if len(starts) == 0:
        return p.moving.copy()
    out = np.zeros(n, dtype=bool)
    for i, s0 in enumerate(starts):
        if key[s0] == 0:
            continue
        e0 = starts[(i + 1) % len(starts)]
        idx = np.arange(s0, e0 if e0 > s0 else e0 + n) % n
        seg = ds[idx]
        along = np.cumsum(seg) - 0.5 * seg
        out[idx] = np.minimum(along, along[-1] + 0.5 * seg[-1] - along) > length
    return out


def assess(p: Profile, r: float, roller_radius: float = 0.0, max_pressure: float = DEFAULT_MAX_PRESSURE) -> dict:
    """Feasibility report: values of each criterion and the first one violated (None if feasible)."""
    rep: dict = dict(lambda2=p.lam2, connection_margin=float(np.min(p.lam2 - np.abs(p.N))))
    fails = []
    if not np.all(p.exists):
        i = int(np.argmin(p.lam2 - np.abs(p.N)))
        rep["connection_break_phi"] = float(p.phi[i])
        fails.append("connection")
    rep["rho_min"] = float(np.min(p.rho)) * r
    if not np.all(p.rho > 0.0):
        fails.append("radius")
    cu = cusps(p) if not fails else np.array([], dtype=int)
    rep["cusps"] = int(len(cu))
    if len(cu):
        fails.append("cusp")
    nxt = np.roll(np.arange(len(p.phi)), -1)
    prv = np.roll(np.arange(len(p.phi)), 1)
    inside = p.moving & p.moving[nxt] & p.moving[prv]   # away from the stroke-end turning points
    with np.errstate(divide="ignore"):
        rc = np.where(inside, np.abs(1.0 / p.curvature) * r, np.nan)
    rep["curvature_radius_min"] = float(np.nanmin(rc)) if np.any(np.isfinite(rc)) else math.nan
    if roller_radius > 0.0:
        # where a branch ends the stone reverses and the path turns on itself (curvature radius -> 0 there
        # whatever the law): the groove's end is the roller's own circle, so a wall can be undercut only
        # farther than one roller radius along the path from the branch's ends
        away = away_from_branch_ends(p, roller_radius / r)
        rw = np.where(away & inside, rc, np.nan)
        rep["curvature_radius_min_working"] = float(np.nanmin(rw)) if np.any(np.isfinite(rw)) else math.nan
        if not fails and not rep["curvature_radius_min_working"] >= roller_radius:
            fails.append("undercut")          # NaN too: no stretch of a branch is longer than two rollers
    # the pressure angle is 0/0 (NaN) where the stone stands still in the groove (the kulisa at rest at a stroke
    # end: rho' = g' = 0): undefined there, not a violation -- np.all on a NaN failed the whole groove
    rep["pressure_angle_max"] = float(np.nanmax(p.theta))
    if np.any(p.theta > max_pressure):
        fails.append("pressure")
    rep["nu_max"] = float(np.nanmax(p.nu))
    rep["failed"] = fails[0] if fails else None
    rep["all_failed"] = fails
    return rep


def export_points(path, p: Profile, r: float, comment: str = "") -> None:
    """ASCII point file for CAD: '# ...' header lines then 'x y' per line in metres (frame F2)."""
    with open(path, "w", encoding="ascii") as f:
        f.write("# LCSM groove centroid profile (locus of the stone pin B), frame F2: origin at the kulisa pivot O2,\n")
        f.write("# x from the crank pivot O1 towards O2, counter-clockwise angles; units: metres\n")
        f.write(f"# r = {r:g} m, lambda1 = {p.lam1:g}, lambda2 = {p.lam2:g}, {len(p.phi)} points over one crank turn\n")
        for line in comment.splitlines():
            f.write(f"# {line}\n")
        for x, y in p.B * r:
            f.write(f"{x:.9f} {y:.9f}\n")


# -- rocker-slider output stage (K1)-(K5) --------------------------------------------------------------------
@dataclass(frozen=True)
class RockerSlider:
    """The rocker-slider contour of seed 001 (its Fig. 2), frame FE: origin at the rocker pivot O2, x along the
    carriage guide, the guide on the line y = e, the carriage E = (s, e), the rocker angle gamma of O2D from
    the guide direction, D = R (cos gamma, sin gamma), E to the right of D (s > D_x).

      (K1) s = s0 - a_k S                                 carriage position from the slider law's invariant a_k
      (K2) gamma01 = delta0 + arctan(e / s0)              the rocker's initial position
      (K3) mu = arccos[(L^2 + R^2 - (e^2 + s^2)) / (2 L R)]   transmission angle at D (rocker vs tie rod)
      (K4) theta = mu + gamma - pi                       pressure angle at the carriage (tie rod vs guide)
      (K5) gamma = arctan(e / s) + delta,  delta = arccos[(R^2 + d^2 - L^2) / (2 R d)],  d^2 = e^2 + s^2

    The seed prints (K5) as "pi + delta - arctg(e/s)", the mirrored layout (E on the negative x side); the
    form above is the one (K2)-(K4) hold in (feeder.md 2.2).  Lengths in any one unit (R, L, e, s0, S)."""
    R: float
    L: float
    e: float
    s0: float
    S: float

    def position(self, a):
        """(K1)."""
        return self.s0 - np.asarray(a, dtype=float) * self.S

    def angle(self, s):
        """(K5): gamma(s) with d gamma/ds and d2 gamma/ds2 (closed forms; NaN where D cannot reach E)."""
        s = np.asarray(s, dtype=float)
        R, L, e = self.R, self.L, self.e
        d2 = e * e + s * s
        d = np.sqrt(d2)
        X = (R * R - L * L) / (2.0 * R * d) + d / (2.0 * R)          # cos delta
        Xd = -(R * R - L * L) / (2.0 * R * d2) + 1.0 / (2.0 * R)
        Xdd = (R * R - L * L) / (R * d2 * d)
        Xs = Xd * s / d
        Xss = Xdd * (s / d) ** 2 + Xd * e * e / (d2 * d)
        with np.errstate(invalid="ignore", divide="ignore"):
            w = np.sqrt(1.0 - X * X)
            delta = np.arccos(X)
            ds = -Xs / w
            dss = -X * Xs ** 2 / w ** 3 - Xss / w
        return np.arctan2(e, s) + delta, -e / d2 + ds, 2.0 * e * s / d2 ** 2 + dss

    def delta0(self) -> float:
        """The auxiliary angle of (K2): the angle at O2 between O2E and O2D in the initial position."""
        d2 = self.e ** 2 + self.s0 ** 2
        return math.acos((self.R ** 2 + d2 - self.L ** 2) / (2.0 * self.R * math.sqrt(d2)))

    def gamma01(self) -> float:
        """(K2)."""
        return self.delta0() + math.atan(self.e / self.s0)

    def transmission(self, s):
        """(K3)."""
        s = np.asarray(s, dtype=float)
        return np.arccos((self.L ** 2 + self.R ** 2 - (self.e ** 2 + s * s)) / (2.0 * self.L * self.R))

    def pressure(self, s):
        """(K4): the signed angle between the tie rod D->E and the guide."""
        return self.transmission(s) + self.angle(s)[0] - math.pi

    def swing(self) -> float:
        """The rocker's swing over the stroke: gamma(s0 - S) - gamma(s0)."""
        return float(self.angle(self.s0 - self.S)[0] - self.angle(self.s0)[0])

    def rocker_law(self, slider: Law, stroke: str = "forward") -> Law:
        """The transformed law on the rocker ("трансформированный ЗПД на коромысле"), normalised to [0, 1]:
        forward, the carriage runs s0 -> s0 - S by ``slider`` and the rocker turns gamma01 -> gamma01 + swing;
        "return", the carriage runs back by ``slider`` (s = s0 - S (1 - a)) and the rocker's normalised
        return law is 1 - (gamma - gamma01)/swing, as :class:`fmus.physics.laws.DwellCycle` takes it."""
        if stroke not in ("forward", "return"):
            raise ValueError(f"stroke = {stroke!r} must be 'forward' or 'return'")
        g0, G = float(self.angle(self.s0)[0]), self.swing()
        sign = 1.0 if stroke == "forward" else -1.0

        def wrap(f):
            def piece(k, m):
                a, b, c = (np.asarray(v, dtype=float) for v in f(np.asarray(k, dtype=float), np))
                s = self.position(a if stroke == "forward" else 1.0 - a)
                g, gs, gss = self.angle(s)
                ds = -sign * self.S                       # ds/da
                out = ((g - g0) / G if stroke == "forward" else 1.0 - (g - g0) / G,
                       sign * gs * ds * b / G, sign * (gss * ds * ds * b * b + gs * ds * c) / G)
                return tuple(float(v) for v in out) if getattr(m, "scalar", m is math) else out
            return piece

        return Law(f"{slider.name}@rocker", f"law {slider.name} of the carriage seen on the rocker ({stroke} "
                   f"stroke) through the rocker-slider stage R={self.R:g}, L={self.L:g}, e={self.e:g}, "
                   f"s0={self.s0:g}, S={self.S:g}", tuple((end, wrap(f)) for end, f in slider.pieces),
                   slider.params)


def rocker_slider_for_swing(swing: float, R: float = 1.0, L: float = 2.5) -> RockerSlider:
    """A rocker-slider stage whose rocker turns through ``swing`` [rad] over the stroke, with rocker R and tie rod
    L (the seed leaves them to "constructional considerations"; ours: L = 2.5 R).  The rocker swings
    symmetrically about the normal to the guide, gamma from pi/2 - swing/2 to pi/2 + swing/2, and e follows from
    the seed's condition of staying away from jamming: the pressure angle (K4) is asin((D_y - e)/L) and D_y
    runs over [R cos(swing/2), R], so e = R (1 + cos(swing/2))/2 makes its largest magnitude least."""
    if not (0.0 < swing < math.pi):
        raise ValueError(f"rocker swing = {swing!r} rad must be in (0, pi)")
    if not (R > 0.0 and L > R):
        raise ValueError(f"tie rod L = {L!r} must exceed the rocker R = {R!r} > 0")
    e = 0.5 * R * (1.0 + math.cos(0.5 * swing))

    def s_at(gamma: float) -> float:
        dx, dy = R * math.cos(gamma), R * math.sin(gamma)
        return dx + math.sqrt(L * L - (e - dy) ** 2)

    s0 = s_at(0.5 * math.pi - 0.5 * swing)
    return RockerSlider(R, L, e, s0, s0 - s_at(0.5 * math.pi + 0.5 * swing))


def combined_kulisa_law(lam1: float, lam2: float, lam3: float, forward: Law, ret: Law | None = None,
                        dwell: float = 0.0, assembly: int = 1, tie_rod: float = 2.5) -> tuple[KulisaLaw, RockerSlider]:
    """Seed 001's combined mechanism: ``forward``/``ret`` are the CARRIAGE's laws; the rocker-slider stage
    (:func:`rocker_slider_for_swing`, tie rod ``tie_rod`` rocker lengths) is laid out for the base four-bar's
    swing, and the kulisa, rigid with the rocker, follows the transformed laws (K1)-(K5) with the phases and the
    dwell of :func:`kulisa_law`."""
    stage = rocker_slider_for_swing(base_design(lam1, lam2, lam3, assembly)["swing"], 1.0, tie_rod)
    ret = forward if ret is None else ret
    return kulisa_law(lam1, lam2, lam3, stage.rocker_law(forward), stage.rocker_law(ret, "return"), dwell,
                      assembly), stage
