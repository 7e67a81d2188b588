"""The centre distance of seed 002's sector pairs against the paper's condition on it (paper A, spec
bed_drives.md section 1.1 item 5).

Each pair's sectors turn about the main shaft C_A and the cylinder's axis C_B; their centre distance
l = |C_A C_B| (eq. 5, per R_B of the pair) changes over the pair's phase.  The paper: "if the synthesis does
not give a law of l like the cylinder's lowering or raising law, or l = const, an angular correction of the
sector gearing is made".

This module models the first way out: the cylinder's axis follows the pairs' l.  Such a cylinder sits at
one height while it prints (2 -> 3: its rims on the bed's racks) and at one height in the uniform phase
(4 -> 1: the concentric pair 8/8' at a fixed distance).  Each pair's size is its own (the paper takes R_B
from the design), so the print heights agree when R_B,7/R_B,9 = l_2/l_3 (braking 7/7' over acceleration 9/9');
the heights of the uniform phase then agree only if l_1/l_2 = l_4/l_3 (``closure`` = 0).  A lowering law
that sets the cylinder on the form at rest also has dl/dphi = 0 at points 2 and 3 (``slope_print``).

``lift_report`` measures a built law (l at the ends, its spread, its slopes, monotony, the closure);
``closing_braking_delta0`` solves the braking pair's delta0 (the one given quantity its synthesis (17)-(20)
leaves free) so that the closure holds: the sectors solved with the centre distance as a condition.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .gear_sectors import GearSectorsModel, GearSectorsParams, _sector_terms


@dataclass(frozen=True)
class PairLift:
    """The centre distance of one pair over its phase, per R_B of the pair; slopes per radian of crank angle."""
    l_print: float        # at the printing side: point 2 (acceleration) or 3 (braking), beta = 0
    l_uniform: float      # at the uniform side: point 1 or 4, beta = beta0
    l_min: float
    l_max: float
    slope_print: float    # |dl/dphi| at the printing side
    slope_uniform: float  # |dl/dphi| at the uniform side
    monotonic: bool       # l moves one way from one side to the other

    @property
    def spread(self) -> float:
        """(l_max - l_min)/l_min: 0 for a constant centre distance."""
        return self.l_max / self.l_min - 1.0


@dataclass(frozen=True)
class LiftReport:
    acc: PairLift               # sectors 9/9', points 1 -> 2
    brk: PairLift               # sectors 7/7', points 3 -> 4
    radius_ratio: float         # R_B,7/R_B,9 that puts both print heights at one l: l_2/l_3
    closure: float              # (l_1/l_2)/(l_4/l_3) - 1: 0 when the uniform phase has one height too


def pair_lift(x, delta0: float, n: int = 2001) -> PairLift:
    """The centre distance of a solved pair x = (eps1, eps2, kappa, beta0) over beta in [0, beta0] (eq. 5):
    l = sqrt(D), dl/dphi = (dD/dbeta / (2 l)) / (d sigma/d beta), d sigma/d beta = k1 N / D."""
    eps1, eps2, kappa, beta0 = x
    beta = np.linspace(0.0, beta0, n)
    _, _, _, D, N, Db, _ = _sector_terms(beta, eps1, eps2, kappa, beta0, delta0, np.cos, np.sin)
    l = np.sqrt(D)
    slope = np.abs(Db / (2.0 * l) * D / ((kappa + 1.0) * N))
    step = np.diff(l)
    return PairLift(float(l[0]), float(l[-1]), float(l.min()), float(l.max()), float(slope[0]), float(slope[-1]),
                    bool(np.all(step > 0.0) or np.all(step < 0.0)))


def lift_report(law) -> LiftReport:
    """The centre distance of a :class:`~fmus.physics.gear_sectors.CylinderLaw`'s two pairs."""
    acc = pair_lift((law.acc.eps1, law.acc.eps2, law.acc.kappa, law.acc.beta0), law.acc.delta0)
    brk = pair_lift((law.brk.eps1, law.brk.eps2, law.brk.kappa, law.brk.beta0), law.brk.delta0)
    return LiftReport(acc, brk, acc.l_print / brk.l_print,
                      (acc.l_uniform / acc.l_print) / (brk.l_uniform / brk.l_print) - 1.0)


def closing_braking_delta0(p: GearSectorsParams, bracket: tuple[float, float]) -> tuple[float, LiftReport, float]:
    """delta0 of the braking pair that closes the lift law (LiftReport.closure = 0), the acceleration pair
    kept: root of the closure in ``bracket`` [rad] (brentq; both ends must give a feasible synthesis and
    closures of opposite sign, else ValueError).  Returns (delta0_brk, its report, the law's cycle error
    of eq. (1) [rad], which the braking pair's changed turn moves)."""
    def closure(d0: float) -> float:
        return lift_report(GearSectorsModel(replace(p, delta0_brk=d0)).law).closure

    lo, hi = (closure(b) for b in bracket)
    if not lo * hi < 0.0:
        raise ValueError(f"delta0_brk bracket {bracket}: closures {lo:.4g}, {hi:.4g} have one sign")
    from scipy import optimize   # here: every FMU imports this module, and scipy.optimize is slow to import

    d0 = optimize.brentq(closure, *bracket, xtol=1e-13)
    law = GearSectorsModel(replace(p, delta0_brk=d0)).law
    return d0, lift_report(law), law.cycle_error


def speed_of_lift(slope: float, R_B: float, omega_K: float) -> float:
    """Speed [m/s] of the cylinder's axis for a slope |dl/dphi| (per R_B per rad), pair radius R_B [m] and
    crank speed omega_K [rad/s]."""
    return slope * R_B * omega_K


