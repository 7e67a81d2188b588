"""Clearance (backlash) contact laws, shared by every component with a joint clearance.

A joint with total clearance ``delta_c`` and relative coordinate ``q`` (along the contact normal) is
separated while ``|q| <= delta_c / 2`` and in contact, with penetration ``pen = |q| - delta_c / 2`` and
penetration rate ``pen_dot = sign(q) * q_dot``, outside that band.  The contact force acts against the
penetration and never pulls (the damping part is limited, as in the Modelica ElastoBacklash element).

Laws (``LAWS`` registry, chosen by the Integer ``contact_law`` parameter of a component):
  0 Kelvin-Voigt          F = k*pen + c*pen_dot, c = 2*zeta*sqrt(k*m_eff) with zeta solved so that the
                          contact, which cannot pull, rebounds with restitution e (kelvin_voigt_zeta)
  1 Hunt-Crossley         F = k*pen^n * (1 + chi*pen_dot), chi = 3(1 - e)/(2 v0)
  2 Lankarani-Nikravesh   F = k*pen^n * (1 + chi*pen_dot), chi = 3(1 - e^2)/(4 v0)
  3 Flores et al.         F = k*pen^n * (1 + chi*pen_dot), chi = 8(1 - e)/(5 e v0)
For the Hunt-Crossley family v0 is the approach speed at first contact: a component keeps it in its
state (``v_impact``), set when contact begins.  Every law needs the effective mass ``m_eff`` of the two
contacting bodies reduced to the contact normal (Kelvin-Voigt: its damping; Hunt-Crossley family: the
energy speed below).

Persistent contact (Hunt-Crossley family). chi ~ 1/v0 is calibrated on ONE impact (Lankarani and Nikravesh
1990: the hysteresis loss is equated to the kinetic-energy loss (1 - e^2) m v0^2 / 2 of a contact whose
elastic energy comes from the approach, so pen_max ~ v0 sqrt(m/k)); then c = k pen^n chi stays of the order of
the critical damping. Hunt and Crossley's own law has a material constant instead (e = 1 - alpha v0, chi = 3
alpha / 2, independent of the approach; the form Simbody's HuntCrossleyForce implements, alpha read off a
measured e(v) curve), which no contact history can make unbounded. When a contact closes with a negligible
approach speed (a slow take-up of the play) and the load then compresses it, the penetration is set by the
load, not by v0, and the damping c/m_eff = k pen^n chi / m_eff grows without bound as v0 -> 0 (its time
constant falls to nanoseconds at V0_FLOOR): no joint has such a damper, the result depends on how exactly a
vanishing onset speed was sampled, and no explicit integrator sized on the contact frequency stays stable
(spurious rattling). The laws here therefore calibrate chi on the energy the contact holds:

    v0 = max(approach speed at the onset, v_E(pen)),   v_E = sqrt(2 E_el / m_eff),  E_el = k pen^(n+1)/(n+1)

v_E is the approach speed of the impact whose elastic energy at this penetration equals the contact's.
During a free impact the elastic energy never exceeds the kinetic energy the contact started with
(E_el <= m_eff v0^2 / 2 - dissipated), so v_E < v0 and a free impact's v0 stays its approach speed at the onset,
to the bit; only a contact loaded beyond what its own impact could have compressed it gets v0 = v_E.  There the
damping is c = C k pen^n / v_E = C sqrt((n + 1) k m_eff pen^(n-1) / 2) (C = chi v0 of the law, e.g. 6.4
for Flores at e = 0.2): the largest damping the same law reaches at the peak of an impact of that depth,
bounded by C sqrt((n + 1) / (2 n)) times the linearised contact frequency.  The criterion has no free
constant.  That bound (``damping_per_frequency``) sizes the integrators' sub-steps (``max_substep``).

The functions take plain floats: they sit in the innermost loop of the integrators.  ``penetration``,
``kelvin_voigt_damping`` and ``contact_force`` also take a math namespace ``m`` (fmus.physics.mathns): VECTOR
for arrays over a batch of variants, each element the float's bits.
"""
from __future__ import annotations

import functools
import math

