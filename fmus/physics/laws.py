"""Laws of periodic motion (LPM, Tir's notation) and the dwell cycle built from them.

A law maps the normalised phase k in [0, 1] to the displacement invariant a(k) (a(0) = 0, a(1) = 1), the
velocity invariant b = da/dk and the acceleration invariant c = d2a/dk2 (spec feeder.md §2.1).  A follower
of stroke H driven over a phase of crank angle Phi at constant crank speed w moves as
x = H*a, x' = H*b*w/Phi, x'' = H*c*(w/Phi)^2.

Every law is written once as piece functions ``f(k, m)`` where ``m`` is the math namespace
(:mod:`fmus.physics.mathns`: ``SCALAR`` for one crank angle in the integrators' inner loop, ``NUMPY`` for the
synthesis tools' arrays, ``VECTOR`` for a batch of variants, each element the scalar's bits), and a law, a dwell
cycle (:class:`DwellCycle`) and a kulisa law (``groove.KulisaLaw``) are each one function of its argument and the
namespace, so every evaluation shares the formulas.

Registry (``get_law(name, **params)``):

  K0           harmonic (cosine acceleration), a = (1 - cos pi k)/2                          [T, standard]
  C0           cycloidal (sine acceleration), a = k - sin(2 pi k)/(2 pi)                       [T, standard]
  0000         the source names this harmonic-group law without a formula.  OUR READING: the
               double-harmonic law a = [(1 - cos pi k) - (1 - cos 2 pi k)/4]/2 (a sum of harmonics, so
               harmonic group; c(0) = 0, c(1) = -pi^2: no soft impact at the start, one at the end).
  power        eps = C[1 - (2k)^n] on 0 <= k <= 1/2 with point-symmetric completion about k = 1/2 and
               C = 4(n+1)(n+2)/[n(n+3)] from a(1) = 1 (spec §2.1.3); parameter n > 0 (default 2).  This is also
               seed 001's power-type form, the type its harmonic slider laws give the rocker (its Fig. 4); it is
               no law the seed names, and it is not 1,3 or 1,5 (below).
  polydynamic  3-4-5 polynomial a = 10k^3 - 15k^4 + 6k^5 (Savvin group placeholder, spec §2.1.4);
  4567         4-5-6-7 polynomial a = 35k^4 - 84k^5 + 70k^6 - 20k^7 (zero jerk at both ends).
  P6           Stoddart's P6 is only named in the source (no formula).  WE DO NOT HAVE IT: "P6" here is a
               documented stand-in, the asymmetric cycloidal law: half sine-waves of acceleration on
               [0, k_m] (run-up) and [k_m, 1] (run-out), c = (pi/k_m)*sin(pi k/k_m) and
               c = -(pi/(1-k_m))*sin(pi (k-k_m)/(1-k_m)); c = 0 at both ends (no soft impact at the
               start, S1-8).  Parameter k_m in (0, 1) (default 0.4); k_m = 1/2 gives C0.
  composite    cycloidal run-up + harmonic run-out with parameter k_m (spec §2.1.5, [T]).
  bed004       seed 004's carrier law synthesised so that the bed moves uniformly through the printing zone
               with the published four-bar and z3/z5 = 3, swing 40 deg (fmus.physics.bed_law); parameter
               k_m = the bed's run-up share of the working stroke (default 0.2).
  bed004r      seed 004's carrier return law: with the four-bar's idle stroke it returns the bed by the harmonic
               law K0 (fmus.physics.bed_law.carrier_return_law); a law for the return phase (law_return = 9).

Named by seed 001 without anything to build them from (``get_law`` refuses them, saying so, with no stand-in):
the catalogue codes "group, number" of Tir & Senyk [10] (group 1 harmonic, 2 cycloidal, 3 polydynamic) that the
seed uses as law names, "1,3", "1,4", "1,5" (harmonic), "2,12" (cycloidal), "3,8" (printed "Pd 3,8",
polydynamic), and Shun's law "Ш" ("Шуна", cycloidal).  [10] is not in our copy and the seed prints none of
their formulas.  What the seed says of each is in :data:`SEED_UNDEFINED`.
"""
from __future__ import annotations

import functools
import math
from typing import Callable, Sequence

import numpy as np

from .mathns import SCALAR, VECTOR, namespace  # noqa: F401
from .motion_law import Law  # noqa: F401  (Law belongs to this module's interface: callers import it from here)

PI = math.pi


