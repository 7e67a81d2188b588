"""The roller's lift-off from its groove wall (seed 000's Fig. 3, for the laws K0 and C0): the forces of the
rigid mechanism on the groove over a crank turn (:func:`wall_forces`, :func:`lift_off`) and the crossing of
the play to the other wall after a lift-off (:func:`crossing`).  The take-up that follows is
:mod:`fmus.physics.takeup`.

The seed (after eq. 23): "the lift-off position of the roller is determined from the rolling condition,
depending on the forces acting on the stone" (Fig. 3: a - K0, b - C0), and "collisions of the roller with
the groove walls are possible not only at the extreme positions of the rocker but also after its lift-off
from the correcting profile, at various positions of the stone depending on the designed law".

Read here as: the roller rolls on one wall of the groove.  A rolling roller, free on its pin (the seed
neglects friction moments in joints and supports, text before eq. 1; the roller's own inertia is neglected
too), passes only a force along the wall's normal n_g; it stays on the wall while that force pushes it, and
lifts off where the normal force the motion needs passes through zero and would have to pull.  The forces
follow from the rigid mechanism at constant crank speed (the groove synthesised for the law, fmus.physics
.groove): the stone (mass m_s, a point at B = rho u on the slot line, frictionless slot) and the kulisa with
the head (inertia J about O2, torque tau of the head's load) are moved by the conrod force F_c along the
conrod (a two-force member, e_c from B to the crank pin A) and the wall force N n_g; the slot's reaction is
internal to the pair (the equations of CamRocker's level 3, fmus.physics.cam_rocker):

    m_s (rho'' - rho gamma'^2)                         = F_c e_c.u + N n_g.u
    (J + m_s rho^2) gamma'' + 2 m_s rho rho' gamma'    = tau + rho (F_c e_c.n + N n_g.n)

(time derivatives; u along the slot, n = u turned +90 deg).  n_g is a wall's normal, not the direction of
travel's: the profile's tangent turned +90 deg, its sign carried on continuously where the stone reverses
along the groove (B' = 0: the dead centre inside a dwell, where the stone runs out and back along one radial
channel, and both dead centres of a circular groove) -- the tangent flips there, the walls do not.  A
lift-off is a sign change of N against that normal.  Without a load torque both forces scale with
omega^2: the lift-off positions do not depend on the crank speed, only on the law, the geometry and the
ratio m_s rho^2 / J.

Pure numpy; no FMI import.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LiftOffCase:
    """One groove of the seed's Fig. 3 (defaults: the running feeder, systems/feeder_gto52)."""
    law: str = "K0"                   # the kulisa's law of periodic motion (seed: K0 and C0)
    r: float = 0.040                  # m, crank radius (seed 001)
    lam1: float = 3.5                 # frame / r (seed 001)
    lam2: float = 4.2                 # conrod / r (the feeder's)
    lam3: float = 3.0                 # base rocker / r (seed 001)
    dwell: float = math.radians(30.0)  # rad, the head's dwell (the feeder's)
    rpm: float = 150.0                # crank speed (seed: 100-200 rpm)
    J: float = 0.00043                # kg.m2, kulisa with the head about O2 (seed: I2)
    m_stone: float = 0.01             # kg, stone with its roller (not in the seed: CamRocker's assumed value)
    head_friction: float = 0.0        # N.m, Coulomb torque of the head's guides against the kulisa's motion
    #                                   (0: the seed's take-up "without external forces", eq. 5)
    n: int = 7200                     # crank-angle samples per turn

    @property
    def omega(self) -> float:
        return self.rpm * 2.0 * math.pi / 60.0

    def check(self) -> None:
        for name, lo, lo_open in (("r", 0.0, True), ("lam1", 0.0, True), ("lam2", 0.0, True), ("lam3", 0.0, True),
                                  ("dwell", 0.0, False), ("rpm", 0.0, True), ("J", 0.0, False),
                                  ("m_stone", 0.0, False), ("head_friction", 0.0, False)):
            v = getattr(self, name)
            if not (math.isfinite(v) and (v > lo if lo_open else v >= lo)):
                raise ValueError(f"LiftOffCase.{name} = {v!r} outside {'(' if lo_open else '['}{lo:g}, inf)")
        if not self.J + self.m_stone > 0.0:
            raise ValueError("LiftOffCase: J = m_stone = 0 moves nothing (allowed: J + m_stone > 0)")
        if not self.n >= 360:
            raise ValueError(f"LiftOffCase.n = {self.n!r} outside [360, inf) samples per turn")


