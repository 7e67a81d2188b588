"""Printing-cylinder drive with eccentric round gear sectors (paper A, seed 002, spec bed_drives.md §2.1).

Sector kinematics in the inverted mechanism (driving sector A fixed, line O_A O_B = carrier at angle beta,
driven sector B rolls outside A), all lengths divided by R_B (eqs. 3-16)::

    k1 = kappa + 1,  delta = delta0 + k1*beta
    u = eps2 cos(delta) + k1 cos(beta) - eps1 cos(beta0),   w = eps2 sin(delta) + k1 sin(beta) - eps1 sin(beta0)
    p = eps2 cos(delta) + cos(beta),  q = eps2 sin(delta) + sin(beta),  D = u^2 + w^2,  N = u p + w q
    sigma = atan2(w, u) (unwrapped; crank angle in the inverted frame),  psi = delta - sigma (cylinder angle)
    l_i = sqrt(D),  omega_C = D/N - 1 = d psi/d sigma,  eps_C = D (D_b N - D N_b) / (k1 N^3) = d omega_C/d sigma
    eps_fwd = eps_C * sign(sigma(0) - sigma(beta0))          (acceleration in forward time, phase 1 -> 2)

beta = 0 is point 2 (end of acceleration) and beta = beta0 point 1; the forward crank angle is
phi_K = phi2 - |sigma(beta) - sigma(0)| (spec ambiguity 6: the forward-time mapping).  beta0 is both the
polar angle of C_A and the carrier angle at point 1 (ambiguity 2, as printed).  delta0 is a given quantity
of the synthesis (ambiguity 1).  Invariants: speeds are per unit crank angle, lengths per r_K*i_CK
(v = omega_C*D_Ci/2, w = eps_C*D_Ci/2).

Synthesis (eq. 25): solve_sectors() finds (eps1, eps2, kappa, beta0) from a chosen set of 4 of the
junction residuals r17..r24 (default {r24, r18, r23, r21}, the legible members of (25) plus (24')), or
least squares over all of them; it starts from several points and always reports every residual.

Full cycle (§2.1.8-2.1.9), crank angle phi measured from the bed's outer dead centre: uniform 4 -> 1
(omega_Ci = 2 v1/D_Ci, concentric sectors 8/8'), acceleration 1 -> 2 (sectors 9/9'), synchronous 2 -> 3
(cylinder surface = bed, bed law of a centric slider-crank with skat ratio i_CK:
S_T = (1 - cos phi) + (1 - sqrt(1 - lam^2 sin^2 phi))/lam), braking 3 -> 4 (sectors 7/7', the same
synthesis with (v2, w2) -> (v3, -w3) and forward time running with beta).  The CylinderLaw class builds
this law from the synthesis once and evaluates angle, speed and acceleration invariants at any crank angle.

The GearSectors model drives the cylinder and the bed from the main shaft.  Accelerations used for the
inertial torques are the analytic second derivatives of the kinematic functions times crank speed squared
(the crank acceleration is taken as negligible, omega_K = const as in the paper).  The slopes of the outputs
(output_jacobian, the FMU's directional derivatives) need one derivative more of each law: sector_jerk (eq. 15
differentiated along the carrier angle), bed_law_jerk, and CylinderLaw.jerk, which takes each phase's own.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .base import Model, ParameterError, Params, Signal, param
from .hybrid import hybrid

RESIDUALS = ("r17", "r18", "r19", "r20", "r21", "r22", "r23", "r24")
DEFAULT_SET = ("r24", "r18", "r23", "r21")
UNKNOWNS = ("eps1", "eps2", "kappa", "beta0")


# ---------------------------------------------------------------------------------------------- kinematics
def _sector_terms(beta, eps1, eps2, kappa, beta0, delta0, cos, sin):
    """(u, w, delta_x, D, N, dD/dbeta, dN/dbeta) of eqs. 3-15, written once for math (scalars) and numpy."""
    k1 = kappa + 1.0
    dl = delta0 + k1 * beta
    cd, sd, cb, sb = cos(dl), sin(dl), cos(beta), sin(beta)
    u = eps2 * cd + k1 * cb - eps1 * math.cos(beta0)
    w = eps2 * sd + k1 * sb - eps1 * math.sin(beta0)
    p = eps2 * cd + cb
    q = eps2 * sd + sb
    Nb = w * (eps2 * k1 * cd + cb) - u * (eps2 * k1 * sd + sb)
    return u, w, dl, u * u + w * w, u * p + w * q, 2.0 * k1 * (w * p - u * q), Nb


def _sector_invariants(D, N, Db, Nb, kappa):
    """(omega_C, eps_C): eq. 12 as the magnitude D/N - 1, and eq. 15."""
    return D / N - 1.0, D * (Db * N - D * Nb) / ((kappa + 1.0) * N ** 3)


def _sector_second_terms(beta, eps2, kappa, u, w, dl, cos, sin):
    """(d2D/dbeta2, d2N/dbeta2): the terms of eqs. 3-15 differentiated once more, with du/dbeta = -k1 q and
    dw/dbeta = k1 p (so dD/dbeta = 2 k1 (w p - u q) and dN/dbeta = u dp/dbeta + w dq/dbeta, as above)."""
    k1 = kappa + 1.0
    cd, sd, cb, sb = cos(dl), sin(dl), cos(beta), sin(beta)
    p, q = eps2 * cd + cb, eps2 * sd + sb
    pb, qb = -(eps2 * k1 * sd + sb), eps2 * k1 * cd + cb
    pbb, qbb = -(eps2 * k1 * k1 * cd + cb), -(eps2 * k1 * k1 * sd + sb)
    return 2.0 * k1 * (k1 * (p * p + q * q) + w * pb - u * qb), k1 * (p * qb - q * pb) + u * pbb + w * qbb


def _sector_jerk(D, N, Db, Nb, Dbb, Nbb, kappa):
    """d eps_C / d sigma: eq. 15 differentiated in beta, divided by d sigma/d beta = k1 N / D."""
    k1 = kappa + 1.0
    G = Db * N - D * Nb                       # N^2 d(D/N)/dbeta
    Gb = Dbb * N - D * Nbb                    # dG/dbeta (the Db Nb terms cancel)
    deps = (Db * G + D * Gb) / (k1 * N ** 3) - 3.0 * D * G * Nb / (k1 * N ** 4)
    return deps * D / (k1 * N)


def sector_jerk(beta, eps1, eps2, kappa, beta0, delta0):
    """d eps_C / d sigma = d2 omega_C / d sigma2 at carrier angle beta (scalar or array): the third derivative of
    the cylinder angle in the crank angle of the inverted frame, which the crank torque's slope needs."""
    u, w, dl, D, N, Db, Nb = _sector_terms(beta, eps1, eps2, kappa, beta0, delta0, np.cos, np.sin)
    return _sector_jerk(D, N, Db, Nb, *_sector_second_terms(beta, eps2, kappa, u, w, dl, np.cos, np.sin), kappa)