from .mathns import SCALAR

KELVIN_VOIGT, HUNT_CROSSLEY, LANKARANI_NIKRAVESH, FLORES = 0, 1, 2, 3
LAWS = {
    KELVIN_VOIGT: "Kelvin-Voigt",
    HUNT_CROSSLEY: "Hunt-Crossley",
    LANKARANI_NIKRAVESH: "Lankarani-Nikravesh",
    FLORES: "Flores",
}

V0_FLOOR = 1e-6  # [m/s] smallest approach speed used in the hysteresis factors (avoids 1/0)


def _restitution_no_pull(zeta: float) -> float:
    """Restitution of a linear spring-damper contact that cannot pull, damping ratio zeta < 1.

    Unit frequency and approach speed: p = exp(-zeta t) sin(wd t)/wd; contact ends when the force
    k p + c p' vanishes (p + 2 zeta p' = 0), before the penetration returns to zero."""
    wd = math.sqrt(1.0 - zeta * zeta)
    t = (math.pi - math.atan2(2.0 * zeta * wd, 1.0 - 2.0 * zeta * zeta)) / wd
    return abs(math.exp(-zeta * t) * (math.cos(wd * t) - zeta * math.sin(wd * t) / wd))


ZETA_MAX = 0.999
E_MIN_KELVIN_VOIGT = _restitution_no_pull(ZETA_MAX)  # about 0.136: lower e needs an overdamped contact


@functools.lru_cache(maxsize=128)
def kelvin_voigt_zeta(e: float) -> float:
    """Damping ratio for which the no-pull Kelvin-Voigt contact rebounds with restitution e.

    (The textbook zeta = -ln e / sqrt(pi^2 + ln^2 e) assumes a contact that may pull; with the force
    clipped at zero it gives too much rebound, e.g. 0.33 instead of 0.2.)  Values of e below
    E_MIN_KELVIN_VOIGT are reached only by an overdamped contact: they get ZETA_MAX."""
    if not 0.0 < e <= 1.0:
        raise ValueError(f"restitution coefficient must be in (0, 1], got {e!r}")
    if e == 1.0:
        return 0.0
    if e <= E_MIN_KELVIN_VOIGT:
        return ZETA_MAX
    # the restitution falls monotonically with zeta: bisection to the last bit, in plain floats (no scipy
    # import in the middle of a run, when the first contact closes)
    lo, hi = 0.0, ZETA_MAX
    while True:
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            return mid
        if _restitution_no_pull(mid) > e:
            lo = mid
        else:
            hi = mid


def kelvin_voigt_damping(k: float, m_eff: float, e: float, m=SCALAR, zeta=None) -> float:
    """Damping coefficient c [N.s/m] for which a no-pull Kelvin-Voigt contact rebounds with restitution e (``m``:
    the math namespace, fmus.physics.mathns; ``zeta``: :func:`kelvin_voigt_zeta` of e when the caller has it, as a
    batch of variants has each variant's)."""
    return 2.0 * (kelvin_voigt_zeta(e) if zeta is None else zeta) * m.sqrt(k * m_eff)


def energy_speed(pen: float, k: float, m_eff: float, exponent: float = 1.0) -> float:
    """v_E = sqrt(2 E_el / m_eff) [m/s], E_el = k pen^(n+1) / (n+1): the approach speed of the impact that
    stores the contact's present elastic energy (see the module docstring)."""
    return math.sqrt(2.0 * k * pen ** (exponent + 1.0) / ((exponent + 1.0) * m_eff))


def hysteresis_factor(law: int, e: float, v0: float) -> float:
    """chi [s/m] of the Hunt-Crossley family for restitution e and approach speed v0."""
    v0 = max(abs(v0), V0_FLOOR)
    if law == HUNT_CROSSLEY:
        return 1.5 * (1.0 - e) / v0
    if law == LANKARANI_NIKRAVESH:
        return 0.75 * (1.0 - e * e) / v0
    if law == FLORES:
        return 1.6 * (1.0 - e) / (e * v0)
    raise ValueError(f"law {law!r} is not a Hunt-Crossley-type law")


