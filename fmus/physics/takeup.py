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

The contact: linear spring c2 and a viscous damper d chosen so that a FREE two-body impact (c1 = 0, no
load) has Newton's restitution e: zeta = -ln(e) / sqrt(pi^2 + ln(e)^2), d = 2 zeta sqrt(c2 m_eff),
m_eff = m1 m2 / (m1 + m2); a contact ends when the penetration returns to zero (the Kelvin-Voigt closed form
e = exp(-zeta pi / sqrt(1 - zeta^2)) holds exactly for that end condition).  Contact onsets and ends are
located as events of the integrator (scipy solve_ivp, DOP853), not at step boundaries.

Classification of a take-up (the seed's "classical impact", S0-3): the first contact is CLASSICAL when the
joint opens again within one period of the take-up oscillation, 2 pi / lambda_m (a free impact lasts half
a damped period, pi / (lambda_m sqrt(1 - zeta^2))); NON-CLASSICAL when the joint is still closed after that
period (the drive or the load keeps it closed: a loaded contact, not a collision).

Pure numpy/scipy; no FMI import.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

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
    m1 = I1 / (r * r * cc) if cc != 0.0 else math.inf      # negative where cc < 0 (TakeUpParams refuses it)
    return m1, I2 / ((1.0 - chi) * R3 * R3)


def mass_ratio(I1, I2, r, R3, beta, theta=0.0, chi=0.2):
    """m1 / m2, the mass ratio the seed's formulas (10)-(12) call alpha_m (= I1/I2 at r = R3, beta = theta
    = chi = 0)."""
    m1, m2 = reduced_masses(I1, I2, r, R3, beta, theta, chi)
    return m1 / m2


def damping_ratio(e: float) -> float:
    """Kelvin-Voigt damping ratio whose free impact (ending at zero penetration) has restitution e."""
    if not 0.0 < e <= 1.0:
        raise ValueError(f"restitution e = {e!r} outside (0, 1]")
    le = math.log(e)
    return -le / math.sqrt(math.pi ** 2 + le * le)


def restitution_of(zeta: float) -> float:
    """The inverse of :func:`damping_ratio`: e = exp(-zeta pi / sqrt(1 - zeta^2)), 0 <= zeta < 1."""
    return math.exp(-zeta * math.pi / math.sqrt(1.0 - zeta * zeta))


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


def z_max(v_pin, V3, lambda_m, e=1.0):
    """Seed eq. (17): largest approach (deformation) of pin and conrod eye, (v_pin - e V3) / lambda_m.  The
    seed prints the factor e_y on V3; with the rocker at rest (V3 = 0, the seed's take-up) it drops out.
    For an undamped contact it is the exact peak of the take-up oscillation of eq. (5)."""
    return (v_pin - e * V3) / lambda_m


def impact_force(v_pin, V3, lambda_m, c2, e=1.0):
    """Seed eq. (18): F = z_max * c2 (eq. (13) writes c4, the joint stiffness reduced to the pin)."""
    return z_max(v_pin, V3, lambda_m, e) * c2


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
        if not 0.0 <= self.chi < 1.0:
            raise ValueError(f"TakeUpParams.chi = {self.chi!r} outside [0, 1)")
        if not 0.0 < self.e <= 1.0:
            raise ValueError(f"TakeUpParams.e = {self.e!r} outside (0, 1]")
        if math.cos(self.beta) * math.cos(self.beta + self.theta) <= 1e-12:
            raise ValueError(f"TakeUpParams: cos(beta) cos(beta + theta) = "
                             f"{math.cos(self.beta) * math.cos(self.beta + self.theta):.3g} <= 0 at beta = "
                             f"{self.beta!r}, theta = {self.theta!r}: the crank does not drive the joint "
                             f"(allowed: cos(beta) cos(beta + theta) > 1e-12)")

    @property
    def I1(self) -> float:
        return self.alpha_m * self.I2

    @property
    def c1(self) -> float:
        return self.alpha_c * self.c2 * self.R3 ** 2

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
        return math.sqrt(self.c2 * (1.0 / m1 + 1.0 / m2))

    def frequencies(self):
        """lambda1, lambda3, lambda_m, alpha_y = 2 lambda1/lambda3 of eqs (7)-(9) at this position."""
        return two_mass_frequencies(self.I1, self.I2, self.c1, self.c2, self.r, self.R3, self.beta, self.theta,
                                    self.chi)


@dataclass
class TakeUpResult:
    params: TakeUpParams
    v_in: float                  # m/s, relative approach speed at the first onset
    classical: bool              # the first contact opened within one take-up period
    opened: bool                 # the first contact opened at all within the run
    duration: float              # s, the first contact's duration (the run's remainder if it never opened)
    e_measured: float            # exit over approach relative speed of the first contact (nan if closed)
    v_rocker_after: float        # m/s, R3 gamma' when the first contact opened (nan if closed)
    v_crank_after: float         # m/s, r cos(beta) phi1' when the first contact opened (nan if closed)
    z_peak: float                # m, largest penetration of the first contact
    F_peak: float                # N, largest contact force of the first contact
    contacts: int                # contact onsets within the run
    period: float                # s, 2 pi / lambda_m
    t: np.ndarray = field(repr=False, default=None)   # time samples [s] (event points included)
    q: np.ndarray = field(repr=False, default=None)   # joint coordinate q [m]


def _rhs_factory(p: TakeUpParams, d: float):
    I1, I2, c1, c2 = p.I1, p.I2, p.c1, p.c2
    a, b = p.r * math.cos(p.beta), p.r * math.cos(p.beta + p.theta)
    w0, chi, R3, load, gap = p.omega1, p.chi, p.R3, p.load, p.clearance

    def rhs(t, y, mode):
        phi, w, g, gw = y
        q = a * phi - R3 * g
        qd = a * w - R3 * gw
        if mode > 0:
            F = c2 * (q - gap) + d * qd
        elif mode < 0:
            F = c2 * q + d * qd
        else:
            F = 0.0
        return [w, (c1 * (w0 * t - phi) - b * F) / I1, gw, ((1.0 - chi) * R3 * F - R3 * load) / I2]

    def joint(y):
        return a * y[0] - R3 * y[2], a * y[1] - R3 * y[3]

    return rhs, joint


def _event(joint, level: float, direction: int):
    """A terminal event: the joint coordinate q crossing ``level`` in ``direction``."""
    def f(t, y, mode):
        return joint(y)[0] - level
    f.terminal, f.direction = True, direction
    return f


def simulate(p: TakeUpParams, rtol: float = 1e-10, samples: int = 0) -> TakeUpResult:
    """Integrate the frozen eq. (1) from the first contact onset: the crank at omega1 (phi1 = omega1 t, on
    the drive's rest position), the rocker at V3 / R3, the joint at the front wall (q = clearance) closing at
    v_in = omega1 r cos(beta) projection - V3 > 0 (the free flight over the play before is uniform: no force
    acts).  The roller-groove take-up (projection = cos(mu) cos(nu), eqs 12, 19-22) is the same 1-D joint
    with its approach speed projected on the groove normal: the rocker side starts at v_pin - v_in.
    ``samples`` > 0 keeps a dense record of q for plots and tests."""
    from scipy.integrate import solve_ivp

    p.check()
    m1, m2 = p.masses()
    meff = m1 * m2 / (m1 + m2)
    zeta = damping_ratio(p.e)
    d = 2.0 * zeta * math.sqrt(p.c2 * meff)
    lam = p.lambda_m()
    period = 2.0 * math.pi / lam
    t_end = p.periods * period
    rhs, joint = _rhs_factory(p, d)
    a = p.r * math.cos(p.beta)
    v_in = p.v_in
    if not v_in > 0.0:
        raise ValueError(f"TakeUpParams: approach speed omega1 r cos(beta) projection - V3 = {v_in:.4g} m/s "
                         f"<= 0 "
                         f"(allowed: > 0, the pin must close the play)")
    # phi1 = clearance / a puts q at the front wall with gamma = 0
    y = np.array([p.clearance / a, p.omega1, 0.0, (p.v_pin - v_in) / p.R3])
    t0 = p.clearance / a / p.omega1          # drive at rest: c1 (omega0 t - phi1) = 0 at the onset
    t = t0
    mode = 1
    onsets, first_end, first_exit = 1, None, None
    z_peak, F_peak = 0.0, 0.0
    ts, qs = [0.0], [p.clearance]
    first = True
    segments = 0
    while t < t0 + t_end - 1e-15:
        segments += 1
        if segments > 100000:
            raise RuntimeError(f"take-up: more than 100000 contact changes before t = {t - t0:.6g} s "
                               f"(alpha_c = {p.alpha_c}, alpha_m = {p.alpha_m}, e = {p.e})")
        if mode > 0:
            ev = [_event(joint, p.clearance, -1)]
        elif mode < 0:
            ev = [_event(joint, 0.0, 1)]
        else:
            # re-entry a hair inside the wall (1e-9 of the play): a contact that ends grazing under a force
            # pressing it back (drive or load) re-closes after a finite time instead of an endless cascade of
            # zero-length segments; the force jump is c2 * 1e-9 * clearance (1e-8 N at the seed's values)
            eps = 1e-9 * p.clearance
            ev = [_event(joint, p.clearance + eps, 1), _event(joint, -eps, -1)]
        dense = samples > 0 or mode != 0
        sol = solve_ivp(rhs, (t, t0 + t_end), y, method="DOP853", rtol=rtol, atol=1e-14,
                        events=ev, args=(mode,), dense_output=dense)
        if not sol.success:
            raise RuntimeError(f"take-up integration failed at t = {t:.6g} s: {sol.message}")
        t_new = sol.t[-1]
        hit = next((k for k, te in enumerate(sol.t_events) if len(te)), None)
        if hit is not None:
            t_new = float(sol.t_events[hit][0])
        if mode != 0 and first:
            tt = np.linspace(t, t_new, 2001)
            Y = sol.sol(tt)
            qq = a * Y[0] - p.R3 * Y[2]
            qd = a * Y[1] - p.R3 * Y[3]
            pen = qq - p.clearance
            F = p.c2 * pen + d * qd
            z_peak = max(z_peak, float(pen.max()))
            F_peak = max(F_peak, float(F.max()))
        if samples > 0:
            tt = np.linspace(t, t_new, max(3, int(samples * (t_new - t) / t_end)))
            Y = sol.sol(tt)
            ts.extend((tt[1:] - t0).tolist())
            qs.extend((a * Y[0][1:] - p.R3 * Y[2][1:]).tolist())
        if hit is None:
            y = sol.y[:, -1]
            t = t_new
            break
        y = sol.y_events[hit][0].copy()
        if mode != 0:                     # a contact ends
            if first:
                first_end = t_new
                qd = joint(y)[1]
                first_exit = (-qd / v_in, p.R3 * y[3], a * y[1])
                first = False
            mode = 0
        else:                             # a contact begins
            onsets += 1
            mode = 1 if hit == 0 else -1
        t = t_new
    if first_end is None:
        duration, opened = t - t0, False
        e_meas, vr, vc = math.nan, math.nan, math.nan
    else:
        duration, opened = first_end - t0, True
        e_meas, vr, vc = first_exit
    res = TakeUpResult(p, v_in, opened and duration <= period, opened, duration, e_meas, vr, vc, z_peak,
                       F_peak, onsets, period)
    if samples > 0:
        res.t, res.q = np.asarray(ts), np.asarray(qs)
    return res


def classify(**kw) -> TakeUpResult:
    """:func:`simulate` with :class:`TakeUpParams` built from keywords."""
    return simulate(replace(TakeUpParams(), **kw))