def sector_point(beta: float, eps1: float, eps2: float, kappa: float, beta0: float, delta0: float):
    """Scalar kinematics at carrier angle beta: (sigma_raw, psi_raw, l_i, omega_C, eps_C) (eq. 3-15).

    sigma_raw is atan2 (not unwrapped); use sector_sigma for a continuous crank angle."""
    u, w, dl, D, N, Db, Nb = _sector_terms(beta, eps1, eps2, kappa, beta0, delta0, math.cos, math.sin)
    sigma = math.atan2(w, u)
    return (sigma, dl - sigma, math.sqrt(D), *_sector_invariants(D, N, Db, Nb, kappa))


def sector_arrays(beta, eps1, eps2, kappa, beta0, delta0):
    """Vectorised kinematics over an increasing array beta starting at 0: sigma (unwrapped), psi, l_i,
    omega_C, eps_C (eqs. 3-15)."""
    beta = np.asarray(beta, dtype=float)
    u, w, dl, D, N, Db, Nb = _sector_terms(beta, eps1, eps2, kappa, beta0, delta0, np.cos, np.sin)
    sigma = np.unwrap(np.arctan2(w, u))
    return (sigma, dl - sigma, np.sqrt(D), *_sector_invariants(D, N, Db, Nb, kappa))


@dataclass(frozen=True)
class SectorSummary:
    """Phase quantities of one sector pair (eqs. 17-23): values at point 2 (beta = 0) and point 1 (beta0)."""
    omega2: float      # omega_C(0)
    eps2_fwd: float    # forward-time acceleration invariant at beta = 0
    omega1: float      # omega_C(beta0)
    eps1_fwd: float    # at beta0
    l_i: float         # centre distance / R_B at beta = 0 (eq. 21)
    phi12: float       # crank angle of the phase |sigma(beta0) - sigma(0)| (eq. 22)
    phiC12: float      # cylinder rotation on the phase, sign*(psi(beta0) - psi(0)) = (sigma0 - sigma1) + (kappa+1) beta0 for sign = +1 (eq. 23)
    sign: float        # sign(sigma(beta0) - sigma(0))
    monotonic: bool    # N has one sign on [0, beta0] (sigma monotonic) and omega_C > 0


def summarize(eps1, eps2, kappa, beta0, delta0, n: int = 65) -> SectorSummary:
    beta = np.linspace(0.0, beta0, n)
    sigma, psi, li, om, ec = sector_arrays(beta, eps1, eps2, kappa, beta0, delta0)
    ds = sigma[-1] - sigma[0]
    s = 1.0 if ds >= 0.0 else -1.0
    dsig = np.diff(sigma)
    mono = bool(np.all(dsig * s > 0.0) and np.all(om > 0.0) and np.all(np.isfinite(om)))
    return SectorSummary(om[0], -s * ec[0], om[-1], -s * ec[-1], li[0], abs(ds),
                         s * (psi[-1] - psi[0]), s, mono)


# ---------------------------------------------------------------------------------------------- synthesis
@dataclass(frozen=True)
class SectorTask:
    """Given quantities of the synthesis problem (invariants, paper A §2.1.7)."""
    D_Ci: float      # cylinder diameter / (r_K i_CK)
    v1: float        # uniform cylinder surface speed invariant
    v2: float        # bed speed invariant at point 2
    w2: float        # bed acceleration invariant at point 2 (forward time)
    l_i: float       # centre distance / R_B when impression is on (beta = 0)
    phi12: float     # crank angle of the phase [rad]
    phiC12: float    # cylinder rotation on the phase [rad]
    c1: float        # character coefficient of the phase law (eq. 24)
    delta0: float    # angle of O_B C_B at beta = 0 [rad]