# -- the laws ------------------------------------------------------------------------------------------------
def _k0(k, m):
    return (1.0 - m.cos(PI * k)) / 2.0, (PI / 2.0) * m.sin(PI * k), (PI ** 2 / 2.0) * m.cos(PI * k)


def _k0_jerk(k, m):
    return -(PI ** 3 / 2.0) * m.sin(PI * k)


def _c0(k, m):
    return (k - m.sin(2 * PI * k) / (2 * PI), 1.0 - m.cos(2 * PI * k), 2 * PI * m.sin(2 * PI * k))


def _c0_jerk(k, m):
    return 4 * PI ** 2 * m.cos(2 * PI * k)


def _double_harmonic(k, m):
    return (0.5 * ((1.0 - m.cos(PI * k)) - 0.25 * (1.0 - m.cos(2 * PI * k))),
            0.5 * (PI * m.sin(PI * k) - 0.5 * PI * m.sin(2 * PI * k)),
            0.5 * PI ** 2 * (m.cos(PI * k) - m.cos(2 * PI * k)))


def _double_harmonic_jerk(k, m):
    return 0.5 * PI ** 3 * (2.0 * m.sin(2 * PI * k) - m.sin(PI * k))


def _p345(k, m):
    p = m.pow
    return (10 * p(k, 3) - 15 * p(k, 4) + 6 * p(k, 5), 30 * p(k, 2) - 60 * p(k, 3) + 30 * p(k, 4),
            60 * k - 180 * p(k, 2) + 120 * p(k, 3))


def _p345_jerk(k, m):
    return 60 - 360 * k + 360 * k ** 2


def _p4567(k, m):
    p = m.pow
    return (35 * p(k, 4) - 84 * p(k, 5) + 70 * p(k, 6) - 20 * p(k, 7),
            140 * p(k, 3) - 420 * p(k, 4) + 420 * p(k, 5) - 140 * p(k, 6),
            420 * p(k, 2) - 1680 * p(k, 3) + 2100 * p(k, 4) - 840 * p(k, 5))


def _p4567_jerk(k, m):
    return 840 * k - 5040 * k ** 2 + 8400 * k ** 3 - 4200 * k ** 4


def power_constant(n: float) -> float:
    """Normalisation C of the power family: a(1) = 1 (spec §2.1.3)."""
    return 4.0 * (n + 1.0) * (n + 2.0) / (n * (n + 3.0))


def _power(n: float) -> Law:
    if not (n > 0.0 and math.isfinite(n)):
        raise ValueError(f"law parameter n = {n!r} of law 'power' must be > 0")
    C = power_constant(n)

    def first(k, m):
        t = 2.0 * k
        return (C * (k * k / 2.0 - m.pow(t, n + 2) / (4.0 * (n + 1) * (n + 2))),
                C * (k - m.pow(t, n + 1) / (2.0 * (n + 1))), C * (1.0 - m.pow(t, n)))

    def first_jerk(k, m):
        t = 2.0 * k
        return -2.0 * n * C * (t ** (n - 1.0) if t > 0.0 or n >= 1.0 else math.inf)   # n < 1: infinite at k = 0

    def second(k, m):
        a, b, c = first(1.0 - k, m)
        return 1.0 - a, b, -c

    def second_jerk(k, m):
        return first_jerk(1.0 - k, m)

    return Law("power", f"power family eps = C[1-(2k)^n], n = {n:g}, C = {C:.6g}, point-symmetric completion",
               ((0.5, first), (1.0, second)), (("n", n),), (first_jerk, second_jerk))


# Seed 001 names its laws by the catalogue codes "group, number" of Tir & Senyk [10] (1 harmonic, 2 cycloidal,
# 3 polydynamic; Savvin [11] for the polydynamic group) and gives none of their formulas.  The one formula it
# prints, "harmonic slider LPMs ("K0", "0000") [are realised] by a [rocker acceleration] of the type
# eps_k = C[1 - (2k)^n], C the constant of the acceleration peak, n the power coefficient (Fig. 4)", is the
# type of the rocker's transformed law, n a property of that result: it is the law 'power' (above), never
# a reading of a law's name.
_HARMONIC_SAYS = ("the seed: harmonic laws ('K0', 1,4 and similar) give a smooth cam profile, without sharpening "
                  "for most parameter sets; 1,5 drives its Fig. 7 and 1,3, 1,5 its Fig. 4")