@dataclass
class WallForces:
    """The groove's forces over one crank turn, and where the roller lifts off a wall."""
    phi: np.ndarray                   # rad, crank angle (frame F2)
    gamma: np.ndarray                 # rad, kulisa angle
    rho: np.ndarray                   # m, stone radius |O2 B|
    B: np.ndarray                     # m, roller centre (n, 2) in frame F2
    F_conrod: np.ndarray              # N, conrod force on the stone along e_c (> 0: the conrod pulls)
    N: np.ndarray                     # N, wall force along n_g (its sign: which wall carries the roller)
    n_wall: np.ndarray                # the wall normal n_g (n, 2), continuous along the groove
    v_slot: np.ndarray                # m/s, the roller centre's kinematic velocity along the slot, rho'
    #                                   (the stone's V3 of eq. 10)
    v_rocker: np.ndarray              # m/s, and across it, rho gamma' (the rocker's; zero at its extremes)
    lift_off: np.ndarray              # (k, 2) sample pairs (i, j): N changes sign from i to the next finite
    #                                   sample j (after the last comes the first: ``wrap_flip`` says how)
    moving: np.ndarray                # the kulisa moves (outside its dwells and dead-centre instants)
    wrap_flip: bool = False           # the continuous normal returns reversed after the turn (an odd number
    #                                   of reversals): the first sample's N counts with the other sign


def _periodic_derivative(y: np.ndarray, h: float) -> np.ndarray:
    """Central difference of samples over one whole period (uniform step h)."""
    return (np.roll(y, -1) - np.roll(y, 1)) / (2.0 * h)


def _continuous_normal(n: np.ndarray) -> tuple[np.ndarray, bool]:
    """The unit normals ``n`` (n, 2) with their sign carried on along the samples: flipped after every
    sample where consecutive normals point apart (the curve reverses); a NaN normal (the stone at rest) takes
    its predecessor's.  Also whether the last one points against the first."""
    out = np.array(n, dtype=float)
    sign, prev = 1.0, None
    for i in range(len(out)):
        if not np.all(np.isfinite(out[i])):
            if prev is not None:
                out[i] = prev
            continue
        if prev is not None and (sign * out[i]) @ prev < 0.0:
            sign = -sign
        out[i] *= sign
        prev = out[i]
    return out, bool(out[-1] @ out[0] < 0.0)


def wall_forces(profile, g1, g2, r: float, omega: float, J: float, m_stone: float,
                head_friction: float = 0.0) -> WallForces:
    """The conrod and wall forces of the rolling roller (block comment above) on a synthesised groove
    ``profile`` (fmus.physics.groove.Profile over one uniform turn of the crank, lengths / r) whose kulisa law
    has the derivatives g1 = dgamma/dphi, g2 = d2gamma/dphi2.  rho'' is the central difference of the profile's
    closed-form rho' (the law's acceleration jumps, K0's soft impacts, stay one sample wide).  Where the
    profile's tangent is undefined (the stone at rest) or the conrod acts along the wall's normal (the pair is
    locked), the forces are NaN."""
    phi, g = profile.phi, profile.gamma
    h = float(phi[1] - phi[0])
    g1, g2 = np.asarray(g1, dtype=float), np.asarray(g2, dtype=float)
    u = np.stack([np.cos(g), np.sin(g)], axis=-1)
    nrm = np.stack([-np.sin(g), np.cos(g)], axis=-1)
    B = r * profile.B
    A = r * np.stack([-profile.lam1 + np.cos(phi), np.sin(phi)], axis=-1)
    e_c = (A - B) / np.linalg.norm(A - B, axis=1)[:, None]
    stopped = profile.speed <= 1e-9 * np.max(profile.speed)       # B' = 0: no tangent, no wall normal
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(stopped[:, None], np.nan, profile.dB / profile.speed[:, None])
    n_g, wrap_flip = _continuous_normal(np.stack([-t[:, 1], t[:, 0]], axis=-1))
    rho = r * profile.rho
    rho1 = r * profile.drho * omega
    rho2 = r * _periodic_derivative(profile.drho, h) * omega ** 2
    w, a = g1 * omega, g2 * omega ** 2
    tau = -head_friction * np.sign(w)
    P_u = m_stone * (rho2 - rho * w ** 2)
    P_n = ((J + m_stone * rho ** 2) * a + 2.0 * m_stone * rho * rho1 * w - tau) / rho
    a11, a12 = np.sum(e_c * u, axis=1), np.sum(n_g * u, axis=1)
    a21, a22 = np.sum(e_c * nrm, axis=1), np.sum(n_g * nrm, axis=1)
    det = a11 * a22 - a12 * a21
    det = np.where(np.abs(det) > 1e-9, det, np.nan)
    F_c = (P_u * a22 - a12 * P_n) / det
    N = (a11 * P_n - a21 * P_u) / det
    # sign changes between consecutive finite samples (a NaN sample -- the stone stopped -- is stepped over)
    idx = np.nonzero(np.isfinite(N))[0]
    nxt = np.roll(idx, -1)
    N_next = N[nxt].copy()
    if wrap_flip:
        N_next[-1] = -N_next[-1]
    lift = np.stack([idx, nxt], axis=-1)[N[idx] * N_next < 0.0]
    return WallForces(phi, g, rho, B, F_c, N, n_g, rho1, rho * w, lift, g1 != 0.0, wrap_flip)