# What each given quantity may be (open intervals): the sizes are lengths, the speeds those of a cylinder that
# turns one way (omega_C > 0, so v = omega_C D_Ci / 2 > 0), phi12 a phase of the cycle whose four phases fill
# one turn (eq. 2), phiC12 the cylinder's forward turn on it.  w2, c1 and delta0 may have either sign.  A
# quantity left NaN is not given: the residual that needs it is not computed into the verdict (build_law).
GIVEN_RANGES = {"D_Ci": (0.0, math.inf), "v1": (0.0, math.inf), "v2": (0.0, math.inf),
                "w2": (-math.inf, math.inf), "l_i": (0.0, math.inf), "phi12": (0.0, 2.0 * math.pi),
                "phiC12": (0.0, math.inf), "c1": (-math.inf, math.inf), "delta0": (-math.inf, math.inf)}
# The given quantities each residual compares with (r18: point 1's zero acceleration needs none).
RESIDUAL_DATA = {"r17": ("v1", "D_Ci"), "r18": (), "r19": ("v2", "D_Ci"), "r20": ("w2", "D_Ci"),
                 "r21": ("l_i",), "r22": ("phi12",), "r23": ("phiC12",), "r24": ("c1",)}
RESIDUAL_MEANING = {"r17": "eq. 17, speed v1 at point 1", "r18": "eq. 18, zero acceleration at point 1",
                    "r19": "eq. 19, bed speed v2 at point 2", "r20": "eq. 20, bed acceleration w2 at point 2",
                    "r21": "eq. 21, centre distance l_i", "r22": "eq. 22, phase angle phi12",
                    "r23": "eq. 23, cylinder turn phiC12", "r24": "eq. 24', character coefficient c1"}
JUNCTION_TOL = 1e-6   # largest |residual| of a condition not solved for that still counts as met


def out_of_range(task: SectorTask) -> tuple[str, float, str] | None:
    """The first given quantity outside its range (:data:`GIVEN_RANGES`) as (name, value, allowed range),
    or None.  NaN means "not given"; an infinite value is never admissible."""
    for name, (lo, hi) in GIVEN_RANGES.items():
        v = getattr(task, name)
        if math.isnan(v):
            continue
        if not (lo < v < hi) or math.isinf(v):
            return name, v, f"({lo:g}, {hi:.6g})"
    return None


def checked_residuals(task: SectorTask) -> tuple[str, ...]:
    """The residuals whose given data are all given (not NaN): those the verdict ``feasible`` requires."""
    return tuple(n for n in RESIDUALS if all(not math.isnan(getattr(task, d)) for d in RESIDUAL_DATA[n]))


def residuals(x, task: SectorTask) -> dict[str, float]:
    """All junction residuals r17..r24 (spec §2.1.7) at unknowns x = (eps1, eps2, kappa, beta0)."""
    eps1, eps2, kappa, beta0 = x
    s = summarize(eps1, eps2, kappa, beta0, task.delta0)
    return {"r17": s.omega1 - 2.0 * task.v1 / task.D_Ci,
            "r18": s.eps1_fwd,
            "r19": s.omega2 - 2.0 * task.v2 / task.D_Ci,
            "r20": s.eps2_fwd - 2.0 * task.w2 / task.D_Ci,
            "r21": s.l_i - task.l_i,
            "r22": s.phi12 - task.phi12,
            "r23": s.phiC12 - task.phiC12,
            "r24": s.phi12 * s.eps2_fwd - task.c1 * (s.omega2 - s.omega1)}


@dataclass
class SectorSolution:
    eps1: float
    eps2: float
    kappa: float
    beta0: float
    residuals: dict[str, float]
    converged: bool
    feasible: bool
    message: str
    used: tuple[str, ...] = field(default=DEFAULT_SET)

    @property
    def x(self):
        return (self.eps1, self.eps2, self.kappa, self.beta0)

    def as_dict(self) -> dict:
        return {"eps1": self.eps1, "eps2": self.eps2, "kappa": self.kappa, "beta0": self.beta0,
                "residuals": dict(self.residuals), "used": list(self.used), "converged": self.converged,
                "feasible": self.feasible, "message": self.message}


def _feasible(x, delta0) -> tuple[bool, str]:
    eps1, eps2, kappa, beta0 = x
    if not (kappa > 0.0):
        return False, f"kappa = {kappa:.6g} must be > 0"
    if not (abs(eps1) < kappa):
        return False, f"|eps1| = {abs(eps1):.6g} must be < kappa = {kappa:.6g} (pivot inside sector A)"
    if not (abs(eps2) < 1.0):
        return False, f"|eps2| = {abs(eps2):.6g} must be < 1 (pivot inside sector B)"
    if not (0.0 < beta0 < math.pi):
        return False, f"beta0 = {beta0:.6g} rad must lie in (0, pi)"
    if not summarize(eps1, eps2, kappa, beta0, delta0).monotonic:
        return False, "sigma is not monotonic or omega_C <= 0 on [0, beta0]"
    return True, "ok"