SEED_UNDEFINED = {
    "1,3": ("harmonic", 3, _HARMONIC_SAYS),
    "1,4": ("harmonic", 4, _HARMONIC_SAYS),
    "1,5": ("harmonic", 5, _HARMONIC_SAYS),
    "2,12": ("cycloidal", 12, "the seed: profiles of the forward stroke like a sine wave with a sharpening at its "
                              "end"),
    "3,8": ("polydynamic", 8, "printed 'Pd 3,8'; the seed: an approximate pause or constant-speed stretches of "
                              "the pushers, its forward profile undercut"),
    "Ш": ("cycloidal", None, "Shun's law, 'Шуна'; the seed: would cut the acceleration peaks substantially, its "
                             "forward profiles violate the no-sharpening condition"),
}
"""Laws seed 001 names without a formula: name -> (group, catalogue number in [10] or None, what the seed says)."""
_UNDEFINED_ALIASES = {"Shuna": "Ш", "Sh": "Ш", "Шуна": "Ш", "Pd 3,8": "3,8", "2.12": "2,12", "3.8": "3,8",
                      "1.3": "1,3", "1.4": "1,4", "1.5": "1,5"}


def _undefined(name: str) -> str:
    """The one-line refusal of a law seed 001 names but does not define."""
    group, number, says = SEED_UNDEFINED[name]
    source = "Tir & Senyk [10] and Savvin [11]" if group == "polydynamic" else "Tir & Senyk [10]"
    what = (f"catalogue law {number} of the {group} group of {source}" if number is not None
            else f"a law of the {group} group")
    return (f"law {name!r} is {what}, which seed 001 names but does not define (not in our copy): no stand-in "
            f"({says})")


def _check_km(name: str, km: float) -> None:
    if not (0.0 < km < 1.0):
        raise ValueError(f"law parameter k_m = {km!r} of law {name!r} must be in (0, 1)")


def _p6(k_m: float) -> Law:
    _check_km("P6", k_m)
    A = PI / k_m
    B = PI / (1.0 - k_m)

    def up(k, m):
        x = PI * k / k_m
        return A * k_m / PI * (k - k_m / PI * m.sin(x)), A * k_m / PI * (1.0 - m.cos(x)), A * m.sin(x)

    def up_jerk(k, m):
        return A * PI / k_m * m.cos(PI * k / k_m)

    def down(k, m):
        L = 1.0 - k_m
        u = (k - k_m) / L
        V = 2.0  # velocity at k_m: 2*A*k_m/pi
        return (k_m + V * L * u - B * L * L / PI * (u - m.sin(PI * u) / PI),
                V - B * L / PI * (1.0 - m.cos(PI * u)), -B * m.sin(PI * u))

    def down_jerk(k, m):
        L = 1.0 - k_m
        return -B * PI / L * m.cos(PI * (k - k_m) / L)

    return Law("P6", f"stand-in for Stoddart P6 (no formula in the source): asymmetric cycloidal, k_m = {k_m:g}",
               ((k_m, up), (1.0, down)), (("k_m", k_m),), (up_jerk, down_jerk))


def _composite(k_m: float) -> Law:
    _check_km("composite", k_m)
    H1 = (PI / 2.0) * k_m / (2.0 * (1.0 - k_m) + (PI / 2.0) * k_m)
    H2 = 1.0 - H1
    L = 1.0 - k_m

    def up(k, m):
        u = k / (2.0 * k_m)
        return (2.0 * H1 * (u - m.sin(2 * PI * u) / (2 * PI)), H1 * (1.0 - m.cos(2 * PI * u)) / k_m,
                H1 * PI * m.sin(2 * PI * u) / k_m ** 2)

    def up_jerk(k, m):
        return H1 * PI ** 2 * m.cos(PI * k / k_m) / k_m ** 3      # du/dk = 1 / (2 k_m)

    def down(k, m):
        u = 0.5 + (k - k_m) / (2.0 * L)
        return (H1 + 2.0 * H2 * ((1.0 - m.cos(PI * u)) / 2.0 - 0.5), H2 * (PI / 2.0) * m.sin(PI * u) / L,
                H2 * (PI ** 2 / 4.0) * m.cos(PI * u) / L ** 2)

    def down_jerk(k, m):
        u = 0.5 + (k - k_m) / (2.0 * L)
        return -H2 * (PI ** 3 / 8.0) * m.sin(PI * u) / L ** 3      # du/dk = 1 / (2 L)

    return Law("composite", f"cycloidal run-up + harmonic run-out, k_m = {k_m:g} (spec 2.1.5)",
               ((k_m, up), (1.0, down)), (("k_m", k_m),), (up_jerk, down_jerk))