def lift_off(case: LiftOffCase) -> WallForces:
    """The seed's Fig. 3 quantity for one law: the groove of ``case.law`` (the kulisa law of
    fmus.physics.groove.kulisa_law with the case's dwell) and the roller's wall forces on it."""
    from . import groove
    from .laws import get_law

    case.check()
    law = groove.kulisa_law(case.lam1, case.lam2, case.lam3, get_law(case.law), dwell=case.dwell)
    branch = groove.base_branch(case.lam1, case.lam2, case.lam3)
    prof = groove.synthesize_law(law, case.lam1, case.lam2, n=case.n, branch=branch)
    if not np.all(prof.exists) or not np.all(prof.rho > 0.0):
        raise ValueError(f"LiftOffCase: law {case.law} with lambda2 = {case.lam2:g} has no groove (the kinematic "
                         f"connection breaks or the stone crosses the pivot; allowed: a lambda2 that "
                         f"python -m harness synth groove --scan lambda2 admits)")
    _, g1, g2 = law(prof.phi)
    return wall_forces(prof, g1, g2, case.r, case.omega, case.J, case.m_stone, case.head_friction)


def crossing(w: WallForces, case: LiftOffCase, clearance: float = 10e-6, window: float = math.radians(30.0),
             substeps: int = 50) -> list[dict]:
    """After each lift-off the roller crosses the groove's play to the other wall ("the duration of the
    displacement", which the seed takes from its ref. [6], not in our copy).  Linearised about the prescribed
    motion at the lift-off: the free mechanism (crank and conrod rigid, the roller off both walls) has one
    degree of freedom, the kulisa angle, of inertia M = J + m_s (rho^2 + (d rho/d gamma)^2) at the frozen crank
    angle; the roller centre's offset d along the wall normal moves k = dB/dgamma . n_g per radian, so its
    reduced mass is m_n = M / k^2, and the force the prescribed motion needs from the walls, missing now,
    drives it away from the wall it left: d'' = -s N(t) / m_n (s the sign of N before the lift-off; N as
    sampled, linear between samples, so that a law's acceleration jump -- K0 at its dwell -- is a step and a
    smooth change a ramp, which gives t = (6 clearance m_n / |Ndot|)^(1/3)).  The roller leaves with zero
    relative speed and strikes the other wall where d reaches ``clearance`` [m]: time t_cross, crank angle,
    speed v_impact.  If N turns back first and the roller returns to its wall within ``window`` of crank
    angle, t_cross is NaN (no crossing).  One dict per lift-off, in the order of ``w.lift_off``."""
    from . import groove

    if not (clearance > 0.0 and window > 0.0):
        raise ValueError(f"crossing: clearance = {clearance!r} m and window = {window!r} rad must be > 0")
    branch = groove.base_branch(case.lam1, case.lam2, case.lam3)
    n, h = len(w.phi), float(w.phi[1] - w.phi[0])
    dt = h / case.omega
    out = []
    for i, j in w.lift_off:
        phi, g = float(w.phi[i]), float(w.gamma[i])
        dg = 1e-6
        drho = case.r * (groove.stone_radius_scalar(phi, g + dg, case.lam1, case.lam2, branch)
                         - groove.stone_radius_scalar(phi, g - dg, case.lam1, case.lam2, branch)) / (2 * dg)
        rho = float(w.rho[i])
        M = case.J + case.m_stone * (rho ** 2 + drho ** 2)
        dB = drho * np.array([math.cos(g), math.sin(g)]) + rho * np.array([-math.sin(g), math.cos(g)])
        m_n = M / float(dB @ w.n_wall[i]) ** 2
        # the needed wall force from the zero crossing on, as sampled (signed so that > 0 pushes away)
        steps = int(window / h) + 1
        idx = (i + np.arange(steps + 1)) % n
        N = w.N[idx].copy()
        if w.wrap_flip:
            N[idx < i] *= -1.0                   # past the turn's last sample the normal comes back reversed
        N = -math.copysign(1.0, w.N[i]) * N
        N = np.interp(np.arange(steps + 1, dtype=float), np.nonzero(np.isfinite(N))[0], N[np.isfinite(N)])
        f0 = N[0] / (N[0] - N[1])                # the zero crossing inside the first sample
        tt = np.linspace(f0, steps, (steps - 1) * substeps + 1)
        a = np.interp(tt, np.arange(steps + 1, dtype=float), N) / m_n
        a[0] = 0.0
        tau = (tt - f0) * dt
        v = np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * np.diff(tau))])
        d = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(tau))])
        back = np.nonzero(d[1:] < 0.0)[0]
        hit = np.nonzero(d >= clearance)[0]
        if len(hit) and (not len(back) or back[0] + 1 > hit[0]):
            k = hit[0]
            x = (clearance - d[k - 1]) / (d[k] - d[k - 1])
            t = tau[k - 1] + x * (tau[k] - tau[k - 1])
            out.append({"t_cross": t, "crank_deg": math.degrees(case.omega * t),
                        "v_impact": v[k - 1] + x * (v[k] - v[k - 1]), "m_n": m_n})
        else:
            out.append({"t_cross": math.nan, "crank_deg": math.nan, "v_impact": math.nan, "m_n": m_n})
    return out