def _junctions_met(x, task: SectorTask, junction_tol: float) -> tuple[bool, str]:
    """Every residual with given data within ``junction_tol`` (solve_sectors' ``feasible``)."""
    try:
        res = residuals(x, task)
    except (ZeroDivisionError, FloatingPointError):
        return False, "the residuals cannot be evaluated"
    unmet = [n for n in checked_residuals(task) if not abs(res[n]) <= junction_tol]
    if not unmet:
        return True, "ok"
    return False, ("unmet: " + ", ".join(f"{n} = {res[n]:.3g} ({RESIDUAL_MEANING[n]})" for n in unmet)
                   + f", each must be within {junction_tol:g}")


def _checked_norm(x, task: SectorTask) -> float:
    """Norm of every residual with given data (inf where they cannot be evaluated)."""
    try:
        res = residuals(x, task)
    except (ZeroDivisionError, FloatingPointError):
        return math.inf
    v = float(np.linalg.norm([res[n] for n in checked_residuals(task)]))
    return v if math.isfinite(v) else math.inf


DEFAULT_STARTS = ((0.3, 0.3, 1.0, 0.8), (0.1, 0.1, 1.5, 0.5), (0.5, 0.2, 2.0, 1.0), (0.2, 0.5, 0.8, 1.2),
                  (-0.2, 0.3, 1.2, 0.6), (0.4, -0.3, 1.0, 0.9), (0.6, 0.6, 1.5, 1.5), (0.05, 0.05, 1.0, 0.3))


def solve_sectors(task: SectorTask, use: tuple[str, ...] | str = DEFAULT_SET, starts=None,
                  tol: float = 1e-9, junction_tol: float = JUNCTION_TOL) -> SectorSolution:
    """Solve the transcendental system (25) for (eps1, eps2, kappa, beta0).

    ``use``: four residual names (root finding by Powell's hybrid method, :func:`fmus.physics.hybrid.hybrid`: SciPy's
    ``optimize.root`` "hybr" in numpy) or "lsq" (least squares over all eight with scipy.optimize.least_squares,
    for the synthesis studies; an FMU never asks it).  Several starting points; the first converged feasible
    solution with the smallest residual norm wins.  ``converged`` means every used residual is below
    ``tol`` (for "lsq": the solver converged; the residuals tell how well the data fit).

    ``feasible`` means a sector pair that can be built (:func:`_feasible`) AND meets every condition whose
    data are given, the ones not solved for included, to ``junction_tol``: the seed's combined law joins its
    phases only where (17)-(20) all hold ("the following equalities must be kept"), and its (25) asks the
    given l_i, phi12, phiC12 and c1 of the same pair.  Four of eight conditions solved for say nothing of
    the other four: with data that over-determine (25) inconsistently the solution is marked infeasible
    and the message names the unmet conditions.  Given quantities out of range (:data:`GIVEN_RANGES`)
    raise ValueError."""
    bad_given = out_of_range(task)
    if bad_given is not None:
        name, v, allowed = bad_given
        raise ValueError(f"SectorTask.{name} = {v!r} outside the allowed range {allowed}")
    lsq = use == "lsq"
    names = checked_residuals(task) if lsq else tuple(use)   # lsq: every condition whose data are given
    if not lsq:
        bad = [n for n in names if n not in RESIDUALS]
        if bad or len(names) != 4:
            raise ValueError(f"residual set {','.join(names)} must name 4 of {','.join(RESIDUALS)}")
        blind = [n for n in names if n not in checked_residuals(task)]
        if blind:
            need = sorted({d for n in blind for d in RESIDUAL_DATA[n] if math.isnan(getattr(task, d))})
            raise ValueError(f"residual set {','.join(names)}: {','.join(blind)} needs {', '.join(need)}, "
                             f"which is not given")
    elif len(names) < 4:
        raise ValueError(f"least squares needs at least 4 conditions with given data, has {','.join(names)}")

    def f(x):
        try:
            r = residuals(x, task)
        except (ZeroDivisionError, FloatingPointError):
            return np.full(len(names), 1e6)
        out = np.array([r[n] for n in names])
        return np.where(np.isfinite(out), out, 1e6)

    best = None
    with np.errstate(all="ignore"):
        for x0 in (starts or DEFAULT_STARTS):
            if lsq:   # the synthesis studies' least squares (SciPy); an FMU solves its four conditions below
                from scipy import optimize

                sol = optimize.least_squares(f, x0, bounds=([-5, -0.999, 1e-3, 1e-3], [5, 0.999, 20, math.pi - 1e-3]),
                                             xtol=1e-14, ftol=1e-14, gtol=1e-14)
                x, ok = sol.x, sol.success
            else:     # Powell's hybrid method, SciPy's "hybr" in numpy (an FMU needs no SciPy)
                x = hybrid(f, x0, xtol=1e-13)
                ok = bool(np.all(np.isfinite(x))) and float(np.max(np.abs(f(x)))) < tol
            buildable, why = _feasible(x, task.delta0) if np.all(np.isfinite(x)) else (False, "non-finite")
            feas = buildable
            if buildable:
                feas, why = _junctions_met(x, task, junction_tol)
            norm = float(np.linalg.norm(f(x)))
            # rank: a full solution; else a converged buildable pair (its unmet conditions are the news),
            # the one nearest to meeting them all; else the smallest residual
            cand = ((not (ok and feas), not (ok and buildable), _checked_norm(x, task), norm), x, ok, feas, why)
            if best is None or cand[0] < best[0]:
                best = cand
            if ok and feas and not lsq:
                break
    (_, _, _, norm), x, ok, feas, why = best
    res = residuals(x, task)
    msg = ("converged" if ok else f"not converged (|r| = {norm:.3g})") + ("" if feas else f"; infeasible: {why}")
    return SectorSolution(*map(float, x), res, bool(ok), bool(feas), msg, names)