_FIXED = {
    "K0": Law("K0", "harmonic (cosine acceleration)", ((1.0, _k0),), (), (_k0_jerk,)),
    "C0": Law("C0", "cycloidal (sine acceleration)", ((1.0, _c0),), (), (_c0_jerk,)),
    "0000": Law("0000", "our reading of the undefined harmonic-group law '0000': double-harmonic law",
                ((1.0, _double_harmonic),), (), (_double_harmonic_jerk,)),
    "polydynamic": Law("polydynamic", "3-4-5 polynomial (polydynamic placeholder)", ((1.0, _p345),), (),
                       (_p345_jerk,)),
    "4567": Law("4567", "4-5-6-7 polynomial (zero jerk at the ends)", ((1.0, _p4567),), (), (_p4567_jerk,)),
}
_FAMILIES: dict[str, tuple[Callable[..., Law], dict[str, float]]] = {
    "power": (_power, {"n": 2.0}),
    "P6": (_p6, {"k_m": 0.4}),
    "composite": (_composite, {"k_m": 0.4}),
}


def _bed004(k_m: float) -> Law:
    """Seed 004's carrier law for a uniform bed (fmus.physics.bed_law), k_m = the bed's run-up share."""
    from .bed_law import carrier_law
    try:
        return carrier_law(k_m).law
    except ValueError as e:
        raise ValueError(f"law bed004, k_m (law_km) = {k_m!r}: {e}") from None


_FAMILIES["bed004"] = (_bed004, {"k_m": 0.2})


def _bed004r(k_m: float) -> Law:
    """Seed 004's carrier return law for a harmonic bed return (fmus.physics.bed_law); k_m is not used."""
    from .bed_law import carrier_return_law
    return carrier_return_law()


_FAMILIES["bed004r"] = (_bed004r, {"k_m": 0.2})
LAW_NAMES: tuple[str, ...] = ("K0", "C0", "0000", "power", "polydynamic", "4567", "P6", "composite", "bed004",
                              "bed004r")
"""The laws the components take; the index in this tuple is their Integer ``law`` parameter (so the FMUs'
interface does not change when a law is added for the synthesis tools only)."""
KNOWN_LAWS: tuple[str, ...] = LAW_NAMES
"""Every name :func:`get_law` builds (the components' laws; seed 001's named laws are refused)."""


@functools.lru_cache(maxsize=256)
def _family(name: str, kw: tuple) -> Law:
    """A family's law for its parameters, made once (a law is immutable; the seed's carrier laws take milliseconds
    to synthesise and check, and a batch builds one model per variant)."""
    return _FAMILIES[name][0](**dict(kw))


def get_law(name: str, **params: float) -> Law:
    """The law ``name``; family parameters: ``n`` (power), ``k_m`` (P6, composite).  Unused ones are ignored."""
    if name in _FIXED:
        return _FIXED[name]
    if name in _FAMILIES:
        _, defaults = _FAMILIES[name]
        return _family(name, tuple((p, float(params.get(p, v))) for p, v in defaults.items()))
    seed = _UNDEFINED_ALIASES.get(name, name)
    if seed in SEED_UNDEFINED:
        raise ValueError(f"{_undefined(seed)}; known laws: {', '.join(KNOWN_LAWS)}")
    raise ValueError(f"unknown law of periodic motion {name!r}; known laws: {', '.join(KNOWN_LAWS)}")


# -- the dwell cycle -----------------------------------------------------------------------------------------
TWO_PI = 2.0 * PI


