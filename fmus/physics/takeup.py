"""Seed 000's clearance take-up, as the paper states it (feeder.md sections 2.5-2.7).

The seed freezes the feeder at a position i (crank-conrod angle beta, four-bar pressure angle theta, stone
radius R3 = l30 + a_k S) and writes the two-mass model (1):

    I1 phi1'' = c1 (omega0 t - phi1) - r cos(beta + theta) F
    I2 gamma'' = (1 - chi) R3 F - R3 F_load                     F = c2 * (deformation of the c2 element)

with the play in the c2 element (the conrod / stone pin).  The relative coordinate of the joint is
q = r cos(beta) phi1 - R3 gamma [m]; the pin is free while 0 < q < clearance and presses on the front wall
for q > clearance (penetration p = q - clearance), on the back wall for q < 0.  This is the dimensionally
consistent form of (1) (feeder.md [T]); the printed normalised form is r = R3 = 1.  F_load is not in the seed
(its take-up is "without external forces", eq. 5, and F_load = 0 is the default); it is here only to place
the running feeder's take-up, which happens at a load reversal, on the same model.

Reduced to the joint coordinate q, the crank side and the rocker are two bodies of mass
    m1 = I1 / (r^2 cos(beta) cos(beta + theta)),   m2 = I2 / ((1 - chi) R3^2)
(m1 v1 + m2 v2 is conserved in a contact when c1 = 0, v1 = r cos(beta) phi1', v2 = R3 gamma'), and the take-up
frequency (7) is lambda_m^2 = c2 (1/m1 + 1/m2).  The seed's impact formulas are the central-impact
formulas of two such bodies with mass ratio alpha_m; :func:`mass_ratio` gives m1/m2, which equals alpha_m
when r = R3 and beta = theta = chi = 0 (the seed's normalised case).

Seed definitions (seed 000 text before (8)): alpha_m = I1 / I2 and alpha_c = c1 / c2 with c2 reduced to the
rotation of the normalised model.  In the consistent model eqs (8)-(9) hold with B1 = alpha_c (1 - chi) /
alpha_m exactly when alpha_c = c1 / (c2 R3^2) (:func:`seed_alpha_c`), lambda in units of sqrt(c2 R3^2 / I2).

The contact: the no-pull Kelvin-Voigt law the FMUs use (fmus.physics.contact): a linear spring k (c2, in
series with the joint's own stiffness c4 when given: eq. (13)) and a viscous damper d = 2 zeta sqrt(k m_eff),
m_eff = m1 m2 / (m1 + m2), zeta calibrated so that a FREE two-body impact (c1 = 0, no load) whose force
cannot pull rebounds with Newton's restitution e (contact.kelvin_voigt_zeta).  A contact ends where its force
k pen + d pen' returns to zero, with the penetration still positive (the bodies then separate); it never
pulls, so a free impact with e < 1 lasts less than half a take-up period pi/lambda_m, and exactly that
with e = 1.  Contact onsets and ends are located as events of the integrator (scipy solve_ivp, DOP853).

Classification (:func:`is_classical`): the seed's alpha_y, natural period over take-up duration, with the
simulated duration of the first contact; only the first contact's peak is checked against all later ones
(:func:`first_governs`, the seed's "only the first impact counts", S0-6).

Beta over the seed's whole 0-180 deg: beyond 90 deg cos(beta) < 0 and the crank pin closes the play on the
other wall (the approach speed is negative); where cos(beta) cos(beta + theta) < 0 the crank side's reduced
mass is negative (the conrod's reaction pushes the crank on, into the joint) and the take-up frequency
lambda_m^2 = k (1/m1 + 1/m2) can be negative: ``TakeUpResult.stable`` says so, the simulation still runs.

The seed's Fig. 3 (the roller's lift-off from its groove wall for K0 and C0, by the rolling condition, and the
crossing of the play after it) is :mod:`fmus.physics.liftoff`: the rigid mechanism's forces on the groove, not
this two-mass model.

Pure numpy/scipy; no FMI import.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from . import contact
from .two_mass import two_mass_frequencies


# --------------------------------------------------------------------------------------------------------------
# seed definitions and closed forms
# --------------------------------------------------------------------------------------------------------------

def seed_alpha_c(c1, c2, R3):
    """The seed's stiffness ratio in the consistent model: c1 [N.m/rad] / (c2 [N/m] * R3^2 [m^2])."""
    return np.asarray(c1, dtype=float) / (np.asarray(c2, dtype=float) * np.asarray(R3, dtype=float) ** 2)