def task_from_geometry(eps1, eps2, kappa, beta0, delta0, D_Ci: float, c1: float | None = None) -> SectorTask:
    """The 'given' quantities that a known sector geometry produces (forward problem, used to build
    self-consistent test cases; c1 defaults to the value that satisfies (24'))."""
    s = summarize(eps1, eps2, kappa, beta0, delta0)
    if c1 is None:
        c1 = s.phi12 * s.eps2_fwd / (s.omega2 - s.omega1)
    return SectorTask(D_Ci=D_Ci, v1=s.omega1 * D_Ci / 2.0, v2=s.omega2 * D_Ci / 2.0, w2=s.eps2_fwd * D_Ci / 2.0,
                      l_i=s.l_i, phi12=s.phi12, phiC12=s.phiC12, c1=c1, delta0=delta0)


# ---------------------------------------------------------------------------------------------- bed law
def bed_law(phi: float, lam: float):
    """Centric slider-crank with skat, invariants per r_K*i_CK: (S_T, v_T = dS/dphi, w_T = d2S/dphi2)."""
    s, c = math.sin(phi), math.cos(phi)
    if lam == 0.0:
        return 1.0 - c, s, c
    r = math.sqrt(1.0 - lam * lam * s * s)
    S = (1.0 - c) + (1.0 - r) / lam
    v = s + lam * s * c / r
    w = c + lam * (c * c - s * s) / r + lam ** 3 * s * s * c * c / r ** 3
    return S, v, w


def bed_law_jerk(phi: float, lam: float) -> float:
    """d3S_T/dphi3 of :func:`bed_law`'s slider-crank (its w_T differentiated once more, r = sqrt(1 - lam^2 sin^2)):
    -sin - 4 lam s c / r + 3 lam^3 s c (c^2 - s^2) / r^3 + 3 lam^5 s^3 c^3 / r^5."""
    s, c = math.sin(phi), math.cos(phi)
    if lam == 0.0:
        return -s
    r = math.sqrt(1.0 - lam * lam * s * s)
    sc = s * c
    return -s - 4.0 * lam * sc / r + 3.0 * lam ** 3 * sc * (c * c - s * s) / r ** 3 + 3.0 * lam ** 5 * sc ** 3 / r ** 5


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


class _Sector:
    """One solved sector pair evaluated at a distance theta in crank angle from its point beta = 0."""

    def __init__(self, x, delta0):
        self.eps1, self.eps2, self.kappa, self.beta0 = x
        self.delta0 = delta0
        self.k1 = self.kappa + 1.0
        self.summary = summarize(*x, delta0)
        self.sign = self.summary.sign
        beta = np.linspace(0.0, self.beta0, 257)
        sigma = sector_arrays(beta, *x, delta0)[0]
        self._theta_tab = self.sign * (sigma - sigma[0])   # increasing from 0 to phi12
        self._beta_tab = beta
        self.sigma0 = math.atan2(*reversed(self._uw(0.0)))

    def _uw(self, beta):
        dl = self.delta0 + self.k1 * beta
        return (self.eps2 * math.cos(dl) + self.k1 * math.cos(beta) - self.eps1 * math.cos(self.beta0),
                self.eps2 * math.sin(dl) + self.k1 * math.sin(beta) - self.eps1 * math.sin(self.beta0))

    def at(self, theta: float):
        """(beta, dpsi, omega_C, eps_C) where |sigma(beta) - sigma(0)| = theta; dpsi = sign*(psi - psi(0))."""
        beta = float(np.interp(theta, self._theta_tab, self._beta_tab))
        args = (self.eps1, self.eps2, self.kappa, self.beta0, self.delta0)
        for _ in range(3):   # Newton on sign*(sigma(beta) - sigma0) = theta, d sigma/d beta = k1*N/D = k1/(1 + omega_C)
            sig, _, _, om, _ = sector_point(beta, *args)
            g = self.sign * _wrap(sig - self.sigma0) - theta
            beta = min(max(beta - g * (1.0 + om) / (self.k1 * self.sign), 0.0), self.beta0)
        sig, _, _, om, ec = sector_point(beta, *args)
        dsig = _wrap(sig - self.sigma0)
        return beta, self.sign * (self.k1 * beta - dsig), om, ec

    def jerk(self, beta: float) -> float:
        """d eps_C / d sigma at carrier angle beta (from :meth:`at`)."""
        return float(sector_jerk(beta, self.eps1, self.eps2, self.kappa, self.beta0, self.delta0))