def penetration(q: float, q_dot: float, clearance: float, m=SCALAR) -> tuple[float, float, float]:
    """(pen, pen_dot, side): side = +1/-1 for contact on the positive/negative wall, 0 when separated (``m``: the
    math namespace, fmus.physics.mathns)."""
    half = 0.5 * clearance
    if m.scalar:
        if q > half:
            return q - half, q_dot, 1.0
        if q < -half:
            return -q - half, -q_dot, -1.0
        return 0.0, 0.0, 0.0
    up, down = q > half, q < -half
    side = m.where(up, 1.0, m.where(down, -1.0, 0.0))
    return (m.where(up, q - half, m.where(down, -q - half, 0.0)), m.where(up, q_dot, m.where(down, -q_dot, 0.0)),
            side)


def contact_force(q: float, q_dot: float, clearance: float, k: float, law: int, e: float,
                  v_impact: float, m_eff: float, exponent: float = 1.0, m=SCALAR, zeta=None) -> float:
    """Signed force along q [N] that the joint exerts to push q back into the clearance band.

    Returns a value of the sign opposite to q while in contact and 0 while separated.  ``v_impact`` is
    the approach speed at the start of the current contact (Hunt-Crossley family), ``m_eff`` the reduced
    mass (Kelvin-Voigt damping; Hunt-Crossley family: energy speed of a persistent contact).  ``m``: the math
    namespace (fmus.physics.mathns); on arrays over a batch of variants the Kelvin-Voigt law, the one the
    vectorised models step (``zeta``: each variant's :func:`kelvin_voigt_zeta`).
    """
    pen, pen_dot, side = penetration(q, q_dot, clearance, m)
    if not m.scalar:
        if law != KELVIN_VOIGT:
            raise ValueError(f"a batch of variants steps the Kelvin-Voigt contact law only, not {LAWS.get(law, law)}")
        f = k * pen + kelvin_voigt_damping(k, m_eff, e, m, zeta) * pen_dot
        return m.where(side == 0.0, 0.0, -side * m.maximum(f, 0.0))
    if side == 0.0:
        return 0.0
    if law == KELVIN_VOIGT:
        f = k * pen + kelvin_voigt_damping(k, m_eff, e) * pen_dot
    else:
        v0 = max(abs(v_impact), energy_speed(pen, k, m_eff, exponent))   # persistent contact: module docstring
        f = k * pen ** exponent * (1.0 + hysteresis_factor(law, e, v0) * pen_dot)
    return -side * max(f, 0.0)