def reduced_masses(I1, I2, r, R3, beta, theta=0.0, chi=0.2):
    """(m1, m2) [kg]: the crank side and the rocker reduced to the joint coordinate q (module docstring)."""
    cc = math.cos(beta) * math.cos(beta + theta)
    m1 = I1 / (r * r * cc) if cc != 0.0 else math.inf      # negative where cc < 0 (module docstring)
    return m1, I2 / ((1.0 - chi) * R3 * R3)


def mass_ratio(I1, I2, r, R3, beta, theta=0.0, chi=0.2):
    """m1 / m2, the mass ratio the seed's formulas (10)-(12) call alpha_m (= I1/I2 at r = R3, beta = theta
    = chi = 0)."""
    m1, m2 = reduced_masses(I1, I2, r, R3, beta, theta, chi)
    return m1 / m2


def v3y_first(alpha_m, e, v_pin, V3):
    """Seed eq. (10): velocity of the stone pin (roller centre) after the take-up impact.
    v_pin = omega1 r cos(beta) (the crank pin along the joint), V3 = the pin's velocity before."""
    return (alpha_m * (1.0 + e) * v_pin + (1.0 - alpha_m * e) * V3) / (alpha_m + 1.0)


def v3y_rebound(alpha_m, e, v_pin, V3):
    """Seed eq. (11) as printed: the velocity after a rebound and re-contact,
    [(alpha_m - e) V3 + (1 + e) v_pin] / (alpha_m + 1): the central-impact velocity of the body of mass
    ratio alpha_m moving at V3 against a unit body moving at v_pin."""
    return ((alpha_m - e) * V3 + (1.0 + e) * v_pin) / (alpha_m + 1.0)


def v3y_roller(alpha_m, e, v_pin, V3, mu, nu):
    """Seed eq. (12): the roller striking the groove wall, v_pin projected by cos(mu) cos(nu)."""
    return v3y_first(alpha_m, e, v_pin * math.cos(mu) * math.cos(nu), V3)


def takeup_constants(p: "TakeUpParams") -> tuple[float, float, float, float]:
    """(C1, C2, C3, C4) of eq. (14) for the undamped free take-up of eq. (5) (c1 = 0, no load, joint closed)
    from the seed's initial conditions phi1 = 0, phi1' = omega1, gamma = 0, R3 gamma' = the rocker side's
    speed at t = 0 (the onset; q then closes at v = p.v_in).  With I1 phi1'' = -k b q, b = r cos(beta +
    theta), q = v sin(lambda t) / lambda: C1 = C4 = 0, C3 = k b v / (I1 lambda^3), C2 = omega1 - C3 lambda."""
    lam = p.lambda_m()
    c3 = p.k * p.r * math.cos(p.beta + p.theta) * p.v_in / (p.I1 * lam ** 3)
    return 0.0, p.omega1 - c3 * lam, c3, 0.0


def crank_angle(t, constants, lambda_m):
    """Seed eq. (14): phi1(t) = C1 + C2 t + C3 sin(lambda t) + C4 cos(lambda t), one frequency lambda_m (the
    paper prints lambda1 and lambda2; eq. (7)'s roots are 0, 0, +-i lambda_m)."""
    c1, c2, c3, c4 = constants
    t = np.asarray(t, dtype=float)
    return c1 + c2 * t + c3 * np.sin(lambda_m * t) + c4 * np.cos(lambda_m * t)


def pin_displacement(t, constants, lambda_m, p: "TakeUpParams", projection: float = 1.0):
    """Seeds eqs (15) (projection 1) and (19) (projection cos(mu) cos(nu)): the displacement of the pin (the
    roller) on the rocker side,
        z(t) = a (C1 + C2 t) + [a - I1 lambda^2 / (k r cos(beta + theta))] (C3 sin(lambda t) + C4 cos(lambda t)),
    a = r cos(beta) projection.  With projection 1 it is R3 gamma(t) = r cos(beta) phi1 - q: the first
    equation of (5) gives q = -I1 phi1'' / (k r cos(beta + theta)).  (The paper prints stray factors t in the
    bracket; feeder.md [R].)"""
    c1, c2, c3, c4 = constants
    t = np.asarray(t, dtype=float)
    a = p.r * math.cos(p.beta) * projection
    osc = c3 * np.sin(lambda_m * t) + c4 * np.cos(lambda_m * t)
    return a * (c1 + c2 * t) + (a - p.I1 * lambda_m ** 2 / (p.k * p.r * math.cos(p.beta + p.theta))) * osc