class CylinderLaw:
    """Full-cycle cylinder motion law phi_C(phi) of paper A (4 phases), built once from two syntheses.

    Crank angle phi from the bed's outer dead centre; phase 1 -> 2 ends at phi2, 2 -> 3 is [phi2, phi3],
    3 -> 4 starts at phi3; cylinder angle 0 at point 1 of cycle 0.  evaluate() returns the cylinder angle
    [rad], its speed and acceleration invariants (d/dphi, d2/dphi2) and the phase number (1: acceleration
    1->2, 2: synchronous 2->3, 3: braking 3->4, 4: uniform 4->1)."""

    def __init__(self, lam, D_Ci, phi2, phi3, v1, acc: SectorSolution, acc_delta0, brk: SectorSolution, brk_delta0):
        self.lam, self.D_Ci, self.phi2, self.phi3, self.v1 = lam, D_Ci, phi2, phi3, v1
        self.acc, self.brk = _Sector(acc.x, acc_delta0), _Sector(brk.x, brk_delta0)
        self.om1 = 2.0 * v1 / D_Ci
        self.phi12 = self.acc.summary.phi12
        self.phi34 = self.brk.summary.phi12
        self.phi1 = phi2 - self.phi12
        self.phi23 = phi3 - phi2
        self.phi41 = 2.0 * math.pi - self.phi12 - self.phi23 - self.phi34
        self.S2 = bed_law(phi2, lam)[0]
        self.C12 = self.acc.summary.phiC12
        self.C23 = 2.0 * (bed_law(phi3, lam)[0] - self.S2) / D_Ci
        self.C34 = self.brk.summary.phiC12
        self.C41 = self.om1 * self.phi41
        self.per_cycle = self.C12 + self.C23 + self.C34 + self.C41     # eq. (1) divided by D_Ci/2
        self.n_rev = max(1, round(self.per_cycle / (2.0 * math.pi)))
        self.cycle_error = self.per_cycle - 2.0 * math.pi * self.n_rev  # [rad]; 0 when eq. (1) holds

    def point2_angle(self, phi: float) -> float:
        """Cylinder angle at point 2 of the cycle that contains crank angle phi."""
        k = math.floor((phi - self.phi1) / (2.0 * math.pi))
        return k * self.per_cycle + self.C12

    def _locate(self, phi: float):
        """(cycle k, phase 1-4, crank angle since the start of that phase); a junction belongs to the phase
        evaluate() has always given it (point 2 and point 3 to the synchronous phase)."""
        k = math.floor((phi - self.phi1) / (2.0 * math.pi))
        th = phi - self.phi1 - 2.0 * math.pi * k
        if th < self.phi12:
            return k, 1, th
        th -= self.phi12
        if th <= self.phi23:
            return k, 2, th
        th -= self.phi23
        if th < self.phi34:
            return k, 3, th
        return k, 4, th - self.phi34

    def evaluate(self, phi: float):
        k, phase, th = self._locate(phi)
        base = k * self.per_cycle
        if phase == 1:
            _, dpsi, om, ec = self.acc.at(self.phi12 - th)
            return base + self.C12 - dpsi, om, -self.acc.sign * ec, 1
        if phase == 2:
            S, v, w = bed_law(self.phi2 + th, self.lam)
            return base + self.C12 + 2.0 * (S - self.S2) / self.D_Ci, 2.0 * v / self.D_Ci, 2.0 * w / self.D_Ci, 2
        if phase == 3:
            _, dpsi, om, ec = self.brk.at(th)
            return base + self.C12 + self.C23 + dpsi, om, self.brk.sign * ec, 3
        return base + self.C12 + self.C23 + self.C34 + self.om1 * th, self.om1, 0.0, 4

    def jerk(self, phi: float) -> float:
        """d3 phi_C / d phi3, the slope of evaluate()'s acceleration invariant, each phase's equation
        differentiated once more.  Sector phases: d eps_C/d sigma at the same carrier angle; evaluate() gives
        the acceleration as -/+ sign*eps_C and d sigma/d phi is -/+ sign (acceleration / braking), so the
        signs cancel in both.  Synchronous phase: the bed law's third derivative scaled like its speed.
        Uniform phase: 0.  At a junction, the derivative of the phase evaluate() reports there (the law
        is continuous up to the acceleration there, not beyond)."""
        _, phase, th = self._locate(phi)
        if phase == 1:
            return self.acc.jerk(self.acc.at(self.phi12 - th)[0])
        if phase == 2:
            return 2.0 * bed_law_jerk(self.phi2 + th, self.lam) / self.D_Ci
        if phase == 3:
            return self.brk.jerk(self.brk.at(th)[0])
        return 0.0