class DwellCycle:
    """Normalised follower position s(phi) in [0, 1] over one turn of the crank.

    Starting at crank angle ``phi_start``: forward phase ``phase_forward`` (s: 0 -> 1 by law ``forward``),
    dwell ``dwell`` at s = 1, return phase ``phase_return`` (s = 1 - a_return(k)), then a dwell at s = 0 for
    the rest of the turn, 2*pi - phase_forward - dwell - phase_return (>= 0).  All angles in rad.
    """

    def __init__(self, forward: Law, ret: Law, phase_forward: float, phase_return: float, dwell: float = 0.0,
                 phi_start: float = 0.0):
        for name, v in (("phase_forward", phase_forward), ("phase_return", phase_return)):
            if not (v > 0.0 and math.isfinite(v)):
                raise ValueError(f"{name} = {v!r} rad must be > 0")
        if not (dwell >= 0.0):
            raise ValueError(f"dwell = {dwell!r} rad must be >= 0")
        rest = TWO_PI - phase_forward - dwell - phase_return
        if rest < -1e-12:
            raise ValueError(f"phase_forward + dwell + phase_return = {TWO_PI - rest!r} rad exceeds 2*pi")
        self.forward, self.ret = forward, ret
        self.phase_forward, self.phase_return, self.dwell = phase_forward, phase_return, dwell
        self.dwell_bottom = max(rest, 0.0)
        self.phi_start = phi_start
        self._t1 = phase_forward
        self._t2 = phase_forward + dwell
        self._t3 = phase_forward + dwell + phase_return

    def at(self, phi, m=None):
        """(s, ds/dphi, d2s/dphi2) at crank angle(s) ``phi`` [rad]: ``m`` the namespace (mathns.namespace: ``math``
        or SCALAR for one float, numpy (the default) or NUMPY for an array, VECTOR for a batch of variants).  One
        phase per angle (forward, top dwell, return, bottom dwell), its law evaluated on the angles in it only.
        The return phase's d2s/dphi2 is -c / P^2 with P^2 as each evaluation has always written it (P*P for
        one float and for a batch, whose elements are one float's; P**2 for numpy)."""
        m = m if m is SCALAR else namespace(m)
        th = (phi - self.phi_start) % TWO_PI
        P, F = self.phase_return, self.phase_forward
        if m.scalar:
            if th < self._t1:
                a, b, c = self.forward.at(th / F, m)
                return a, b / F, c / F ** 2
            if th < self._t2:
                return 1.0, 0.0, 0.0
            if th < self._t3:
                a, b, c = self.ret.at((th - self._t2) / P, m)
                return 1.0 - a, -b / P, -c / (P * P)
            return 0.0, 0.0, 0.0
        th = np.asarray(th, dtype=float)
        f = th < self._t1
        if m is VECTOR and f.all():     # every variant on the forward phase: no subsets (the same numbers)
            a, b, c = self.forward.at(th / F, m)
            return a, b / F, c / F ** 2
        s, s1, s2 = np.zeros_like(th), np.zeros_like(th), np.zeros_like(th)
        if f.any():
            a, b, c = self.forward.at(th[f] / F, m)
            s[f], s1[f], s2[f] = a, b / F, c / F ** 2
        s[~f & (th < self._t2)] = 1.0
        r = (th >= self._t2) & (th < self._t3)
        if r.any():
            a, b, c = self.ret.at((th[r] - self._t2) / P, m)
            s[r], s1[r], s2[r] = 1.0 - a, -b / P, -c / (P * P if m is VECTOR else P ** 2)
        return s, s1, s2

    __call__ = at   # also cycle(phi, m); hot paths call .at (calling an instance costs ~100 ns more)

    def jerk(self, phi: float) -> float:
        """d3s/dphi3 at one crank angle: the phase :meth:`at` takes there, its law's jerk (Law.jerk) scaled
        like its acceleration by one more 1/phase; 0 in the dwells."""
        th = (phi - self.phi_start) % TWO_PI
        if th < self._t1:
            return self.forward.jerk(th / self.phase_forward) / self.phase_forward ** 3
        if th < self._t2:
            return 0.0
        if th < self._t3:
            P = self.phase_return
            return -self.ret.jerk((th - self._t2) / P) / (P * P * P)
        return 0.0


def follower_motion(cycle: DwellCycle, phi, w: float, H: float):
    """Position, velocity, acceleration (H*s, H*s'*w, H*s''*w^2) of a follower of stroke H at crank speed w."""
    s, s1, s2 = cycle(phi)
    return H * s, H * s1 * w, H * s2 * w * w


def dwell_cycle(forward: str | Law, phase_forward: float, phase_return: float, dwell: float = 0.0,
                ret: str | Law | None = None, phi_start: float = 0.0, **law_params: float) -> DwellCycle:
    """Convenience constructor by law names (``ret`` defaults to the forward law)."""
    f = forward if isinstance(forward, Law) else get_law(forward, **law_params)
    r = f if ret is None else (ret if isinstance(ret, Law) else get_law(ret, **law_params))
    return DwellCycle(f, r, phase_forward, phase_return, dwell, phi_start)