def approach(t, v_pin, V3, lambda_m, e=1.0):
    """Seed eqs (16) (pin) and (20) (roller, v_pin projected by cos(mu) cos(nu)): the approach of the joint
    during an undamped take-up, z(t) = (v_pin - e V3) sin(lambda t) / lambda (e: as :func:`z_max`)."""
    return (v_pin - e * V3) * np.sin(lambda_m * np.asarray(t, dtype=float)) / lambda_m


def z_max(v_pin, V3, lambda_m, e=1.0):
    """Seed eqs (17) and (21): largest approach (deformation) of the joint, (v_pin - e V3) / lambda_m.  The
    seed prints the factor e_y on V3; with the rocker at rest (V3 = 0, the seed's take-up) it drops out.
    For an undamped contact it is the exact peak of the take-up oscillation of eq. (5)."""
    return (v_pin - e * V3) / lambda_m


def impact_force(v_pin, V3, lambda_m, stiffness, e=1.0):
    """Seed eqs (18) and (22): F = z_max * stiffness.  The paper prints c2 there and c4 (pin-eye) or c'4
    (roller-groove) in eq. (13); with the joint's own stiffness c4 in series with c2 the connection is
    k = c2 c4 / (c2 + c4) (``TakeUpParams.k``), lambda_m is eq. (7) with k, and F = k z_max is also eq. (13)'s
    c4 z_joint with the joint's own share of the approach z_joint = F / c4 (:func:`joint_deformation`)."""
    return z_max(v_pin, V3, lambda_m, e) * stiffness


def joint_deformation(force, c4):
    """Eq. (13) read backwards: the joint's own deformation z = F / c4 [m] (c4: the joint's stiffness)."""
    return force / c4


def roller_force(F_pin, mu, nu):
    """Seed eq. (23): F_roller = F_pin cos(mu) cos(nu) (first approximation from the velocity plan)."""
    return F_pin * math.cos(mu) * math.cos(nu)