def build_law(lam, D_Ci, phi2, phi3, v1, delta0_acc, delta0_brk, use=("r17", "r18", "r19", "r20")):
    """Synthesise the acceleration and braking sector pairs from the junction conditions and build the
    cycle law.  Returns (law, acc_solution, brk_solution); raises ValueError naming the phase if a
    synthesis does not converge to a feasible geometry."""
    _, v2, w2 = bed_law(phi2, lam)
    _, v3, w3 = bed_law(phi3, lam)
    nan = float("nan")
    sols = []
    for name, v, w, d0 in (("acceleration", v2, w2, delta0_acc), ("braking", v3, -w3, delta0_brk)):
        task = SectorTask(D_Ci=D_Ci, v1=v1, v2=v, w2=w, l_i=nan, phi12=nan, phiC12=nan, c1=nan, delta0=d0)
        sol = solve_sectors(task, use)
        if not (sol.converged and sol.feasible):
            raise ValueError(f"{name} sectors: {sol.message}")
        sols.append(sol)
    law = CylinderLaw(lam, D_Ci, phi2, phi3, v1, sols[0], delta0_acc, sols[1], delta0_brk)
    if not law.phi41 > 0.0:
        raise ValueError(f"phases overlap: uniform phase 4->1 = {law.phi41:.4g} rad <= 0")
    return law, sols[0], sols[1]


# ---------------------------------------------------------------------------------------------- component
@dataclass(frozen=True)
class GearSectorsParams(Params):
    J_cyl: float = param(2.5, "kg.m2", "moment of inertia of the printing cylinder", low=0.0, low_open=True)
    m_bed: float = param(300.0, "kg", "reduced mass of the bed (taler)", low=0.0)
    r_K: float = param(0.1, "m", "crank radius OA of the bed slider-crank", low=0.0, low_open=True)
    i_CK: float = param(2.0, "1", "skat ratio: bed displacement / slider displacement (rolling gear: 2)",
                        low=0.0, low_open=True)
    lambda_s: float = param(0.25, "1", "slider-crank ratio r_K / L_AB (0 = Scotch yoke)", low=0.0, high=0.9)
    D_C: float = param(0.33638082647978446, "m", "cylinder diameter (rims 6' on racks 6); default closes eq. (1) with n = 1",
                       low=0.0, low_open=True)
    phi2: float = param(1.0117953358399812, "rad", "crank angle of point 2 (start of printing) from bed outer dead centre",
                        low=0.0, low_open=True, high=math.pi)
    phi3: float = param(1.7, "rad", "crank angle of point 3 (end of printing)", low=0.0, low_open=True, high=math.pi)
    v1: float = param(0.8035873393247397, "1", "uniform cylinder surface speed invariant v1 = V/(omega_K r_K i_CK)",
                      low=0.0, low_open=True)
    delta0_acc: float = param(-1.2, "rad", "angle delta0 of O_B C_B at point 2, acceleration sectors 9/9'")
    delta0_brk: float = param(-1.2, "rad", "angle delta0 of O_B C_B at point 3, braking sectors 7/7'")
    c_cyl: float = param(2.0e5, "N.m/rad", "torsional stiffness sectors -> cylinder (fidelity 1)", low=0.0, low_open=True)
    d_cyl: float = param(50.0, "N.m.s/rad", "torsional damping sectors -> cylinder (fidelity 1)", low=0.0)
    fidelity: int = param(0, "", "0: rigid kinematic cylinder; 1: cylinder inertia behind a torsional compliance",
                          choices=(0, 1))

    def check(self) -> None:
        if not self.phi3 > self.phi2:
            raise ParameterError("phi3", self.phi3, f"must be > phi2 = {self.phi2:g} rad")