def contact_force_slopes(q: float, q_dot: float, clearance: float, k: float, law: int, e: float,
                         v_impact: float, m_eff: float, exponent: float = 1.0) -> tuple[float, float, float, float]:
    """(F, dF/dq, dF/dq_dot, dF/dm_eff): :func:`contact_force` and its partial derivatives, for a component's
    Jacobian (its directional derivatives).  The force is :func:`contact_force`'s own value; the slopes
    differentiate its law term by term, each the derivative of one equation of this module (no copy of the law):

    * separated, or in contact with the force clipped at zero (a receding contact whose damping would pull):
      F = 0 in a neighbourhood, all slopes 0;
    * Kelvin-Voigt f = k pen + c pen_dot, c = 2 zeta sqrt(k m_eff): df/dpen = k, df/dpen_dot = c,
      df/dm_eff = pen_dot c / (2 m_eff) (the damping follows the reduced mass, which a component's pose sets);
    * Hunt-Crossley family f = k pen^n (1 + chi pen_dot), chi = C / v0 (C = chi v0 of the law):
      df/dpen_dot = k pen^n chi and df/dpen = n k pen^(n-1) (1 + chi pen_dot) + k pen^n pen_dot dchi/dpen, where
      chi moves only while the energy-calibrated v0 = v_E(pen, m_eff) is the larger speed (module docstring;
      dv_E/dpen = (n + 1) v_E / (2 pen), dv_E/dm_eff = -v_E / (2 m_eff)) and v0 is above V0_FLOOR; with the
      onset speed v_impact the larger, chi is a constant of the contact (v_impact is a state, not an argument
      the slopes follow).
    The signed force is F = -side f with pen = side q - clearance/2, pen_dot = side q_dot, so dF/dq = -df/dpen,
    dF/dq_dot = -df/dpen_dot, dF/dm_eff = -side df/dm_eff.  On the band edge, where v_E = v_impact, and where the
    clipped force reaches zero the law has a kink: the slope of the side ``contact_force`` takes is returned."""
    force = contact_force(q, q_dot, clearance, k, law, e, v_impact, m_eff, exponent)
    if force == 0.0:                                   # separated, or clipped (cannot pull): flat around here
        return force, 0.0, 0.0, 0.0
    pen, pen_dot, side = penetration(q, q_dot, clearance)
    if law == KELVIN_VOIGT:
        c = kelvin_voigt_damping(k, m_eff, e)
        f_pen, f_rate, f_mass = k, c, pen_dot * c / (2.0 * m_eff)
    else:
        v_e = energy_speed(pen, k, m_eff, exponent)
        v0 = max(abs(v_impact), v_e)
        chi = hysteresis_factor(law, e, v0)
        elastic = k * pen ** exponent
        f_pen, f_rate, f_mass = exponent * k * pen ** (exponent - 1.0) * (1.0 + chi * pen_dot), elastic * chi, 0.0
        if v_e > abs(v_impact) and v0 > V0_FLOOR:      # chi = C / v_E(pen, m_eff): it moves with both
            dchi = -chi / v0 * elastic * pen_dot       # d f / d v0
            f_pen += dchi * 0.5 * (exponent + 1.0) * v_e / pen
            f_mass = -dchi * 0.5 * v_e / m_eff
    return force, -f_pen, -f_rate, -side * f_mass


def contact_frequency(k: float, m_eff: float) -> float:
    """Angular frequency sqrt(k/m) [rad/s] of the linearised contact; sizes the integration sub-step."""
    return math.sqrt(k / m_eff)


def damping_per_frequency(law: int, e: float, exponent: float = 1.0) -> float:
    """Upper bound of the contact's damping rate c/m_eff [1/s] over its linearised frequency [rad/s].

    Kelvin-Voigt: 2 zeta.  Hunt-Crossley family: C sqrt((n + 1) / (2 n)), C = chi v0, thanks to the
    energy-calibrated v0 (module docstring), whatever the approach speed; e.g. Flores at e = 0.2: 6.4,
    at e = 0.05: 30.4, Hunt-Crossley at most 1.5."""
    if law == KELVIN_VOIGT:
        return 2.0 * kelvin_voigt_zeta(e)
    return hysteresis_factor(law, e, 1.0) * math.sqrt((exponent + 1.0) / (2.0 * exponent))


SUBSTEP_PER_PERIOD = 0.1  # [rad] sub-step times the contact frequency: ~60 RK4 sub-steps per contact period
RATE_STEP = 1.0           # largest sub-step times the damping rate c/m_eff (RK4 is stable up to 2.78 on the
                          # negative real axis; at 1 it damps 0.375 per sub-step where exp(-1) = 0.368)


def max_substep(omega: float, law: int, e: float, exponent: float = 1.0) -> float:
    """Largest explicit (RK4) sub-step [s] for a clearance contact whose linearised frequency is at most
    omega [rad/s]: SUBSTEP_PER_PERIOD / omega for the stiffness, and RATE_STEP over the bound of the
    damping rate (``damping_per_frequency`` * omega), so that a strongly damped law (Flores at low e) is
    integrated as stably as a soft one.  Depends on parameters only: sub-steps stay deterministic, runs
    bit-reproducible and rollback exact.  (For an exponent n > 1 omega must bound sqrt(n k pen^(n-1) / m);
    the components take sqrt(k / m), which does for pen < n^(-1/(n-1)) m, 0.44 m at n = 1.5.)"""
    d = damping_per_frequency(law, e, exponent)
    return (SUBSTEP_PER_PERIOD if d * SUBSTEP_PER_PERIOD <= RATE_STEP else RATE_STEP / d) / omega