# --------------------------------------------------------------------------------------------------------------
# the frozen model of eq. (1), simulated
# --------------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class TakeUpParams:
    """Seed 000's frozen take-up at one position (values: feeder.md section 3.1 unless marked)."""
    I2: float = 0.00043          # kg.m2, rocker inertia (seed)
    alpha_m: float = 1.0         # I1 / I2 (seed: 0.5-2 in the impact study, 0.5-5 in the frequency study)
    alpha_c: float = 0.2         # c1 / (c2 R3^2) (seed: 0.05-0.3 studied, threshold 0.3-0.4)
    c2: float = 5.0e5            # N/m, conrod / pin stiffness (seed: 1e5-1e6)
    c4: float = math.inf         # N/m, the joint's own contact stiffness, in series with c2: c4 of the pin-eye
    #                              joint (eq. 13), c'4 of the roller-groove joint (eq. 22); inf: the seed's
    #                              (18) and (22) as printed, the joint as stiff as c2 alone
    r: float = 0.040             # m, crank radius (seed 001)
    R3: float = 0.12             # m, stone radius l30 + a_k S (the feeder's groove: 0.071-0.12 m)
    beta: float = 0.0            # rad, crank-conrod angle at the take-up (seed: 0-180 deg)
    theta: float = 0.0           # rad, pressure angle in the four-bar (not given by the seed)
    chi: float = 0.2             # friction as a fraction of the elastic force (seed)
    e: float = 0.2               # restitution at the take-up (seed)
    clearance: float = 20e-6     # m, total play (seed: 5-20 um)
    omega1: float = 2 * math.pi * 150.0 / 60.0   # rad/s, crank speed (seed: 100-200 rpm)
    V3: float = 0.0              # m/s, the pin's (rocker's) velocity at the onset: 0 = rocker at rest (seed)
    load: float = 0.0            # N, force on the pin pressing the rocker back (0 in the seed's eq. 5)
    projection: float = 1.0      # cos(mu) cos(nu) for the roller-groove take-up (eqs 12, 19-22); 1 = pin
    periods: float = 4.0         # length of the run after the first onset, in take-up periods 2 pi/lambda_m

    def check(self) -> None:
        for name, lo, hi in (("I2", 0.0, math.inf), ("alpha_m", 0.0, math.inf), ("alpha_c", -1e-300, math.inf),
                             ("c2", 0.0, math.inf), ("r", 0.0, math.inf), ("R3", 0.0, math.inf),
                             ("clearance", 0.0, math.inf), ("periods", 0.0, math.inf)):
            v = getattr(self, name)
            if not lo < v < hi:
                raise ValueError(f"TakeUpParams.{name} = {v!r} outside ({lo:g}, {hi:g})")
        if not self.c4 > 0.0:
            raise ValueError(f"TakeUpParams.c4 = {self.c4!r} outside (0, inf] (inf: no joint compliance beside c2)")
        if not 0.0 <= self.chi < 1.0:
            raise ValueError(f"TakeUpParams.chi = {self.chi!r} outside [0, 1)")
        if not 0.0 < self.e <= 1.0:
            raise ValueError(f"TakeUpParams.e = {self.e!r} outside (0, 1]")
        if self.e < contact.E_MIN_KELVIN_VOIGT:
            raise ValueError(f"TakeUpParams.e = {self.e!r} below {contact.E_MIN_KELVIN_VOIGT:.4f}, the least "
                             f"restitution of a no-pull Kelvin-Voigt contact (allowed: [{contact.E_MIN_KELVIN_VOIGT:.4f},"
                             f" 1])")

    @property
    def I1(self) -> float:
        return self.alpha_m * self.I2

    @property
    def c1(self) -> float:
        return self.alpha_c * self.c2 * self.R3 ** 2

    @property
    def k(self) -> float:
        """Stiffness of the connection along the joint [N/m]: c2 and c4 in series (c2 when c4 is inf)."""
        return self.c2 if math.isinf(self.c4) else self.c2 * self.c4 / (self.c2 + self.c4)

    @property
    def v_pin(self) -> float:
        """The crank pin's speed along the joint, omega1 r cos(beta) (0.4-0.8 m/s at 100-200 rpm, beta = 0)."""
        return self.omega1 * self.r * math.cos(self.beta)

    @property
    def v_in(self) -> float:
        """Relative approach speed at the onset: v_pin * projection - V3."""
        return self.v_pin * self.projection - self.V3

    def masses(self) -> tuple[float, float]:
        return reduced_masses(self.I1, self.I2, self.r, self.R3, self.beta, self.theta, self.chi)

    def lambda_m(self) -> float:
        """Take-up frequency, eq. (7), in the consistent form [rad/s]: c2 (1/m1 + 1/m2) is
        fmus.physics.two_mass's lambda_m^2, written here through the reduced masses so that it also holds at
        alpha_c = 0, where two_mass flags the vanishing lambda3."""
        m1, m2 = self.masses()
        lam2 = self.k * (1.0 / m1 + 1.0 / m2)
        return math.sqrt(lam2) if lam2 > 0.0 else math.nan   # nan: no free take-up oscillation (``stable``)

    def frequencies(self):
        """lambda1, lambda3, lambda_m, alpha_y = 2 lambda1/lambda3 of eqs (7)-(9) at this position."""
        return two_mass_frequencies(self.I1, self.I2, self.c1, self.k, self.r, self.R3, self.beta, self.theta,
                                    self.chi)


@dataclass(frozen=True)
class Contact:
    """One contact of the joint within a run (times from the first onset)."""
    onset: float                 # s
    end: float                   # s; nan when the joint is still closed at the run's end
    wall: int                    # +1 the front wall (q = clearance), -1 the back wall (q = 0)
    v_in: float                  # m/s, approach speed at the onset (along the joint, into the wall)
    F_peak: float                # N, largest force of the contact
    z_peak: float                # m, largest penetration of the contact