class GearSectorsModel(Model):
    """Main shaft (crank) -> printing cylinder by the 4-phase law, and -> bed by the slider-crank with skat.

    crank.tau is the reaction on the main shaft from the power balance
    -crank.tau*w_K = (J_cyl*a_cyl - cylinder.tau)*w_cyl + (m_bed*a_bed - bed.f)*v_bed, with the kinematic
    accelerations a = (d2x/dphi2)*w_K^2 (crank acceleration neglected), divided by w_K analytically, so it
    stays defined at w_K = 0.  Fidelity 1: the kinematic cylinder angle drives the cylinder inertia through
    (c_cyl, d_cyl); the spring torque replaces the cylinder term.

    mesh_force is the tangential tooth force the drive puts on the cylinder, referred to the cylinder's pitch
    circle of diameter D_C (the rims 6' rolling on the bed's racks 6 while printing): the torque the gearing
    applies to the cylinder, J_cyl*a_cyl - cylinder.tau (fidelity 0) or the spring torque (fidelity 1),
    divided by D_C/2; positive when it drives the cylinder forward.  The sectors' own pitch radii vary along
    the law and are known only relative to R_B (the synthesis is dimensionless), so D_C/2 is the one absolute
    pitch radius of the drive."""
    Params = GearSectorsParams
    inputs = ("crank.phi", "crank.w", "cylinder.tau", "bed.f")
    outputs = ("crank.tau", "cylinder.phi", "cylinder.w", "bed.s", "bed.v", "sync_error", "phase", "mesh_force")
    states = (Signal("phi_cyl", "rad", "angle of the cylinder (fidelity 1; kinematic at fidelity 0)"),
              Signal("w_cyl", "rad/s", "angular velocity of the cylinder"))

    def __init__(self, p: GearSectorsParams):
        super().__init__(p)
        self.L = p.r_K * p.i_CK
        D_Ci = p.D_C / self.L
        try:
            self.law, self.acc, self.brk = build_law(p.lambda_s, D_Ci, p.phi2, p.phi3, p.v1, p.delta0_acc, p.delta0_brk)
        except ValueError as e:
            name = "phi3" if str(e).startswith("braking") else "phi2"
            raise ParameterError(name, getattr(p, name), f"no feasible sector synthesis: {e}") from None

    def substep_limit(self) -> float:
        p = self.p
        if p.fidelity == 0:
            return math.inf
        return 0.25 / max(math.sqrt(p.c_cyl / p.J_cyl), p.d_cyl / p.J_cyl)

    def kinematic(self, phi, w):
        phic, om, ec, _ = self.law.evaluate(phi)
        return phic, om * w

    def initial_state(self, u):
        return np.array(self.kinematic(u[0], u[1]))

    def derivatives(self, t, x, u, t0):
        p = self.p
        phic, wc = self.kinematic(u[0] + u[1] * (t - t0), u[1])
        m = p.c_cyl * (phic - x[0]) + p.d_cyl * (wc - x[1])
        return np.array([x[1], (m + u[2]) / p.J_cyl])

    def advance(self, t0, h, x, u):
        if self.p.fidelity == 0:
            return np.array(self.kinematic(u[0] + u[1] * h, u[1]))
        return super().advance(t0, h, x, u)

    def output(self, t, x, u):
        p, L = self.p, self.L
        phi, wk, tau_c, f_bed = u
        phic, om, ec, phase = self.law.evaluate(phi)
        S, v, w = bed_law(phi, p.lambda_s)
        bed_term = (p.m_bed * L * w * wk * wk - f_bed) * L * v
        if p.fidelity == 0:
            phi_cyl, w_cyl = phic, om * wk
            m = p.J_cyl * ec * wk * wk - tau_c        # the gearing's torque on the cylinder
        else:
            phi_cyl, w_cyl = x[0], x[1]
            m = p.c_cyl * (phic - x[0]) + p.d_cyl * (om * wk - x[1])
        crank_tau = -m * om - bed_term
        sync = 0.0
        if phase == 2:
            sync = 0.5 * p.D_C * (phi_cyl - self.law.point2_angle(phi)) - L * (S - self.law.S2)
        return (crank_tau, phi_cyl, w_cyl, L * S, L * v * wk, sync, float(phase), m / (0.5 * p.D_C))

    def output_jacobian(self, t, x, u):
        """d outputs / d (crank.phi, crank.w, cylinder.tau, bed.f), every column in closed form from :meth:`output`'s
        equations.  The crank angle's column needs one derivative more of each law than output() evaluates: the
        inertial terms hold the accelerations (ec, w), so crank.tau's slope holds the third derivatives
        CylinderLaw.jerk (each phase's equation differentiated: sectors, bed law, uniform) and bed_law_jerk.
        phase is piecewise constant (slope 0); sync_error's point-2 angle is constant on each cycle and jumps
        only at point 1, outside the synchronous phase where sync_error uses it, so it adds no slope.  At a
        phase junction the slopes are those of the phase output() reports there (the law is continuous up to
        its acceleration, so crank.tau's slope in the angle jumps there)."""
        p, L = self.p, self.L
        phi, wk, tau_c, f_bed = u
        phic, om, ec, phase = self.law.evaluate(phi)
        jc = self.law.jerk(phi)
        _, v, w = bed_law(phi, p.lambda_s)
        j = bed_law_jerk(phi, p.lambda_s)
        D = np.zeros((len(self.outputs), len(self.inputs)))
        d_bed_phi = p.m_bed * L * L * wk * wk * (j * v + w * w) - f_bed * L * w   # d bed_term / d phi
        d_bed_w = 2.0 * p.m_bed * L * L * w * v * wk                           # d bed_term / d wk
        if p.fidelity == 0:
            D[0] = (-p.J_cyl * jc * wk * wk * om - (p.J_cyl * ec * wk * wk - tau_c) * ec - d_bed_phi,
                    -2.0 * p.J_cyl * ec * wk * om - d_bed_w, om, L * v)
            D[1, 0] = om                                     # cylinder.phi = phi_C(phi)
            D[2, :2] = (ec * wk, om)                         # cylinder.w = om * wk
            D[7, :3] = (p.J_cyl * jc * wk * wk, 2.0 * p.J_cyl * ec * wk, -1.0)   # mesh_force * D_C / 2
            d_cyl_phi = om
        else:
            m = p.c_cyl * (phic - x[0]) + p.d_cyl * (om * wk - x[1])
            dm_phi = p.c_cyl * om + p.d_cyl * ec * wk
            D[0] = (-dm_phi * om - m * ec - d_bed_phi, -p.d_cyl * om * om - d_bed_w, 0.0, L * v)
            D[7, :2] = (dm_phi, p.d_cyl * om)                # mesh_force * D_C / 2
            d_cyl_phi = 0.0                                  # cylinder.phi is the state
        D[7] /= 0.5 * p.D_C
        D[3, 0] = L * v                                      # bed.s = L S
        D[4, :2] = (L * w * wk, L * v)                       # bed.v = L v wk
        if phase == 2:
            D[5, 0] = 0.5 * p.D_C * d_cyl_phi - L * v
        return D