# -- an end stop (a jam): the tool runs into something stiff -----------------------------------------------------
def end_stop(pen: float, pen_dot: float, k: float, c: float) -> float:
    """Force [N] (torque [N.m] on a rotation) with which a one-sided end stop pushes back against a penetration
    ``pen`` (0 or less: clear of it) that grows at ``pen_dot``: the stated stiffness ``k`` and damping ``c`` of
    a Kelvin-Voigt contact that cannot pull, max(k pen + c pen_dot, 0) (the damping part is limited, as in a
    clearance joint above)."""
    if pen <= 0.0:
        return 0.0
    return max(k * pen + c * pen_dot, 0.0)


class EndStop:
    """The end stop of a component (a mixin of its model): a jam at ``stop_position`` on one of its coordinates q,
    with ``stop_stiffness`` (0: no stop) and ``stop_damping``, of one of two kinds (``stop_catch``):

    * 0, an end stop: it blocks the forward motion past the stop and cannot pull (:func:`end_stop`); the tool
      may rebound off it (an elastic drive with a flywheel does: its twist gives the energy back);
    * 1, a catch: once the tool has reached the stop it is held there both ways by the same spring and damper,
      k (q - q_stop) + c q' (a knife stuck in the block, a bed wedged), so the drive is blocked.  Whether it has
      is the model's memory (a state: :meth:`stop_caught`, set where q passes the stop).

    The component's parameters declare the four (the stiffness tunable: a jam sets it when it appears, while the
    tool is short of the stop); ``stop_signals`` names the outputs that carry q and its rate, from which
    :meth:`stop_load` follows (a report computes the stop's load from them)."""

    stop_signals: tuple[str, str] = ("", "")

    @property
    def has_stop(self) -> bool:
        return self.p.stop_stiffness > 0.0

    def stop_penetration(self, q: float) -> float:
        """How far q is past the stop (<= 0: short of it)."""
        return q - self.p.stop_position

    def stop_holds(self, q: float, caught: float) -> bool:
        """Whether the stop acts both ways at q: a catch the tool has reached (``caught``, the memory) or is past."""
        return bool(self.p.stop_catch) and (caught >= 0.5 or q > self.p.stop_position)

    def stop_load(self, q: float, q_dot: float, caught: float = 0.0) -> float:
        """The stop's force (torque) on the coordinate: against the penetration (a catch also against leaving)."""
        p = self.p
        pen = q - p.stop_position
        if self.stop_holds(q, caught):
            return -(p.stop_stiffness * pen + p.stop_damping * q_dot)
        return -end_stop(pen, q_dot, p.stop_stiffness, p.stop_damping)

    def stop_caught(self, q: float, caught: float) -> float:
        """The memory after a (sub-)step that ends at q: 1 once a catch has been reached, else as it was."""
        return 1.0 if self.p.stop_catch and q > self.p.stop_position else caught

    def stop_energy(self, q: float, caught: float = 0.0) -> float:
        """Elastic energy the stop holds at q [J]."""
        pen = q - self.p.stop_position
        return 0.5 * self.p.stop_stiffness * pen * pen if pen > 0.0 or self.stop_holds(q, caught) else 0.0

    def stop_substep(self, inertia: float, stiffness: float = 0.0, damping: float = 0.0) -> float:
        """Largest RK4 sub-step [s] for the coordinate's ``inertia`` (mass) held between the stop and the
        component's own ``stiffness`` and ``damping`` on it (the sizing of :func:`max_substep`)."""
        p = self.p
        omega = math.sqrt((stiffness + p.stop_stiffness) / inertia)
        rate = (damping + p.stop_damping) / inertia
        return min(SUBSTEP_PER_PERIOD / omega, RATE_STEP / rate if rate > 0.0 else math.inf)

    def stop_ode_form(self) -> str | None:
        """Why the model with its stop is not an ODE a host could integrate (a catch's memory), or None."""
        if self.has_stop and self.p.stop_catch:
            return (f"{type(self).__name__} with a catching end stop (stop_catch = 1): whether the tool has reached "
                    f"it is a memory its step sets, not an ODE")
        return None