@dataclass
class TakeUpResult:
    params: TakeUpParams
    v_in: float                  # m/s, relative approach speed at the first onset (signed: < 0 on the back wall)
    classical: bool              # the seed's classical impact (module docstring): see :func:`is_classical`
    opened: bool                 # the first contact's force returned to zero within the run
    duration: float              # s, the first contact's duration (the run's remainder if it never opened)
    e_measured: float            # exit over approach relative speed of the first contact (nan if closed)
    v_rocker_after: float        # m/s, R3 gamma' when the first contact opened (nan if closed)
    v_crank_after: float         # m/s, r cos(beta) phi1' when the first contact opened (nan if closed)
    z_peak: float                # m, largest penetration of the first contact
    F_peak: float                # N, largest contact force of the first contact
    contacts: int                # contact onsets within the run
    period: float                # s, 2 pi / |lambda_m| (the free take-up's period; |.|: see ``stable``)
    F_min: float = math.nan      # N, the law's smallest value inside the contacts of the run: < 0 only where
    #                              the events missed a graze (the force applied is clipped at zero there)
    stable: bool = True          # lambda_m^2 > 0: the free take-up oscillates (False: cos(beta) cos(beta +
    #                              theta) < 0 with a crank side lighter than the rocker along the joint)
    history: tuple = ()          # every contact of the run (:class:`Contact`)
    first_governs: bool = True   # S0-6 checked: no later contact of the run is harder than the first
    alpha_y: float = math.nan    # the seed's alpha_y measured: natural period 2 pi / lambda3 over ``duration``
    t: np.ndarray = field(repr=False, default=None)   # time samples [s] (event points included)
    q: np.ndarray = field(repr=False, default=None)   # joint coordinate q [m]
    F: np.ndarray = field(repr=False, default=None)   # joint force [N], signed as q's wall (0 while free)
    y: np.ndarray = field(repr=False, default=None)   # states (phi1, phi1', gamma, gamma') at the samples


def _rhs_factory(p: TakeUpParams, d: float, q0: float = 0.0):
    """(rhs(t, y, mode), joint(y)): eq. (1) with the joint force of ``mode`` (+1 front wall, -1 back wall, 0
    free); q = r cos(beta) phi1 - R3 gamma + q0 (q0 places the start on a wall with phi1 = gamma = 0).  The
    force of a mode is the no-pull Kelvin-Voigt law; the events of :func:`simulate` end the mode where it
    returns to zero."""
    I1, I2, c1, c2 = p.I1, p.I2, p.c1, p.k
    a, b = p.r * math.cos(p.beta), p.r * math.cos(p.beta + p.theta)
    w0, chi, R3, load, gap = p.omega1, p.chi, p.R3, p.load, p.clearance

    def rhs(t, y, mode):
        phi, w, g, gw = y
        q = a * phi - R3 * g + q0
        qd = a * w - R3 * gw
        if mode > 0:        # a contact only pushes: a dip of the law below zero that the events' step-end
            F = max(c2 * (q - gap) + d * qd, 0.0)      # sign test misses (a graze) applies no force
        elif mode < 0:
            F = min(c2 * q + d * qd, 0.0)
        else:
            F = 0.0
        return [w, (c1 * (w0 * t - phi) - b * F) / I1, gw, ((1.0 - chi) * R3 * F - R3 * load) / I2]

    def joint(y):
        return a * y[0] - R3 * y[2] + q0, a * y[1] - R3 * y[3]

    return rhs, joint


def _wall_force(p: TakeUpParams, d: float, joint, wall: int):
    """The push of ``wall`` (+1 front, -1 back) as a function of the state, positive while it pushes:
    c2 pen + d pen_dot, pen = q - clearance (front) or -q (back); the no-pull force is max(0, this)."""
    c2, gap = p.k, p.clearance

    def push(y):
        q, qd = joint(y)
        return c2 * (q - gap) + d * qd if wall > 0 else -(c2 * q + d * qd)
    return push


def _event(fun, level: float, direction: int):
    """A terminal event: fun(y) crossing ``level`` in ``direction``."""
    def f(t, y, mode):
        return fun(y) - level
    f.terminal, f.direction = True, direction
    return f


def contact_damping(p: TakeUpParams) -> float:
    """Damping coefficient d [N.s/m] of the joint: the no-pull Kelvin-Voigt law of
    :mod:`fmus.physics.contact` (the one the FMUs use), calibrated so that a free two-body impact (c1 = 0)
    rebounds with restitution e.  Its reduced mass m1 m2 / (m1 + m2); where the crank side's reduced mass is
    not positive (cos(beta) cos(beta + theta) <= 0: no free impact exists to calibrate on) the rocker's m2
    alone, the joint's only positive mass."""
    m1, m2 = p.masses()
    meff = m1 * m2 / (m1 + m2) if m1 > 0.0 and math.isfinite(m1) else m2
    return contact.kelvin_voigt_damping(p.k, meff, p.e)


