"""Crank-rocker four-bar linkage: closed-form kinematics and an elastic coupler with a clearance joint
(seed 000, two-mass model with clearance).  The synthesis/analysis of the bed-drive four-bar of seed 004
(/work/shared/specs/bed_drives.md section 2.2.2) is :mod:`fmus.physics.fourbar_synthesis`.

Geometry (all levels).  Crank pivot O2 = (0, 0), rocker pivot O5 = (f, 0) (the frame line points from the
crank pivot to the rocker pivot), crank pin A = a*(cos phi, sin phi), rocker pin D = O5 + r*(cos psi, sin psi).
``phi`` (crank.phi) and ``psi`` (rocker.phi) are absolute angles from the frame line, counter-clockwise.
a, b, f, r = crank_length, coupler_length, frame_length, rocker_length.

Closed-form position analysis: with v = A - O5, d = |v|, theta_A = angle of v (computed as
pi + atan2(-a sin phi, f - a cos phi), continuous because f > a), gamma = acos((r^2 + d^2 - b^2)/(2 r d)):

    psi = theta_A - branch * gamma

``branch = +1`` puts D clockwise from O5->A as seen from O5 (the usual picture with the rocker above the
frame line); precisely, sign(cross(D - O5, A - O5)) = branch.  With theta_c the coupler angle (A -> D):

    dpsi/dphi   = a sin(theta_c - phi) / (r sin(theta_c - psi))
    dtheta_c/dphi = a sin(psi - phi) / (b sin(theta_c - psi))
    d2psi/dphi2 = [-a cos(theta_c - phi) - b theta_c'^2 + r psi'^2 cos(theta_c - psi)] / (r sin(theta_c - psi))
    transmission angle mu = angle at D between D->A and D->O5, cos mu = cos(theta_c - psi), mu in [0, pi].

Fidelity levels of :class:`FourBarModel` (port crank: motion in; port rocker: motion out):

0. rigid, ideal massless links: rocker.phi, rocker.w from the closed forms above; crank.tau from the power
   balance.  Sign convention of the toolkit (fmus.slave): crank.tau is the torque the four-bar exerts on the
   crank flange, rocker.tau the torque the load exerts on the rocker, so power conservation of massless links
   reads ``crank.tau * crank.w = rocker.tau * rocker.w``, i.e. crank.tau = rocker.tau * dpsi/dphi (a load
   driven forwards, rocker.tau < 0, gives crank.tau < 0).  The form "crank.tau*w_crank + rocker.tau*w_rocker
   = 0" would, with this bond convention, make a load pull the crank forwards (tested).
   joint_force (coupler tension) from the rocker's torque balance: F = rocker.tau / arm,
   arm = cross(D - O5, e_AD) (the rocker inertia is not used at this level).
1. elastic coupler: the rocker is a state (psi, w) with inertia I = rocker_inertia + coupler_mass/2 * r^2
   (ambiguity choice: the coupler mass is lumped half at each pin; the crank-pin half moves with the
   prescribed crank and, the crank acceleration not being an input, does not appear in crank.tau).
   Coupler deformation q = |D - A| - b, tension F = k q + c dq/dt (k = coupler_stiffness,
   c = coupler_damping).  The rocker receives the fraction (1 - chi) of the coupler force, chi =
   friction_ratio (seed 000 eq. (1): "the elastic force net of friction that reaches the rocker is
   (1 - chi) x the elastic force"; the crank reacts to the full force):
       I dw/dt = -(1 - chi) F arm + rocker.tau,      crank.tau = F * cross(A - O2, e_AD).
   Within a communication step the crank pin moves with the held speed: phi(t) = crank.phi + crank.w (t - t0).
   Integrated by exponential Rosenbrock steps of order 3 (integrate.exprb32_pair): the coupler mode exactly on
   its linearisation, one step per 0.01 rad of crank rotation, no sub-step sized for the coupler;
   the rates' Jacobian and time derivative in closed form (``_acc_jet_at``).
2. as 1, with a total clearance ``clearance`` (dead band |q| <= clearance/2, seed 000 "total play") at the
   coupler-rocker joint.  The coupler and the joint are one spring: the contact force is
   fmus.physics.contact.contact_force(q, dq/dt, clearance, k=coupler_stiffness, contact_law, restitution,
   v_impact, m_eff) (linear force exponent 1, so coupler_stiffness keeps its unit N/m).  m_eff = I /
   (arm^2 (1 - chi)) is the rocker inertia reduced to the coupler axis, divided by (1 - chi) so that the
   Kelvin-Voigt damping still gives the restitution ``restitution`` with the (1 - chi)-scaled force on the
   rocker.  Contact onsets and separations are located inside ``advance`` (regula falsi on the band edge)
   and recorded in the state: v_impact (approach speed at the onset, used by the Hunt-Crossley family),
   impact_count, last_impact_speed, rebound_speed.  coupler_damping is not used at this level (the
   contact law's damping replaces it).  RK4 sub-steps of at most 0.1/omega (omega = sqrt(k r^2 / I)) and
   of at most 1/(the contact law's largest damping rate), contact.max_substep: the Hunt-Crossley family's
   damping is bounded also in a contact that closed at a negligible approach speed and then carries a
   load (v0 calibrated on the contact's elastic energy, fmus.physics.contact), so it stays stable.
   Without a clearance (clearance = 0) the joint is in contact on one side or the other at all times.
   A parallelogram's arm vanishes at its dead points, and with it the m_eff above would grow without
   bound, and so would the contact law's damping coefficient (Kelvin-Voigt: 2*zeta*sqrt(k*m_eff)): the
   crank, whose arm is not zero while the rocker lags it through a dead point, would take impulses from a
   damper no real joint has.  For a parallelogram m_eff is therefore the rocker inertia reduced at the full
   arm, I / (r^2 (1 - chi)): a damping coefficient of the joint, as a real joint's, not of the pose.

Parallelogram (crank = rocker, coupler = frame, seed 003's double crank).  At its two dead points (crank
along the frame line) all four pins are collinear: the coupler's arm on the rocker vanishes and the
parallelogram branch meets the antiparallelogram branch, so a single coupler cannot say which way the
rocker goes on.  Seed 003 fits a belt between the two crank shafts for exactly this reason; the rigid
level takes the parallelogram branch (the belt's job).  At fidelity 1 and 2 the belt is an element of
its own: a torsional spring-damper between the crank and the rocker shaft (equal pulleys, ratio 1),
``belt_stiffness`` and ``belt_damping`` reduced to the shafts (c2, b2 of seed 003).  The belt torque
T_b = belt_stiffness*(phi - psi) + belt_damping*(crank.w - w) acts on the rocker, -T_b on the crank:

    I dw/dt = -(1 - chi) F arm + T_b + rocker.tau,      crank.tau = F * cross(A - O2, e_AD) - T_b.

Without a belt (both 0, the default) an elastic parallelogram under a load that brakes the rocker at a
dead point can turn into an antiparallelogram and run backwards: the linkage without its belt does that
too.  A belt is refused for any other linkage (its ratio-1 drive would fight the coupler).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import contact
from .base import Model, ParameterError, Params, Signal, last_call, param
from . import integrate_batch, variants
from .mathns import SCALAR, namespace
from .integrate import exprb32_pair, march_pair, rk4_pair, substeps

# --------------------------------------------------------------------------------------------------------
# linkage checks and closed-form kinematics (numpy: scalars or arrays)
# --------------------------------------------------------------------------------------------------------

_LINK_NAMES = ("crank_length", "coupler_length", "frame_length", "rocker_length")


def check_crank_rocker(a: float, b: float, f: float, r: float, names=_LINK_NAMES) -> None:
    """Raise ParameterError unless (a, b, f, r) is a Grashof crank-rocker with a fully rotating crank a."""
    values = (a, b, f, r)
    for n, v in zip(names, values):
        if not (math.isfinite(v) and v > 0.0):
            raise ParameterError(n, v, "must be a finite length > 0")
    if not a < min(b, f, r):
        raise ParameterError(names[0], a, f"linkage cannot be assembled as a crank-rocker: the crank must be "
                                          f"the shortest link (coupler {b:g}, frame {f:g}, rocker {r:g})")
    i = max(range(1, 4), key=lambda k: values[k])
    others = sum(values[1:]) - values[i]
    if not a + values[i] < others:
        raise ParameterError(names[i], values[i], f"linkage cannot be assembled at every crank angle "
                                                  f"(Grashof crank-rocker needs crank + longest < sum of the "
                                                  f"other two, got {a + values[i]:g} >= {others:g})")


def linkage_type(a: float, b: float, f: float, r: float, tol: float = 1e-12) -> str:
    """'parallelogram' (crank = rocker, coupler = frame), 'double-crank' (Grashof, frame shortest) or
    'crank-rocker' (Grashof, crank shortest); anything else raises ParameterError naming the link at fault."""
    for n, v in zip(_LINK_NAMES, (a, b, f, r)):
        if not (math.isfinite(v) and v > 0.0):
            raise ParameterError(n, v, "must be a finite length > 0")
    scale = max(a, b, f, r)
    if abs(a - r) <= tol * scale and abs(b - f) <= tol * scale and a < f:
        return "parallelogram"
    if f < min(a, b, r):
        longest = max(a, b, r)
        if not f + longest < a + b + r - longest:
            raise ParameterError("frame_length", f, f"double-crank linkage is not Grashof (frame + longest = "
                                                    f"{f + longest:g} >= sum of the other two {a + b + r - longest:g})")
        return "double-crank"
    check_crank_rocker(a, b, f, r)
    return "crank-rocker"


def position(phi, a, b, f, r, branch=1, m=None):
    """(psi, theta_c): rocker angle and coupler angle (A -> D) for crank angle(s) phi (closed form); ``m`` the
    math namespace (mathns.namespace: numpy, the default, or NUMPY for arrays; ``math`` or SCALAR for one float,
    twenty times faster than numpy scalars; VECTOR for a batch of variants, each element one float's bits)."""
    return kinematics(phi, a, b, f, r, branch, m, rates=False)


def kinematics(phi, a, b, f, r, branch=1, m=None, mu=True, rates=True):
    """(psi, dpsi/dphi, d2psi/dphi2, mu): position, velocity and acceleration ratios, transmission angle, at crank
    angle(s) phi; ``m`` as :func:`position` (numpy's arccos, arctan2 and hypot round differently from math's in the
    last bit: an array evaluation by NUMPY differs from the per-angle one by a few ulps, one by VECTOR does not).
    ``mu=False``: the transmission angle is not computed (None); ``rates=False``: :func:`position`'s answer."""
    m = m if m is SCALAR else namespace(m)
    vx = a * m.cos(phi) - f
    vy = a * m.sin(phi)
    d = m.hypot(vx, vy)
    theta_a = m.pi + m.atan2(-vy, -vx)
    gamma = m.acos(m.minimum(1.0, m.maximum(-1.0, (r * r + d * d - b * b) / (2.0 * r * d))))
    psi = theta_a - branch * gamma
    th = m.atan2(r * m.sin(psi) - vy, f + r * m.cos(psi) - a * m.cos(phi))
    if not rates:
        return psi, th
    s_cr = m.sin(th - psi)
    v = a * m.sin(th - phi) / (r * s_cr)
    vc = a * m.sin(psi - phi) / (b * s_cr)
    acc = (-a * m.cos(th - phi) - b * vc * vc + r * v * v * m.cos(th - psi)) / (r * s_cr)
    return psi, v, acc, m.acos(m.minimum(1.0, m.maximum(-1.0, m.cos(th - psi)))) if mu else None


def extreme_transmission(a, b, f, r):
    """Transmission angles mu [rad] at d = |A O5| = f - a and f + a (crank along the frame line)."""
    mu_near = math.acos(max(-1.0, min(1.0, (b * b + r * r - (f - a) ** 2) / (2 * b * r))))
    mu_far = math.acos(max(-1.0, min(1.0, (b * b + r * r - (f + a) ** 2) / (2 * b * r))))
    return mu_near, mu_far


def min_transmission(a, b, f, r) -> float:
    """Smallest deviation-free transmission angle min(mu, pi - mu) over a crank turn [rad].

    mu grows monotonically with d = |A O5|, which spans [f - a, f + a]; the extreme values are at the ends.
    """
    m1, m2 = extreme_transmission(a, b, f, r)
    return min(m1, math.pi - m1, m2, math.pi - m2)


# --------------------------------------------------------------------------------------------------------
# FMU model
# --------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class FourBarParams(Params):
    crank_length: float = param(0.1, "m", "crank O2A (seed 004: 1 x scale)", low=0.0, low_open=True)
    coupler_length: float = param(0.191579, "m", "coupler AD (seed 004: 1.91579 x crank)", low=0.0, low_open=True)
    rocker_length: float = param(0.225263, "m", "rocker DO5 (seed 004: 2.25263 x crank)", low=0.0, low_open=True)
    frame_length: float = param(0.210526, "m", "frame O2O5 (seed 004: 2.10526 x crank)", low=0.0, low_open=True)
    clearance: float = param(1e-5, "m", "total play of the coupler-rocker joint (fidelity 2; seed 000: 5-20 um)",
                             low=0.0)
    fidelity: int = param(0, "", "0 rigid ideal linkage, 1 elastic coupler, 2 elastic coupler + clearance joint",
                          choices=(0, 1, 2))
    branch: int = param(1, "", "assembly branch: +1 rocker pin D clockwise from O5->A (seen from O5), -1 mirrored",
                        choices=(-1, 1))
    rocker_inertia: float = param(4.3e-4, "kg.m2", "reduced inertia of the rocker and its load I2 (seed 000: 0.00043)",
                                  low=0.0, low_open=True)
    coupler_mass: float = param(0.0, "kg", "coupler mass, lumped half at each pin (fidelity >= 1)", low=0.0)
    coupler_stiffness: float = param(1e6, "N/m", "axial stiffness of coupler + joint c2 (seed 000: 1e5-1e6)",
                                     low=0.0, low_open=True)
    coupler_damping: float = param(0.0, "N.s/m", "axial viscous damping of the coupler (fidelity 1)", low=0.0)
    contact_law: int = param(0, "", "clearance contact law (fmus.physics.contact.LAWS): 0 Kelvin-Voigt, "
                                    "1 Hunt-Crossley, 2 Lankarani-Nikravesh, 3 Flores", choices=tuple(contact.LAWS))
    restitution: float = param(0.2, "1", "coefficient of restitution e of the clearance impacts (seed 000: 0.2)",
                               low=0.0, low_open=True, high=1.0)
    friction_ratio: float = param(0.0, "1", "seed 000 chi: the rocker receives (1 - chi) of the coupler force "
                                            "(seed value 0.2)", low=0.0)
    belt_stiffness: float = param(0.0, "N.m/rad", "parallelogram only: torsional stiffness of the belt between "
                                  "the crank and rocker shafts, ratio 1 (seed 003 c2; fidelity 1, 2; 0 = no belt)",
                                  low=0.0)
    belt_damping: float = param(0.0, "N.m.s/rad", "parallelogram only: damping of that belt (seed 003 b2; "
                                "fidelity 1, 2)", low=0.0)

    def check(self) -> None:
        kind = linkage_type(self.crank_length, self.coupler_length, self.frame_length, self.rocker_length)
        if not self.friction_ratio < 1.0:
            raise ParameterError("friction_ratio", self.friction_ratio, "must be < 1")
        for name in ("belt_stiffness", "belt_damping"):
            if getattr(self, name) > 0.0 and kind != "parallelogram":
                raise ParameterError(name, getattr(self, name), f"a belt between the crank shafts (ratio 1) "
                                                                f"needs a parallelogram linkage, not a {kind}")


PSI, W, V_IMPACT, COUNT, LAST_V, REBOUND = range(6)
KINEMATIC_ANGLE = 0.01   # rad of crank rotation per exponential step at fidelity 1 (FourBarModel._elastic_exact)


class FourBarModel(Model):
    """Crank-rocker four-bar, crank motion in, rocker motion out (see the module docstring)."""
    Params = FourBarParams
    inputs = ("crank.phi", "crank.w", "rocker.tau")
    outputs = ("crank.tau", "rocker.phi", "rocker.w", "transmission_angle", "joint_force", "contact_force",
               "in_contact", "impact_count", "last_impact_speed", "rebound_speed")
    states = (Signal("psi", "rad", "rocker angle (fidelity >= 1; kinematic value at fidelity 0)"),
              Signal("w_rocker", "rad/s", "rocker angular velocity"),
              Signal("v_impact", "m/s", "approach speed at the onset of the current/last contact"),
              Signal("onsets", "1", "number of contact onsets so far (output impact_count)"),
              Signal("v_last_onset", "m/s", "approach speed at the last onset (output last_impact_speed)"),
              Signal("v_last_separation", "m/s", "separation speed at the end of the last contact "
                                                 "(output rebound_speed)"))
    switches = (Signal("clearance_wall_positive", "m", "coupler elongation minus the clearance's positive wall "
                                                       "(fidelity 2)"),
                Signal("clearance_wall_negative", "m", "coupler elongation plus the clearance's negative wall "
                                                       "(fidelity 2)"))

    def __init__(self, p: FourBarParams):
        self._a, self._b = p.crank_length, p.coupler_length
        self._f, self._r = p.frame_length, p.rocker_length
        self._inertia = p.rocker_inertia + 0.5 * p.coupler_mass * p.rocker_length ** 2
        self._keep = 1.0 - p.friction_ratio
        self._half = 0.5 * p.clearance
        super().__init__(p)
        self.kind = linkage_type(self._a, self._b, self._f, self._r)
        # a double crank's output turns fully: keep rocker.phi continuous as phi + (psi - phi), with the
        # difference unwrapped around its value at phi = 0 (it stays within +-pi of it for a Grashof linkage)
        self._offset0 = float(kinematics(0.0, self._a, self._b, self._f, self._r, p.branch)[0])
        # output() at fidelity 1, 2: the coupler geometry of one (crank, rocker) motion, asked twice per
        # communication point (before and after the load torque on the rocker is set)
        self._coupler_at = last_call(self._coupler)

    # -- helpers -----------------------------------------------------------------------------------------
    def substep_limit(self) -> float:
        p = self.p
        if p.fidelity == 0:
            return math.inf
        r2_over_i = p.rocker_length ** 2 / (p.rocker_inertia + 0.5 * p.coupler_mass * p.rocker_length ** 2)
        omega = math.sqrt(p.coupler_stiffness * r2_over_i)      # highest axial frequency (lever arm = r)
        dt = 0.1 / omega                                         # ~30 sub-steps per contact half-period
        if p.fidelity == 2:   # and the contact law's damping rate (bounded, contact.max_substep) * dt <= 1
            dt = contact.max_substep(omega, p.contact_law, p.restitution)
        if p.fidelity == 1 and p.coupler_damping > 0.0:
            dt = min(dt, 1.0 / (p.coupler_damping * r2_over_i))  # RK4 real-axis stability 2.78
        inertia = p.rocker_inertia + 0.5 * p.coupler_mass * p.rocker_length ** 2
        if p.belt_stiffness > 0.0:
            dt = min(dt, 0.1 / math.sqrt(p.belt_stiffness / inertia))
        if p.belt_damping > 0.0:
            dt = min(dt, inertia / p.belt_damping)
        return dt

    def rigid_kinematics(self, phi: float, mu: bool = True) -> tuple[float, float, float]:
        """(psi, dpsi/dphi, mu) of the rigid linkage, psi continuous over full turns of a double crank.

        The parallelogram is taken on its parallelogram branch (psi = phi), the branch seed 003's belt
        between the two crank shafts holds at the dead points; its transmission angle is the angle between
        coupler (parallel to the frame) and rocker.  ``mu=False``: a crank-rocker's or double crank's
        transmission angle is not computed (None).
        """
        m = self.m
        if self.kind == "parallelogram":
            mu = abs(m.atan2(m.sin(phi), m.cos(phi)))
            return (float(phi), 1.0, mu) if m.scalar else (phi, np.ones_like(phi), mu)
        psi, v, _, mu = kinematics(phi, self._a, self._b, self._f, self._r, self.p.branch, m, mu)
        if self.kind == "double-crank":
            d = psi - phi - self._offset0
            psi = phi + self._offset0 + m.atan2(m.sin(d), m.cos(d))
        return psi, v, mu

    def rigid(self, phi: float, w: float) -> tuple[float, float]:
        """Rocker angle and speed of the rigid linkage for crank angle phi and speed w."""
        psi, v, _ = self.rigid_kinematics(phi)
        return psi, v * w

    def _geometry(self, phi, wc, psi, w, trig=None):
        """(q, qdot, ex, ey, arm_rocker, arm_crank) of the elastic coupler (``trig``: (cos phi, sin phi, cos psi,
        sin psi) when the caller has them)."""
        a, r, m = self._a, self._r, self.m
        c, s, cp, sp = trig or (m.cos(phi), m.sin(phi), m.cos(psi), m.sin(psi))
        dx = self._f + r * cp - a * c
        dy = r * sp - a * s
        length = m.hypot(dx, dy)
        ex, ey = dx / length, dy / length
        qd = ex * (-r * sp * w + a * s * wc) + ey * (r * cp * w - a * c * wc)
        return length - self._b, qd, ex, ey, r * (cp * ey - sp * ex), a * (c * ey - s * ex)

    def _coupler(self, phi, wc, psi, w):
        """(q, qdot, arm_rocker, arm_crank, transmission angle) of the elastic coupler (output)."""
        q, qd, ex, ey, arm, arm_crank = self._geometry(phi, wc, psi, w)
        m = self.m
        return q, qd, arm, arm_crank, m.acos(m.maximum(-1.0, m.minimum(1.0, ex * m.cos(psi) + ey * m.sin(psi))))

    def _tension(self, q, qd, arm, v_impact):
        """Coupler tension [N] (positive pulls the pins together)."""
        p = self.p
        if p.fidelity == 1:
            return p.coupler_stiffness * q + p.coupler_damping * qd
        return -contact.contact_force(q, qd, p.clearance, p.coupler_stiffness, p.contact_law, p.restitution,
                                      v_impact, self._reduced_mass(arm))

    def _reduced_mass(self, arm) -> float:
        """m_eff of the clearance joint (fidelity 2): the rocker inertia reduced to the coupler axis, over (1 - chi)
        (module docstring); a parallelogram's at the full arm r (its arm -> 0 at the dead points)."""
        if self.kind == "parallelogram":
            arm = self._r
        return self._inertia / (max(arm * arm, 1e-300) * self._keep)

    def _tension_slopes(self, q, qd, arm, v_impact) -> tuple[float, float, float, float]:
        """(:meth:`_tension`, its partial derivatives in q, qdot and the rocker's arm).  Fidelity 1: k, c, 0.
        Fidelity 2: the contact law's own slopes (contact.contact_force_slopes), signs turned to the tension; the
        arm enters through m_eff = I / (arm^2 (1 - chi)), dm_eff/darm = -2 m_eff / arm (0 for a parallelogram, whose
        m_eff is taken at the full arm, and where the 1e-300 floor holds)."""
        p = self.p
        if p.fidelity == 1:
            return self._tension(q, qd, arm, v_impact), p.coupler_stiffness, p.coupler_damping, 0.0
        m_eff = self._reduced_mass(arm)
        force, f_q, f_qd, f_m = contact.contact_force_slopes(q, qd, p.clearance, p.coupler_stiffness, p.contact_law,
                                                             p.restitution, v_impact, m_eff)
        floored = self.kind == "parallelogram" or arm * arm < 1e-300
        return -force, -f_q, -f_qd, 0.0 if floored else 2.0 * f_m * m_eff / arm

    def _belt(self, phi, wc, psi, w) -> float:
        """Torque [N.m] of the shaft-to-shaft belt on the rocker (parallelogram, fidelity >= 1)."""
        return self.p.belt_stiffness * (phi - psi) + self.p.belt_damping * (wc - w)

    def _side(self, q) -> float:
        return 1.0 if q > self._half else (-1.0 if q < -self._half else 0.0)

    # -- model interface ---------------------------------------------------------------------------------
    def initial_state(self, u):
        psi, w = self.rigid(u[0], u[1])
        return np.array([psi, w, 0.0, 0.0, 0.0, 0.0])

    def derivatives(self, t, x, u, t0):
        return self._rates(t, x, u, t0, True)

    def event_indicators(self, t, x, u):
        """The walls of the clearance joint (``switches``, fidelity 2): q -+ clearance/2, the coupler's
        elongation against each wall; a constant 1 at the other levels."""
        if self.p.fidelity != 2:
            return (1.0, 1.0)
        q = self._gap(t, x, u, t)[0]
        return (q - self._half, q + self._half)

    def at_event(self, t, x, u):
        """At a located wall crossing, the memory ``_substep_with_events`` updates there: onset on a wall (the
        approach speed as v_impact and last_impact_speed, impact_count + 1) or separation (rebound_speed)."""
        x = np.array(x, dtype=float)
        if self.p.fidelity != 2:
            return x
        q, qd = self._gap(t, x, u, t)
        if self._side(q) != 0.0:
            x[V_IMPACT] = x[LAST_V] = abs(qd)
            x[COUNT] += 1.0
        else:
            x[REBOUND] = abs(qd)
        return x

    def _acceleration(self, t, psi, w, v_impact, u, t0, contact_on):
        """Rocker angular acceleration [rad/s2] at time t for rocker angle psi and speed w."""
        phi = u[0] + u[1] * (t - t0)
        q, qd, _, _, arm, _ = self._geometry(phi, u[1], psi, w)
        force = self._tension(q, qd, arm, v_impact) if contact_on else 0.0
        belt = self._belt(phi, u[1], psi, w)
        return (u[2] - self._keep * force * arm + belt) / self._inertia

    def _rates(self, t, x, u, t0, contact_on):
        return np.array([x[1], self._acceleration(t, x[0], x[1], x[2], u, t0, contact_on), 0.0, 0.0, 0.0, 0.0])

    def _elastic_steps(self, t0, h, n, x, u):
        """Fidelity 1 over [t0, t0 + h]: the classical RK4 of :meth:`_step` on the two evolving states
        (psi, w), in plain floats (integrate.rk4_pair: the same numbers without an array per stage)."""
        v_imp = float(x[V_IMPACT])

        def acc(t, psi, w):
            return self._acceleration(t, psi, w, v_imp, u, t0, True)

        y = np.array(x, dtype=float)
        y[PSI], y[W] = march_pair(rk4_pair, acc, t0, h, n, float(x[PSI]), float(x[W]))
        return y

    def _acc_at(self, phi, wc, tau, psi, w):
        """Rocker angular acceleration [rad/s2] at crank angle phi (fidelity 1)."""
        q, qd, _, _, arm, _ = self._geometry(phi, wc, psi, w)
        return self._elastic_acc(phi, wc, tau, psi, w, q, qd, arm)[1]

    def _elastic_acc(self, phi, wc, tau, psi, w, q, qd, arm):
        """(coupler force [N], rocker acceleration [rad/s2]) of fidelity 1 from the coupler's geometry."""
        force = self.p.coupler_stiffness * q + self.p.coupler_damping * qd
        return force, (tau - self._keep * force * arm + self._belt(phi, wc, psi, w)) / self._inertia

    def _acc_jet_at(self, phi, wc, tau, psi, w):
        """(_acc_at, its derivatives in psi, w and time) at crank angle phi turning at wc (fidelity 1), in closed
        form: with d = B - A the coupler vector, e = d/|d|, t_r = dd/dpsi and t_c = dd/dphi, the stretch q has
        dq/dpsi = e.t_r = arm and dq/dphi = e.t_c = -arm_crank, and the unit vector turns by
        de = (t - e (e.t)) / |d|, which gives the arms' rates."""
        a, r, p, m = self._a, self._r, self.p, self.m
        c, s = m.cos(phi), m.sin(phi)
        cp, sp = m.cos(psi), m.sin(psi)
        q, qd, ex, ey, arm, arm_crank = self._geometry(phi, wc, psi, w, (c, s, cp, sp))
        force, acc = self._elastic_acc(phi, wc, tau, psi, w, q, qd, arm)
        k, cd = p.coupler_stiffness, p.coupler_damping
        length = q + self._b
        rr_c = -r * a * (cp * c + sp * s)                                    # t_r . t_c
        arm_psi = -r * (ex * cp + ey * sp) + (r * r - arm * arm) / length
        arm_phi = (rr_c + arm * arm_crank) / length
        crank_psi = -arm_phi
        crank_phi = -(a * (ex * c + ey * s) + (a * a - arm_crank * arm_crank) / length)
        qd_psi = w * arm_psi - wc * crank_psi
        qd_phi = w * arm_phi - wc * crank_phi
        keep, inertia = self._keep, self._inertia
        a_psi = (-keep * ((k * arm + cd * qd_psi) * arm + force * arm_psi) - p.belt_stiffness) / inertia
        a_w = (-keep * cd * arm * arm - p.belt_damping) / inertia
        a_phi = (-keep * ((-k * arm_crank + cd * qd_phi) * arm + force * arm_phi) + p.belt_stiffness) / inertia
        return acc, a_psi, a_w, wc * a_phi

    def _elastic_exact(self, t0, h, x, u):
        """Fidelity 1 over [t0, t0 + h]: exponential Rosenbrock steps of order 3 (integrate.exprb32_pair) of
        (psi, w), one per KINEMATIC_ANGLE of crank rotation.  The coupler mode is integrated exactly on its
        linearisation at each step start, so the coupler stiffness sets no sub-step; the crank's motion
        phi(t) = crank.phi + crank.w (t - t0) enters through the rates' time derivative.  The rates' Jacobian and
        time derivative are in closed form (:meth:`_acc_jet_at`): one coupler geometry per step for them and one
        for the step's end.  (The former RK4
        sub-steps, :meth:`_elastic_steps`, are kept as the comparison of tests/test_exponential.py.)"""
        phi0, wc, tau = float(u[0]), float(u[1]), float(u[2])
        n = max(1, math.ceil(abs(wc) * h / KINEMATIC_ANGLE * (1.0 - 1e-12)))
        acc_at, jet_at = self._acc_at, self._acc_jet_at

        def acc(t, psi, w):
            return acc_at(phi0 + wc * (t - t0), wc, tau, psi, w)

        def jet(t, psi, w):
            return jet_at(phi0 + wc * (t - t0), wc, tau, psi, w)

        y = np.array(x, dtype=float)
        y[PSI], y[W] = march_pair(exprb32_pair, acc, t0, h, n, float(x[PSI]), float(x[W]), jet)
        return y

    def output(self, t, x, u):
        p = self.p
        if p.fidelity == 0:
            psi, v, mu = self.rigid_kinematics(u[0])
            _, _, _, _, arm, _ = self._geometry(u[0], u[1], psi, v * u[1])
            # at a dead point (arm = 0, reached exactly only by a parallelogram) the coupler force of the
            # rigid linkage is indeterminate; seed 003's belt between the crank shafts carries the torque
            live, m = abs(arm) > 1e-12 * self._r, self.m
            force = (u[2] / arm if live else 0.0) if m.scalar else m.where(live, u[2] / m.where(live, arm, 1.0), 0.0)
            return (u[2] * v, psi, v * u[1], mu, force, 0.0, 1.0, x[3], x[4], x[5])
        q, qd, arm, arm_crank, mu = self._coupler_at(u[0], u[1], x[0], x[1])
        force = self._tension(q, qd, arm, x[2])
        crank_tau = force * arm_crank - self._belt(u[0], u[1], x[0], x[1])
        if p.fidelity == 1:
            return (crank_tau, x[0], x[1], mu, force, 0.0, 1.0, x[3], x[4], x[5])
        side = self._side(q)
        return (crank_tau, x[0], x[1], mu, force, abs(force), abs(side), x[3], x[4], x[5])

    def output_jacobian(self, t, x, u):
        """d outputs / d (crank.phi, crank.w, rocker.tau) in closed form at every fidelity.

        Fidelity 0: the loop closure's psi' and psi'' (kinematics) and the coupler's geometry
        (:meth:`_geometry_slopes`) at the rigid pose psi(phi).  Fidelities 1 and 2: the rocker's (psi, w) are states,
        so only the crank pin moves with the inputs; the coupler tension F(q, qdot, arm) moves with phi through
        q (dq/dphi = -arm_crank), qdot (qd_phi) and the arm (arm_phi), and with crank.w through qdot
        (dqdot/dw = -arm_crank).  Its partial derivatives in q, qdot and the arm are the force law's own
        (:meth:`_tension_slopes`): k and c at fidelity 1, the clearance contact law's at fidelity 2 (every law and
        phase of contact.contact_force_slopes: separated or clipped 0; the arm through the reduced mass, which sets
        the Kelvin-Voigt damping and the Hunt-Crossley family's energy speed).  crank.tau = F arm_crank - T_belt
        adds F d arm_crank / dphi and the belt's stiffness and damping; transmission_angle is geometry alone
        (mu_phi).  contact_force = |F| has the slope sign(F) dF; in_contact (and the counters, which are states) are
        piecewise constant: slope 0.  rocker.tau drives only the state, so its column is 0 at fidelities 1 and 2.
        On a kink of the contact law (a wall, the force reaching zero, the onset speed meeting the energy speed)
        the slope of the side the outputs take is returned."""
        p = self.p
        phi, wc, tau = float(u[0]), float(u[1]), float(u[2])
        D = np.zeros((len(self.outputs), len(self.inputs)))
        if p.fidelity == 0:
            psi, v, _ = self.rigid_kinematics(phi)
            acc = 0.0 if self.kind == "parallelogram" else kinematics(phi, self._a, self._b, self._f, self._r,
                                                                       p.branch, SCALAR, mu=False)[2]
            g = self._geometry_slopes(phi, wc, psi, v * wc)
            D[0] = (tau * acc, 0.0, v)                                  # crank.tau = tau * psi'
            D[1, 0] = v                                                 # rocker.phi = psi(phi)
            D[2, :2] = (acc * wc, v)                                    # rocker.w = psi' * w
            if self.kind == "parallelogram":                            # mu = |phi| wrapped to [-pi, pi]
                D[3, 0] = math.copysign(1.0, math.atan2(math.sin(phi), math.cos(phi)))
            else:
                D[3, 0] = g["mu_phi"] + g["mu_psi"] * v
            arm = g["arm"]
            if abs(arm) > 1e-12 * self._r:                              # joint_force = tau / arm(phi, psi(phi))
                D[4] = (-tau * (g["arm_phi"] + g["arm_psi"] * v) / (arm * arm), 0.0, 1.0 / arm)
            return D
        g = self._geometry_slopes(phi, wc, float(x[0]), float(x[1]))
        force, f_q, f_qd, f_arm = self._tension_slopes(g["q"], g["qd"], g["arm"], float(x[2]))
        d_force = np.array([-f_q * g["arm_crank"] + f_qd * g["qd_phi"] + f_arm * g["arm_phi"],
                            -f_qd * g["arm_crank"], 0.0])
        D[0] = d_force * g["arm_crank"] + np.array([force * g["crank_phi"] - p.belt_stiffness, -p.belt_damping, 0.0])
        D[3, 0] = g["mu_phi"]
        D[4] = d_force
        if p.fidelity == 2:
            D[5] = math.copysign(1.0, force) * d_force if force != 0.0 else 0.0
        return D

    def _geometry_slopes(self, phi, wc, psi, w) -> dict[str, float]:
        """The coupler's geometry and its partial derivatives in the crank angle phi and the rocker angle psi (the
        closed forms of :meth:`_acc_jet_at`: with d = B - A, e = d/|d|, t_r = dd/dpsi, t_c = dd/dphi, the stretch
        has dq/dpsi = e.t_r = arm and dq/dphi = e.t_c = -arm_crank and the unit vector turns by
        de = (t - e (e.t)) / |d|), and of the transmission angle mu = acos(e . (cos psi, sin psi))."""
        a, r = self._a, self._r
        c, s = math.cos(phi), math.sin(phi)
        cp, sp = math.cos(psi), math.sin(psi)
        q, qd, ex, ey, arm, arm_crank = self._geometry(phi, wc, psi, w, (c, s, cp, sp))
        length = q + self._b
        rr_c = -r * a * (cp * c + sp * s)
        arm_psi = -r * (ex * cp + ey * sp) + (r * r - arm * arm) / length
        arm_phi = (rr_c + arm * arm_crank) / length
        crank_phi = -(a * (ex * c + ey * s) + (a * a - arm_crank * arm_crank) / length)
        cos_mu = ex * cp + ey * sp
        sin_mu = math.sqrt(max(0.0, 1.0 - cos_mu * cos_mu))
        # d cos_mu: the unit vector turning (de . rocker direction), and at psi the rocker direction turning too
        e_tc = -arm_crank                                   # e . t_c
        dcos_phi = ((a * s - ex * e_tc) * cp + (-a * c - ey * e_tc) * sp) / length
        dcos_psi = ((-r * sp - ex * arm) * cp + (r * cp - ey * arm) * sp) / length + (-ex * sp + ey * cp)
        inv = -1.0 / sin_mu if sin_mu > 0.0 else 0.0
        return {"q": q, "qd": qd, "arm": arm, "arm_crank": arm_crank, "arm_psi": arm_psi, "arm_phi": arm_phi,
                "crank_phi": crank_phi, "qd_phi": w * arm_phi - wc * crank_phi,
                "mu_phi": inv * dcos_phi, "mu_psi": inv * dcos_psi}

    def _step(self, t, x, dt, u, t0, contact_on=True):
        """One classical Runge-Kutta step of length dt from (t, x); phi(t) uses the step start t0.

        ``contact_on=False`` integrates the free flight (no force in the clearance joint)."""
        def f(tt, xx):
            return self._rates(tt, xx, u, t0, contact_on)
        k1 = f(t, x)
        k2 = f(t + 0.5 * dt, x + 0.5 * dt * k1)
        k3 = f(t + 0.5 * dt, x + 0.5 * dt * k2)
        k4 = f(t + dt, x + dt * k3)
        return x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    def _gap(self, t, x, u, t0):
        q, qd, *_ = self._geometry(u[0] + u[1] * (t - t0), u[1], x[0], x[1])
        return q, qd

    def _locate(self, t, x, span, u, t0, sgn, contact_on):
        """Time tau in [0, span] at which sgn*q - clearance/2 changes sign (Illinois regula falsi)."""
        def g(tau):
            xs = x if tau == 0.0 else self._step(t, x, tau, u, t0, contact_on)
            return sgn * self._gap(t + tau, xs, u, t0)[0] - self._half
        lo, hi = 0.0, span
        glo, ghi = g(lo), g(hi)
        if glo * ghi > 0.0:
            return hi if abs(ghi) < abs(glo) else lo
        last = 0
        for _ in range(60):
            if glo == ghi:
                break
            mid = (lo * ghi - hi * glo) / (ghi - glo)
            gm = g(mid)
            if gm == 0.0 or abs(hi - lo) <= 1e-13 * span:
                return mid
            if gm * ghi < 0.0:          # root between mid and hi: hi becomes the old end
                lo, glo = hi, ghi
                last = 0
            else:                       # same end kept twice: Illinois halving
                if last == 1:
                    glo *= 0.5
                last = 1
            hi, ghi = mid, gm
        return hi

    def advance(self, t0, h, x, u):
        p = self.p
        if p.fidelity == 0:
            psi, w = self.rigid(u[0] + u[1] * h, u[1])
            y = x.copy()
            y[PSI], y[W] = psi, w
            return y
        if p.fidelity == 1:
            return self._elastic_exact(t0, h, x, u)
        n = substeps(h, self.max_substep)
        dt = h / n
        for i in range(n):
            t = t0 + i * dt
            t_end = t0 + (i + 1) * dt if i < n - 1 else t0 + h
            x = self._substep_with_events(t, t_end, x, u, t0)
        return x

    def _substep_with_events(self, t, t_end, x, u, t0):
        """One sub-step at fidelity 2, split at contact onsets and separations.

        While separated the step is integrated as free flight (no joint force); if the free flight crosses a
        wall of the clearance band, the onset is located on it (exact: before the onset there is no
        force), the approach speed is stored (v_impact, last_impact_speed, impact_count + 1) and the rest of
        the sub-step is integrated with the contact force.  A separation (leaving the wall) is located the
        same way on the contact step and its speed stored as rebound_speed."""
        side_now = self._side(self._gap(t, x, u, t0)[0])
        for _ in range(4):
            span = t_end - t
            if span <= 0.0:
                return x
            on = side_now != 0.0
            x_new = self._step(t, x, span, u, t0, on)
            side_end = self._side(self._gap(t_end, x_new, u, t0)[0])
            if side_end == side_now:
                return x_new
            sgn = side_now if on else side_end
            tau = self._locate(t, x, span, u, t0, sgn, on)
            xc = x.copy() if tau == 0.0 else self._step(t, x, tau, u, t0, on)
            qd = self._gap(t + tau, xc, u, t0)[1]
            if on:                                   # separation from wall side_now
                xc[REBOUND] = abs(qd)
                side_now = 0.0
            else:                                    # onset on wall side_end
                v = abs(qd)
                xc[V_IMPACT], xc[LAST_V], xc[COUNT] = v, v, xc[COUNT] + 1.0
                side_now = side_end
            t, x = t + tau, xc
        return self._step(t, x, t_end - t, u, t0, side_now != 0.0) if t_end > t else x


class FourBarBatch(variants.Vectorised):
    """Variants of :class:`FourBarModel` stepped together (fmus.physics.variants): the rigid kinematics (fidelity 0)
    and the elastic coupler's exponential steps (fidelity 1, each variant on its own count of steps) on arrays, the
    model's own geometry, forces and jet.  The clearance level (fidelity 2), whose contact events are located per
    variant, runs each variant's scalar model; linkages of other kinds (the kinematics branch on it) go apart."""
    attributes = ("_a", "_b", "_f", "_r", "_inertia", "_keep", "_half", "_offset0", "kind")

    @classmethod
    def refuses(cls, models):
        return "the clearance level locates contact events per variant" if models[0].p.fidelity == 2 else None

    @classmethod
    def key(cls, model):
        return (model.kind,)

    def __init__(self, models):
        super().__init__(models)
        self.v._coupler_at = variants.last_call(self.v._coupler)
        self._ports = variants.last_call(self._crank_tau)   # a point's geometry, read at each visit

    def _crank_tau(self, phi, wc, tau, psi, w, v_impact):
        q, qd, _, _, arm, arm_crank = self.v._geometry(phi, wc, psi, w)
        return self.v._tension(q, qd, arm, v_impact) * arm_crank - self.v._belt(phi, wc, psi, w)

    def output(self, t, X, U, rows=None):
        v = self.v
        if rows is not None and set(rows) <= {0, 1, 2}:   # the ports alone (transmission angle, forces unread)
            Y = np.zeros((len(v.outputs), self.n))
            if v.p.fidelity == 0:
                psi, ratio, _ = v.rigid_kinematics(U[0], mu=False)
                Y[0], Y[1], Y[2] = U[2] * ratio, psi, ratio * U[1]
            else:
                Y[0] = self._ports(U[0], U[1], U[2], X[0], X[1], X[2])
                Y[1], Y[2] = X[0], X[1]
            return Y
        return v.m.stack(v.output(t, X, U))

    def advance(self, t0, h, X, U):
        v = self.v
        if v.p.fidelity == 0:
            return v.advance(t0, h, X, U)
        phi0, wc, tau = U[0], U[1], U[2]
        n = np.maximum(1.0, np.ceil(np.abs(wc) * h / KINEMATIC_ANGLE * (1.0 - 1e-12)))
        y = np.array(X, dtype=float)
        y[PSI], y[W] = integrate_batch.march_pair(lambda t, q, w: v._acc_at(phi0 + wc * (t - t0), wc, tau, q, w),
                                                  lambda t, q, w: v._acc_jet_at(phi0 + wc * (t - t0), wc, tau, q, w),
                                                  t0, h, n, X[PSI], X[W])
        return y


FourBarModel.Batch = FourBarBatch