def simulate(p: TakeUpParams, rtol: float = 1e-10, samples: int = 0) -> TakeUpResult:
    """Integrate the frozen eq. (1) from the first contact onset: the crank at omega1 on the drive's rest
    position, the rocker at V3 / R3, the joint on the wall the pin closes (front for an approach speed
    v_in = omega1 r cos(beta) projection - V3 > 0, back for v_in < 0, as for beta > 90 deg), closing at |v_in|
    (the free flight over the play before is uniform: no force acts).  A contact ends where its no-pull force
    returns to zero (the penetration is then still positive: the bodies separate with the speed of that
    instant) and begins where the penetration and the pushing force are both positive.  The roller-groove
    take-up (projection = cos(mu) cos(nu), eqs 12, 19-22) is the same 1-D joint with its approach speed
    projected on the groove normal.  ``samples`` > 0 keeps a dense record of q and the force."""
    from scipy.integrate import solve_ivp

    p.check()
    v_in = p.v_in
    scale = abs(p.omega1 * p.r) + abs(p.V3)
    if not abs(v_in) > 1e-12 * scale:
        raise ValueError(f"TakeUpParams: approach speed omega1 r cos(beta) projection - V3 = {v_in:.4g} m/s at "
                         f"beta = {math.degrees(p.beta):.6g} deg: the pin does not close the play (allowed: "
                         f"|approach| > 1e-12 of omega1 r + |V3|)")
    m1, m2 = p.masses()
    lam2 = p.k * (1.0 / m1 + 1.0 / m2)
    period = 2.0 * math.pi / math.sqrt(abs(lam2))
    t_end = p.periods * period
    d = contact_damping(p)
    wall0 = 1 if v_in > 0.0 else -1
    rhs, joint = _rhs_factory(p, d, q0=p.clearance if wall0 > 0 else 0.0)
    push = {w: _wall_force(p, d, joint, w) for w in (1, -1)}
    eps = 1e-9 * p.clearance * p.k        # onset a hair inside (see below), as a force
    pen = {1: lambda y: joint(y)[0] - p.clearance, -1: lambda y: -joint(y)[0]}
    a = p.r * math.cos(p.beta)
    y = np.array([0.0, p.omega1, 0.0, (p.v_pin - v_in) / p.R3])
    t, mode = 0.0, wall0
    history, onset, peak = [], (0.0, wall0, abs(v_in)), (0.0, 0.0)
    F_min = math.inf
    ts, qs, fs, ys = [0.0], [joint(y)[0]], [0.0], [y.tolist()]
    first_exit = None
    segments = 0
    while t < t_end - 1e-15 * t_end:
        segments += 1
        if segments > 100000:
            raise RuntimeError(f"take-up: more than 100000 contact changes before t = {t:.6g} s "
                               f"(alpha_c = {p.alpha_c}, alpha_m = {p.alpha_m}, e = {p.e})")
        if mode != 0:
            ev = [_event(push[mode], 0.0, -1)]
        else:
            # an onset needs penetration and a pushing force: min of the two (as forces) crossing a hair above
            # zero (1e-9 of the play), so that a contact that ended grazing under a force pressing it back
            # re-closes after a finite time instead of an endless cascade of zero-length segments
            ev = [_event(lambda y, w=w: min(p.k * pen[w](y), push[w](y)), eps, 1) for w in (1, -1)]
        sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=rtol, atol=1e-14, events=ev, args=(mode,),
                        dense_output=True)
        if not sol.success:
            raise RuntimeError(f"take-up integration failed at t = {t:.6g} s: {sol.message}")
        hit = next((k for k, te in enumerate(sol.t_events) if len(te)), None)
        t_new = float(sol.t_events[hit][0]) if hit is not None else float(sol.t[-1])
        if mode != 0 or samples > 0:
            n = max(3, int(samples * (t_new - t) / t_end)) if samples > 0 else 0
            tt = np.linspace(t, t_new, max(n, 2001 if not history else 401))
            Y = sol.sol(tt)
            q = joint(Y)[0]                         # on every sample at once (the same operations as per sample)
            law = push[mode](Y) if mode != 0 else np.zeros(len(tt))
            F = np.maximum(law, 0.0)                                        # as applied
            if mode != 0:
                F_min = min(F_min, float(law[:-1].min()) if len(law) > 1 else 0.0)
                z = q - p.clearance if mode > 0 else -q
                peak = (max(peak[0], float(F.max())), max(peak[1], float(z.max())))
            if samples > 0:
                ts.extend(tt[1:].tolist())
                qs.extend(q[1:].tolist())
                fs.extend((mode * F[1:]).tolist())
                ys.extend(Y[:, 1:].T.tolist())
        y = sol.y_events[hit][0].copy() if hit is not None else sol.y[:, -1]
        if hit is None:
            t = t_new
            break
        if mode != 0:                     # a contact ends: its force is back to zero
            history.append(Contact(onset[0], t_new, onset[1], onset[2], *peak))
            if first_exit is None:
                qd = joint(y)[1]
                first_exit = (-qd / v_in, p.R3 * y[3], a * y[1])
            mode = 0
        else:                             # a contact begins
            mode = 1 if hit == 0 else -1
            onset, peak = (t_new, mode, abs(joint(y)[1])), (0.0, 0.0)
        t = t_new
    if mode != 0:                         # still closed at the run's end
        history.append(Contact(onset[0], math.nan, onset[1], onset[2], *peak))
    first = history[0]
    opened = first_exit is not None
    duration = first.end if opened else t
    e_meas, vr, vc = first_exit if opened else (math.nan, math.nan, math.nan)
    lam3 = 0.0 if p.c1 == 0.0 else float(p.frequencies().lambda3)     # c1 = 0: no slow mode, alpha_y infinite
    res = TakeUpResult(p, v_in, False, opened, duration, e_meas, vr, vc, first.z_peak, first.F_peak,
                       len(history), period, F_min=F_min if history else math.nan, stable=lam2 > 0.0,
                       history=tuple(history), first_governs=first_governs(history),
                       alpha_y=(math.inf if lam3 == 0.0 else 2.0 * math.pi / lam3 / duration if lam3 > 0.0
                                else math.nan))
    res.classical = is_classical(res)
    if samples > 0:
        res.t, res.q, res.F, res.y = np.asarray(ts), np.asarray(qs), np.asarray(fs), np.asarray(ys)
    return res


def first_governs(history) -> bool:
    """S0-6, checked: "the impact force ... reaches its largest value only at the first collision, and that
    is enough to account for it in strength calculations" -- true when no later contact of the run peaks
    above the first (a later one may equal it to 1e-9: a contact held to the run's end by a load)."""
    return all(c.F_peak <= history[0].F_peak * (1.0 + 1e-9) for c in history[1:])


def classify(**kw) -> TakeUpResult:
    """:func:`simulate` with :class:`TakeUpParams` built from keywords."""
    return simulate(replace(TakeUpParams(), **kw))


ALPHA_Y_CLASSICAL = 4.0   # a classical impact is over within a quarter of the natural period (is_classical)


def is_classical(res: TakeUpResult) -> bool:
    """The seed's classical impact, from its own measure: alpha_y, "the ratio of the period of the system's
    natural oscillations to the duration of the clearance take-up" (text before eq. (8)), here with the
    simulated duration of the first contact: alpha_y = (2 pi / lambda3) / duration (``res.alpha_y``; infinite
    without a drive stiffness, c1 = 0, where the slow mode stops).  The seed states no threshold on alpha_y.
    A take-up is taken as a classical impact when the first contact opens again (its force back to zero)
    within a quarter of the natural period, alpha_y > 4: the impulse is delivered before the slow oscillation
    it excites reaches its extreme, so the drive's motion during the contact is negligible -- the premise of
    the impact formulas (10)-(12).  Only a stable take-up (lambda_m^2 > 0) can be one.  Two kinds of first
    contact make up the map: collisions, which open by themselves after about 0.7-1.1 pi/lambda_m, and
    contacts the drive holds closed until its slow mode turns, about pi/lambda3 (alpha_y near 2).  A collision
    is not classical where the natural period is itself short (large alpha_c: alpha_y 3-5 for collisions on
    the study's grid), so alpha_y spreads continuously from 1.3 to beyond 20 and the threshold is a choice;
    at beta = 0 the study's first non-classical alpha_c is the same for thresholds 3 to 8 (docs/seeds_000_001.md)."""
    return bool(res.stable and res.opened and res.alpha_y > ALPHA_Y_CLASSICAL)
