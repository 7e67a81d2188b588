"""Cam-corrected rocker: a motion transformer from a crank to an output rocker (seeds 000/001/004).

``mechanism``
  0  slotted rocker (LCSM, seeds 000/001): the kulisa follows a prescribed law of periodic motion; the stone
     pin runs in a groove synthesised from that law (fmus.physics.groove).  The swing, the extreme positions
     and the phase angles are those of the base four-bar (crank_radius, lambda1..3) with the optional
     ``dwell`` centred on its extended dead centre (see groove.py).  rocker.phi is the ABSOLUTE kulisa angle
     gamma_b in frame F2 (x from the crank pivot towards the kulisa pivot, counter-clockwise); crank.phi is
     the crank angle in the same frame.  ``stone_radius`` = rho = |O2B| from (K8).
  1  disc cam with an oscillating roller follower (seed 004's carrier cam): the cam turns with the crank;
     the follower (pivot at distance ``cam_distance`` from the cam centre, arm ``follower_arm``) rises by
     ``swing`` over ``phase_forward`` from crank angle ``phi_start``, dwells ``dwell``, returns over
     ``phase_return`` and dwells for the rest of the turn.  rocker.phi = follower angle above its lowest
     (base-circle) position.  ``stone_radius`` = distance of the roller centre from the cam centre.
     Pressure angle: between the pitch-curve normal and the velocity of the roller centre.

``fidelity``
  0  rigid: rocker.phi = G(crank.phi), rocker.w = G'(crank.phi)*crank.w.  The rocker inertia is carried with
     the kinematic acceleration G''*w^2 (FMI 2.0 gives no crank acceleration: the G'*dw/dt term is dropped),
     and crank.tau = -G'*(J*G''*w^2 - rocker.tau) from the power balance.
  1  elastic: torque T = stiffness*(G - gamma) + damping*(G'*w - omega) between the kinematic angle and the
     rocker inertia J: J*domega/dt = T + rocker.tau; crank.tau = -G'*T.
  2  elastic + clearance at the stone pin (LCSM) / roller (cam): the linear play ``clearance`` [m] acts at
     the radius R (stone radius rho(phi), or the follower arm) so the relative coordinate is
     q = R*(G - gamma) [m] and the contact law of fmus.physics.contact gives the pin force F [N] with the
     series stiffness k = 1/(1/contact_stiffness + R^2/stiffness) and m_eff = J/R^2; the rocker gets
     T = -F*R.  Impacts are counted at every separated -> contact transition.
     Integration, Kelvin-Voigt law: exponential Rosenbrock steps (order 3) of at most EXP_STEP_PHASE/omega_c
     in the contact mode of each step's start, contact events located by bisection inside the step
     (``_advance_kelvin_voigt``).  Other laws (``exact_contact = False`` for all):
     RK4 on sub-steps of at most 0.1/omega (omega = the larger of the transmission's and the
     contact's frequency sqrt(contact_stiffness*r_max^2/J)) and of at most 1/(the contact law's largest
     damping rate), contact.max_substep; the Hunt-Crossley family's damping is bounded in a persistent
     contact (its v0 is calibrated on the elastic energy the contact holds, see fmus.physics.contact), so
     a slow take-up of the play followed by a loaded contact stays stable.  The contact flag and v_impact
     are memory updated at the sub-step boundaries; a contact that begins inside a sub-step (flag still 0)
     uses its present penetration rate as its approach speed.
  3  LCSM only: seed 000's two clearances.  The stone is a body of its own (``stone_mass``) that slides along
     the slot: states gamma, omega of the kulisa and the stone radius rho_s, its rate.  Two joints act on the
     stone pin B = rho_s u(gamma) (u along the slot, n = u turned +90 deg):
       * the conrod eye: elongation d_p = |B - A(phi)| - L (A the crank pin, L the conrod length), total play
         ``clearance``, series stiffness 1/(1/contact_stiffness + R^2/stiffness) ALONG the conrod (level 2's
         1-D play acts along the rocker's tangent instead);
       * the roller in the groove: normal offset d_g = (B - B_g(phi)).n_g of the roller centre from the
         centroid profile (B_g the profile point of the present crank angle, n_g its unit normal; linear in
         the offset, which stays at the scale of the plays), total play ``groove_clearance``, stiffness
         ``groove_stiffness`` (seed c'4).
     Each joint has its own contact law state (approach speed, flag, impact count) and reduced mass
     1/((e.u)^2/m_s + (rho_s e.n)^2/J) along its direction e.  Equations of motion (frictionless slot, the
     stone a point mass on the slot line):
       (J + m_s rho_s^2) domega/dt + 2 m_s rho_s drho_s/dt omega = rocker.tau + rho_s F.n
       m_s (d2rho_s/dt2 - rho_s omega^2)                           = F.u,       F = F_p e_c + F_g n_g
     so ``rocker_inertia`` is the kulisa's (with the head) and the stone adds m_s rho_s^2: the inertia reduced
     to the rocker changes as the stone moves (seed 000 freezes it per position).  The energy balance is
     exact: kinetic energy + contact potentials change only by the load's and the crank's power (tested
     with conservative contacts).  crank.tau = -F_p r (cos(phi) e_c,y - sin(phi) e_c,x).  RK4 sub-steps as
     level 2, sized on the larger joint frequency sqrt(k (1/m_s + r_max^2/J)).

Inside a communication step the crank angle is extrapolated with the held crank speed,
phi(t) = crank.phi + crank.w*(t - t0).  State: gamma, omega, v_impact, impacts, contact_flag (the last
three are discrete memory updated in ``advance``); level 3 adds rho_s, rho_rate and the groove joint's
v_impact, impacts and contact flag.

The model is one ``Model`` class whose levels share its state vector, kinematics G(phi) and geometry (lever,
stone radius, roller); the two levels with their own integration live beside it as mixins of that class:
:class:`fmus.physics.cam_rocker_kv.KelvinVoigtPin` (level 2 with the Kelvin-Voigt law: exponential steps and
located contact events) and :class:`fmus.physics.cam_rocker_stone.SlidingStone` (level 3: the stone as a body
with two joints).  The equations that stand alone live apart: the laws of motion (fmus.physics.laws), the
groove (groove), the contact laws (contact), the integrators (integrate).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from . import contact, groove, integrate, integrate_batch, variants
from .base import Model, ParameterError, Params, Signal, last_call, param
from .cam_rocker_kv import EXP_STEP_PHASE, KelvinVoigtPin
from .cam_rocker_stone import SlidingStone
from .laws import LAW_NAMES, TWO_PI, DwellCycle, get_law

DEG = math.pi / 180.0


@dataclass(frozen=True)
class CamRockerParams(Params):
    mechanism: int = param(0, "", "0 = slotted rocker with groove (LCSM, seeds 000/001), 1 = disc cam with oscillating roller follower (seed 004)", choices=(0, 1))
    fidelity: int = param(0, "", "0 = rigid kinematics, 1 = elastic transmission, 2 = elastic + clearance with impacts, 3 = LCSM with seed 000's two clearances (stone pin and roller in the groove, the stone sliding along the slot)", choices=(0, 1, 2, 3))
    law: int = param(0, "", "law of periodic motion, index into " + ", ".join(f"{i}={n}" for i, n in enumerate(LAW_NAMES)), choices=tuple(range(len(LAW_NAMES))))
    law_return: int = param(-1, "", "law of the return phase (same indices), -1 = same as law", choices=tuple(range(-1, len(LAW_NAMES))))
    law_n: float = param(2.0, "1", "exponent n of the power law", low=0.0, low_open=True)
    law_km: float = param(0.4, "1", "end of run-up k_m of the P6 stand-in and composite laws", low=0.0, low_open=True, high=1.0)
    crank_radius: float = param(0.040, "m", "LCSM crank radius r (seed 001: 0.040 m)", low=0.0, low_open=True)
    lambda1: float = param(3.5, "1", "LCSM frame length / r (seed 001: 3.5)", low=0.0, low_open=True)
    lambda2: float = param(4.03, "1", "LCSM conrod length / r (inside the K0 feasible interval computed by synth groove)", low=0.0, low_open=True)
    lambda3: float = param(3.0, "1", "LCSM base four-bar rocker length / r (seed 001: 3)", low=0.0, low_open=True)
    assembly: int = param(1, "", "LCSM base four-bar assembly mode (+1/-1)", choices=(1, -1))
    dwell: float = param(0.0, "rad", "dwell after the forward phase (LCSM: centred on the extended dead centre)", low=0.0)
    swing: float = param(40.0 * DEG, "rad", "cam follower swing (seed 004: 40 deg); the LCSM swing is the base four-bar's", low=0.0, low_open=True, high=math.pi)
    phase_forward: float = param((216 + 53 / 60 + 10 / 3600) * DEG, "rad", "cam rise phase angle (seed 004: 216 deg 53' 10\")", low=0.0, low_open=True)
    phase_return: float = param((143 + 6 / 60 + 50 / 3600) * DEG, "rad", "cam return phase angle (seed 004: 143 deg 06' 50\")", low=0.0, low_open=True)
    phi_start: float = param(0.0, "rad", "cam: crank angle at which the rise begins")
    cam_base_radius: float = param(0.0663, "m", "cam: base-circle radius of the pitch curve r0 (0.95*S, S = follower_arm*swing, seed 004 r0/S)", low=0.0, low_open=True)
    follower_arm: float = param(0.1, "m", "cam: follower arm, pivot to roller centre", low=0.0, low_open=True)
    cam_distance: float = param(0.15, "m", "cam: distance cam centre - follower pivot", low=0.0, low_open=True)
    rocker_inertia: float = param(0.00043, "kg.m2", "rocker (kulisa/follower) inertia about its pivot (seed 000: I2)", low=0.0, low_open=True)
    stiffness: float = param(5000.0, "N.m/rad", "transmission stiffness reduced to the rocker angle (fidelity 1, 2)", low=0.0, low_open=True)
    damping: float = param(0.1, "N.m.s/rad", "transmission damping reduced to the rocker (fidelity 1)", low=0.0)
    clearance: float = param(10e-6, "m", "total linear play at the stone pin / roller (seed 000: 5-20 um), fidelity 2", low=0.0)
    contact_stiffness: float = param(5e5, "N/m", "joint stiffness at the pin c2 (seed 000: 1e5-1e6 N/m)", low=0.0, low_open=True)
    restitution: float = param(0.2, "1", "restitution coefficient (seed 000: 0.2)", low=0.0, low_open=True, high=1.0)
    groove_clearance: float = param(10e-6, "m", "total play of the roller in the groove, along the profile normal (seed 000: 5-20 um), fidelity 3", low=0.0)
    groove_stiffness: float = param(5e5, "N/m", "roller-groove contact stiffness c'4 (seed 000 gives no value: c2's), fidelity 3", low=0.0, low_open=True)
    stone_mass: float = param(0.01, "kg", "mass of the stone with its roller, sliding along the slot (not in the seed: assumed), fidelity 3", low=0.0, low_open=True)
    contact_law: int = param(0, "", "contact law: 0 Kelvin-Voigt, 1 Hunt-Crossley, 2 Lankarani-Nikravesh, 3 Flores", choices=(0, 1, 2, 3))
    contact_exponent: float = param(1.0, "1", "force exponent of the Hunt-Crossley family", low=1.0)

    def laws(self):
        f = get_law(LAW_NAMES[self.law], n=self.law_n, k_m=self.law_km)
        r = f if self.law_return < 0 else get_law(LAW_NAMES[self.law_return], n=self.law_n, k_m=self.law_km)
        return f, r

    def check(self) -> None:
        if self.fidelity == 3 and self.mechanism != 0:
            raise ParameterError("fidelity", self.fidelity, "level 3 (stone pin and roller-groove clearances) exists for the slotted rocker, mechanism 0, only")
        if not self.law_km < 1.0:
            raise ParameterError("law_km", self.law_km, "must be < 1")
        if self.mechanism == 0:
            l1, l2, l3 = self.lambda1, self.lambda2, self.lambda3
            if not groove.grashof_crank_rocker(l1, l2, l3):
                raise ParameterError("lambda2", l2, f"base four-bar (lambda1={l1:g}, lambda3={l3:g}) must be a Grashof crank-rocker")
            try:
                law = groove.kulisa_law(l1, l2, l3, *self.laws(), dwell=self.dwell, assembly=self.assembly)
            except ValueError as e:
                raise ParameterError("dwell", self.dwell, str(e)) from None
            p = groove.synthesize_law(law, l1, l2, 1440, groove.base_branch(l1, l2, l3, self.assembly))
            if not np.all(p.exists):
                raise ParameterError("lambda2", l2, f"the groove does not exist: kinematic connection breaks "
                                     f"(|N| - lambda2 = {-float(np.min(l2 - np.abs(p.N))):.4g} > 0); try `synth groove --scan lambda2`")
            if not np.all(p.rho > 0.0):
                raise ParameterError("lambda2", l2, "the stone radius rho becomes <= 0")
        else:
            total = self.phase_forward + self.dwell + self.phase_return
            if total > TWO_PI + 1e-9:
                raise ParameterError("phase_return", self.phase_return, f"phase_forward + dwell + phase_return = {total:.6g} rad exceeds 2*pi")
            a, l, r0 = self.cam_distance, self.follower_arm, self.cam_base_radius
            if not abs(a - l) < r0 < a + l:
                raise ParameterError("cam_base_radius", r0, f"must lie between |cam_distance - follower_arm| = {abs(a - l):g} m and cam_distance + follower_arm = {a + l:g} m")
            psi0 = math.acos((a * a + l * l - r0 * r0) / (2 * a * l))
            if psi0 + self.swing >= math.pi:
                raise ParameterError("swing", self.swing, f"follower would pass the line of centres (psi0 = {psi0:.4g} rad)")


class CamRockerModel(KelvinVoigtPin, SlidingStone, Model):
    Params = CamRockerParams
    # level 2 with the Kelvin-Voigt law: exponential steps between located contact events (False: the RK4
    # sub-steps of the other laws, kept as the comparison of tests/test_cam_rocker.py)
    exact_contact = True
    inputs = ("crank.phi", "crank.w", "rocker.tau")
    outputs = ("crank.tau", "rocker.phi", "rocker.w", "pressure_angle", "stone_radius", "pin_force",
               "in_contact", "impact_count", "groove_force", "groove_contact", "groove_impact_count")
    states = (Signal("gamma", "rad", "rocker angle (fidelity 1-3)"),
              Signal("omega", "rad/s", "rocker angular velocity (fidelity 1-3)"),
              Signal("v_impact", "m/s", "stone-pin approach speed at the start of the current contact (fidelity 2, 3)"),
              Signal("impacts", "1", "number of stone-pin impacts so far (fidelity 2, 3), state behind output impact_count"),
              Signal("contact_flag", "1", "1 while the stone-pin clearance is closed (fidelity 2, 3), state behind output in_contact"),
              Signal("rho_s", "m", "stone radius along the slot (fidelity 3)"),
              Signal("rho_rate", "m/s", "stone speed along the slot (fidelity 3)"),
              Signal("groove_v_impact", "m/s", "roller-groove approach speed at the start of the current contact (fidelity 3)"),
              Signal("groove_impacts", "1", "number of roller-groove impacts so far (fidelity 3)"),
              Signal("groove_flag", "1", "1 while the roller touches a groove wall (fidelity 3)"))
    switches = (Signal("pin_wall_positive", "m", "stone-pin play minus its positive wall (fidelity 2, 3)"),
                Signal("pin_wall_negative", "m", "stone-pin play plus its negative wall (fidelity 2, 3)"),
                Signal("groove_wall_positive", "m", "roller offset in the groove minus its positive wall (fidelity 3)"),
                Signal("groove_wall_negative", "m", "roller offset in the groove plus its negative wall (fidelity 3)"))

    def __init__(self, p: CamRockerParams):
        super().__init__(p)
        fwd, ret = p.laws()
        if p.mechanism == 0:
            self.branch = groove.base_branch(p.lambda1, p.lambda2, p.lambda3, p.assembly)
            self.kulisa = groove.kulisa_law(p.lambda1, p.lambda2, p.lambda3, fwd, ret, p.dwell, p.assembly)
            prof = groove.synthesize_law(self.kulisa, p.lambda1, p.lambda2, 1440, self.branch)
            radii = prof.rho * p.crank_radius
        else:
            self.cycle = DwellCycle(fwd, ret, p.phase_forward, p.phase_return, p.dwell, p.phi_start)
            a, l, r0 = p.cam_distance, p.follower_arm, p.cam_base_radius
            self.psi0 = math.acos((a * a + l * l - r0 * r0) / (2 * a * l))
            radii = np.array([l])
        self.r_min, self.r_max = float(np.min(radii)), float(np.max(radii))
        self.max_substep = self.substep_limit()
        # level 2, Kelvin-Voigt: the exponential step, sized on the contact's frequency
        w_c = math.sqrt(p.contact_stiffness * self.r_max * self.r_max / p.rocker_inertia)
        self._exp_step = EXP_STEP_PHASE / w_c
        self._kv_zeta = None     # a batch's view holds each variant's kelvin_voigt_zeta (one variant: its own)
        # output(): the rigid kinematics and geometry of one crank angle, asked twice per communication point
        self._rigid_at = last_call(self._rigid_kinematics)

    # -- kinematics (closed form per call) ------------------------------------------------------------------
    def kinematics(self, phi: float) -> tuple[float, float, float]:
        """(G, dG/dphi, d2G/dphi2) of the rocker."""
        if self.p.mechanism == 0:
            return self.kulisa.at(phi, self.m)
        s, s1, s2 = self.cycle.at(phi, self.m)
        sw = self.p.swing
        return sw * s, sw * s1, sw * s2

    def kinematics_jerk(self, phi: float) -> float:
        """d3G/dphi3 of the rocker: the law's jerk (laws.Law.jerk through the dwell cycle), scaled as
        :meth:`kinematics` scales its G''."""
        if self.p.mechanism == 0:
            return self.kulisa.jerk(phi)
        return self.p.swing * self.cycle.jerk(phi)

    def lever(self, phi: float, g: float) -> float:
        """Radius R [m] at which the clearance acts (stone radius, or follower arm)."""
        if self.p.mechanism == 0:
            return self.p.crank_radius * groove.stone_radius_scalar(phi, g, self.p.lambda1, self.p.lambda2, self.branch)
        return self.p.follower_arm

    def geometry(self, phi: float, kin=None) -> tuple[float, float]:
        """(pressure angle [rad], stone/contact radius [m]) at crank angle phi (rigid kinematics); ``kin`` is
        ``kinematics(phi)`` when the caller has it."""
        p, m = self.p, self.m
        g, g1, _ = kin or self.kinematics(phi)
        if p.mechanism == 0:
            rho, _, theta = groove.stone_scalar(phi, g, g1, p.lambda1, p.lambda2, self.branch, m)
            return theta, rho * p.crank_radius
        cx, cy, ex, ey, vx, vy = self._roller(g, g1)
        vn = m.hypot(vx, vy)
        if m.scalar:
            theta = 0.0 if vn == 0.0 else math.acos(min(1.0, abs(vx * ey - vy * ex) / vn))
        else:
            still = vn == 0.0
            theta = m.where(still, 0.0, m.acos(m.minimum(1.0, abs(vx * ey - vy * ex) / m.where(still, 1.0, vn))))
        return theta, m.hypot(cx, cy)

    def _roller(self, g: float, g1: float) -> tuple[float, float, float, float, float, float]:
        """Cam mechanism at follower angle psi = psi0 + G: the roller centre C (cam frame), the direction e of its
        velocity (psi increasing) and its velocity v relative to the cam per unit crank speed (geometry() and
        geometry_slopes())."""
        a, l, m = self.p.cam_distance, self.p.follower_arm, self.m
        psi = self.psi0 + g
        cx, cy = a - l * m.cos(psi), l * m.sin(psi)
        ex, ey = m.sin(psi), m.cos(psi)
        return cx, cy, ex, ey, l * g1 * ex + cy, l * g1 * ey - cx

    def geometry_slopes(self, phi: float, kin) -> tuple[float, float]:
        """(d pressure angle/dphi, d radius/dphi) of :meth:`geometry` at crank angle phi (``kin`` =
        ``kinematics(phi)``).  Slotted rocker: groove.stone_slopes_scalar (theta') and the stone radius's rate
        r rho' (stone_scalar's).  Cam: the follower angle psi = psi0 + G moves at G', so the roller centre C and the
        direction e turn with it (dC/dphi = l G' e, de/dphi = G' (cos psi, -sin psi)); the relative velocity
        v = l G' e + (cy, -cx) moves by l G'' e + l G' de/dphi + (dcy, -dcx); theta = arccos(z),
        z = |v x e| / |v|, has slope -z' / sqrt(1 - z^2) (0 where geometry() clips z at 1 or gives 0)."""
        p = self.p
        g, g1, g2 = kin
        if p.mechanism == 0:
            _, rho1, _ = groove.stone_scalar(phi, g, g1, p.lambda1, p.lambda2, self.branch)
            _, theta1 = groove.stone_slopes_scalar(phi, g, g1, g2, p.lambda1, p.lambda2, self.branch)
            return theta1, rho1 * p.crank_radius
        l = p.follower_arm
        cx, cy, ex, ey, vx, vy = self._roller(g, g1)
        cx1, cy1 = l * ex * g1, l * ey * g1
        ex1, ey1 = ey * g1, -ex * g1
        vx1 = l * g2 * ex + l * g1 * ex1 + cy1
        vy1 = l * g2 * ey + l * g1 * ey1 - cx1
        radius1 = (cx * cx1 + cy * cy1) / math.hypot(cx, cy)
        vn = math.hypot(vx, vy)
        if vn == 0.0:
            return 0.0, radius1
        cr = vx * ey - vy * ex
        z = abs(cr) / vn
        if z >= 1.0:
            return 0.0, radius1
        cr1 = vx1 * ey + vx * ey1 - vy1 * ex - vy * ex1
        z1 = math.copysign(1.0, cr) * cr1 / vn - abs(cr) * (vx * vx1 + vy * vy1) / vn ** 3
        return -z1 / math.sqrt(1.0 - z * z), radius1

    # -- model interface --------------------------------------------------------------------------------------
    def substep_limit(self) -> float:
        p = self.p
        if p.fidelity == 0:
            return math.inf
        w = math.sqrt(p.stiffness / p.rocker_inertia)
        if p.fidelity >= 2:
            r_max = getattr(self, "r_max", None)
            if r_max is None:
                return math.inf  # set again after the kinematic tables exist
            if p.fidelity == 3:   # both joints: frequency bound sqrt(k (1/m_s + r_max^2/J)) of each
                mobility = 1.0 / p.stone_mass + r_max * r_max / p.rocker_inertia
                w_c = math.sqrt(max(p.contact_stiffness, p.groove_stiffness) * mobility)
                return contact.max_substep(w_c, p.contact_law, p.restitution, p.contact_exponent)
            # contact: 0.1/omega_c and the contact law's damping rate (bounded by contact.damping_per_frequency
            # times omega_c, whatever the approach speed) times the sub-step <= 1: RK4 stays stable
            w_c = math.sqrt(p.contact_stiffness * r_max * r_max / p.rocker_inertia)
            return min(0.1 / w, contact.max_substep(w_c, p.contact_law, p.restitution, p.contact_exponent))
        return 0.1 / w

    def initial_state(self, u):
        g, g1, _ = self.kinematics(u[0])
        x = np.zeros(len(self.states))
        x[0], x[1] = g, g1 * u[1]
        if self.p.fidelity == 3:
            rho, rho1, _ = groove.stone_scalar(u[0], g, g1, self.p.lambda1, self.p.lambda2, self.branch)
            x[5], x[6] = self.p.crank_radius * rho, self.p.crank_radius * rho1 * u[1]
        return x

    def _kin(self, phi: float) -> tuple[float, float, float]:
        """(G, G', R) at crank angle phi: the rigid kulisa angle, its ratio, and (level 2) the lever R of the
        clearance; a pure function of phi, so ``advance`` evaluates it once per distinct sub-step time."""
        g, g1, _ = self.kinematics(phi)
        return g, g1, self.lever(phi, g) if self.p.fidelity == 2 else 0.0

    def _pin_stiffness(self, R: float) -> tuple[float, float]:
        """(k_pin, m_eff) of the level-2 clearance joint at lever R."""
        p = self.p
        return 1.0 / (1.0 / p.contact_stiffness + R * R / p.stiffness), p.rocker_inertia / (R * R)

    def _pin(self, g, g1, R, w, x):
        """(q, q_dot, k_pin, m_eff) of the clearance joint."""
        return (R * (g - x[0]), R * (g1 * w - x[1])) + self._pin_stiffness(R)

    def transmitted(self, phi: float, w: float, x, kin=None) -> tuple[float, float]:
        """(torque on the rocker from the transmission [N.m], pin force [N]) at fidelity 1/2; ``kin`` is
        ``_kin(phi)`` when the caller has it."""
        p = self.p
        g, g1, R = kin or self._kin(phi)
        if p.fidelity == 1:
            return p.stiffness * (g - x[0]) + p.damping * (g1 * w - x[1]), 0.0
        q, qd, k, m = self._pin(g, g1, R, w, x)
        # v_impact and the contact flag are memory set at the sub-step boundaries (advance): a contact that
        # began inside the present sub-step (flag still 0) approaches at its present penetration rate, not
        # at the stored speed of the previous contact (0 before the first one)
        v0 = (x[2] if x[4] != 0.0 else abs(qd)) if self.m.scalar else 0.0   # (a batch: Kelvin-Voigt, no onset speed)
        F = contact.contact_force(q, qd, p.clearance, k, p.contact_law, p.restitution, v0, m, p.contact_exponent,
                                  self.m, self._kv_zeta)
        return -F * R, F

    def _acceleration(self, t, gamma, omega, x, u, t0, kin=None) -> float:
        """Rocker angular acceleration [rad/s2] at time t (x: the contact memory, entries 2..4); ``kin`` a
        function of phi returning ``_kin(phi)`` (a memo inside ``advance``)."""
        phi = u[0] + u[1] * (t - t0)
        T, _ = self.transmitted(phi, u[1], (gamma, omega, x[2], x[3], x[4]), kin(phi) if kin else None)
        return (T + u[2]) / self.p.rocker_inertia

    def derivatives(self, t, x, u, t0):
        dx = np.zeros(len(self.states))
        if self.p.fidelity == 3:
            dx[0], dx[5] = x[1], x[6]
            dx[1], dx[6] = self._accelerations(u[0] + u[1] * (t - t0), u[1], u[2], x[0], x[1], x[5], x[6], x)
        elif self.p.fidelity > 0:
            dx[0], dx[1] = x[1], self._acceleration(t, x[0], x[1], x, u, t0)
        return dx

    def event_indicators(self, t, x, u):
        """The walls of the clearances (``switches``): q -+ clearance/2 of the stone pin (fidelity 2, 3) and
        d_g -+ groove_clearance/2 of the roller in the groove (fidelity 3); a constant 1 where a level has no such
        wall.  A contact begins or ends where one changes sign (contact.penetration's bands)."""
        p = self.p
        if p.fidelity == 2:
            q = self._pin(*self._kin(u[0]), u[1], x)[0]
            half = 0.5 * p.clearance
            return (q - half, q + half, 1.0, 1.0)
        if p.fidelity == 3:
            *_, (d_p, _), (d_g, _) = self._joints(u[0], u[1], x[0], x[1], x[5], x[6], x)
            half, g_half = 0.5 * p.clearance, 0.5 * p.groove_clearance
            return (d_p - half, d_p + half, d_g - g_half, d_g + g_half)
        return (1.0, 1.0, 1.0, 1.0)

    def at_event(self, t, x, u):
        """At a located switch, the contact memory ``advance`` updates there: onset (flag 1, impacts + 1, the
        approach speed), separation (flag 0)."""
        x = np.array(x, dtype=float)
        if self.p.fidelity == 2:
            self._update_contact(u[1], x, self._kin(u[0]))
        elif self.p.fidelity == 3:
            self._update_joints(u[0], u[1], x)
        return x

    def _update_contact(self, w: float, x: np.ndarray, kin) -> None:
        q, qd, _, _ = self._pin(*kin, w, x)
        pen, pen_dot, side = contact.penetration(q, qd, self.p.clearance)
        if side == 0.0:
            x[4] = 0.0
        elif x[4] == 0.0:
            x[4] = 1.0
            x[3] += 1.0
            x[2] = abs(pen_dot)

    # -- level 3: the stone on the slot with two clearances ---------------------------------------------
    def advance(self, t0, h, x, u):
        """RK4 on equal sub-steps of (gamma, omega) in plain floats (integrate.rk4_pair: the numbers of
        integrate.rk4 without an array per stage); at fidelity 2 the contact memory is updated at every
        sub-step boundary."""
        p = self.p
        x = np.array(x, dtype=float)
        if p.fidelity == 0:
            return x
        if p.fidelity == 3:
            return self._advance_two_clearances(t0, h, x, u)
        if p.fidelity == 2 and p.contact_law == contact.KELVIN_VOIGT and self.exact_contact:
            return self._advance_kelvin_voigt(t0, h, x, u)
        n = integrate.substeps(h, self.max_substep)
        dt = h / n
        # _kin per crank angle, once: RK4's two mid stages share one, a sub-step's end is the next start
        kin = functools.cache(self._kin)

        def acc(t, gamma, omega):
            return self._acceleration(t, gamma, omega, x, u, t0, kin)

        gamma, omega = float(x[0]), float(x[1])
        for i in range(n):
            t = t0 + i * dt
            if p.fidelity == 2:
                x[0], x[1] = gamma, omega
                self._update_contact(u[1], x, kin(u[0] + u[1] * (t - t0)))
            gamma, omega = integrate.rk4_pair(acc, t, dt, gamma, omega)
        x[0], x[1] = gamma, omega
        if p.fidelity == 2:
            self._update_contact(u[1], x, kin(u[0] + u[1] * h))
        return x

    def _rigid_kinematics(self, phi: float):
        """(kinematics(phi), geometry(phi)) of the rigid law at one crank angle."""
        kin = self.kinematics(phi)
        return kin, self.geometry(phi, kin)

    def output(self, t, x, u):
        p = self.p
        phi, w, tau_load = u[0], u[1], u[2]
        kin, (theta, radius) = self._rigid_at(phi)
        g, g1, g2 = kin
        if p.fidelity == 0:
            T = p.rocker_inertia * g2 * w * w - tau_load   # torque the transmission exerts on the rocker
            return (-g1 * T, g, g1 * w, theta, radius, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        if p.fidelity == 3:
            f_p, f_g, _, (ex, ey), _, _ = self._joints(phi, w, x[0], x[1], x[5], x[6], x)
            tau = -f_p * p.crank_radius * (math.cos(phi) * ey - math.sin(phi) * ex)
            return (tau, x[0], x[1], theta, x[5], abs(f_p), x[4], x[3], abs(f_g), x[9], x[8])
        # the lever of level 2 is the stone radius geometry() just computed (the same numbers), or the arm
        lever = (radius if p.mechanism == 0 else p.follower_arm) if p.fidelity == 2 else 0.0
        T, F = self.transmitted(phi, w, x, (g, g1, lever))
        return (-g1 * T, x[0], x[1], theta, radius, abs(F), x[4], x[3], 0.0, 0.0, 0.0)

    def _force_slopes(self, d, rate, play, k, m_eff, v_stored, flag) -> tuple[float, float, float, float]:
        """(F, dF/dd, dF/d rate, dF/dm_eff) of one clearance joint as :meth:`transmitted` / :meth:`_joints` use its
        law: contact.contact_force_slopes with the stored approach speed, or (flag 0, a contact begun inside the
        sub-step) |rate|; when that onset speed governs the Hunt-Crossley family's chi = C/|rate|, the damping
        term C side sign(rate) k pen^n does not move with the rate: slope 0 in the rate."""
        p = self.p
        onset = flag == 0.0
        v0 = abs(rate) if onset else v_stored
        F, F_d, F_rate, F_m = contact.contact_force_slopes(d, rate, play, k, p.contact_law, p.restitution, v0, m_eff,
                                                           p.contact_exponent)
        if onset and F != 0.0 and p.contact_law != contact.KELVIN_VOIGT and v0 > contact.V0_FLOOR:
            pen = contact.penetration(d, rate, play)[0]
            if contact.energy_speed(pen, k, m_eff, p.contact_exponent) <= v0:
                F_rate = 0.0
        return F, F_d, F_rate, F_m

    def output_jacobian(self, t, x, u):
        """d outputs / d (crank.phi, crank.w, rocker.tau) in closed form at every fidelity, from :meth:`output`'s
        equations (no differences: the outputs' slopes in the crank angle need one derivative more of the law and
        the groove than output() evaluates, which the laws and groove.py now give).

        Every level: pressure_angle and stone_radius are geometry of the rigid law alone, their slopes in the crank
        angle :meth:`geometry_slopes` (the groove's rho'' and theta', or the cam's roller geometry, which need G'').
        Fidelity 0: crank.tau = -G' (J G'' w^2 - rocker.tau) holds G'', so its slope in the angle needs the law's
        jerk d3G/dphi3 (:meth:`kinematics_jerk`: each law's c differentiated beside its own equation, laws.Law.jerk);
        rocker.phi = G and rocker.w = G' w.  Fidelity 1: rocker.phi, rocker.w are the states (slope 0), the torque
        T = k (G - gamma) + c (G' w - omega) moves with G' and G''.  Fidelity 2: the pin force
        F(q, qdot, k_pin, m_eff) with q = R (G - gamma), qdot = R (G' w - omega) and the lever R (the stone radius
        r rho(phi), or the constant arm) setting k_pin = 1/(1/contact_stiffness + R^2/stiffness) and
        m_eff = J/R^2; its partial derivatives in q, qdot and m_eff are contact.contact_force_slopes' (every law
        and phase: separated or clipped 0), the one in k_pin follows from the laws being homogeneous of degree 1
        in (k, m_eff) (Kelvin-Voigt's c = 2 zeta sqrt(k m), the Hunt-Crossley family's energy speed a function
        of k/m): dF/dk = (F - m dF/dm)/k.  A contact that began inside the present sub-step (flag still 0) takes
        |qdot| as its approach speed (:meth:`transmitted`); with a Hunt-Crossley-family law that speed, when it
        governs chi = C/v0, makes the damping term C side sign(qdot) k pen^n constant in qdot: its slope in qdot is
        0 there.  crank.tau = G' F R, pin_force = |F| (slope sign(F) dF); the contact flag and counters are
        states (slope 0); rocker.tau drives only the state at fidelities 1-3 (column 0).
        Fidelity 3: the two joints' forces with the stone's pose held (:meth:`_two_clearance_jacobian`: the crank
        pin and the profile point B_g with its normal n_g move with the angle, the conrod eye's rate with crank.w);
        stone_radius is the state rho_s there (slope 0).
        At a junction of the law's segments (G'' or its slope jumps) and on a kink of the contact law the slope of the
        side output() takes is returned."""
        p = self.p
        phi, w, tau_load = float(u[0]), float(u[1]), float(u[2])
        kin = self.kinematics(phi)
        g, g1, g2 = kin
        D = np.zeros((len(self.outputs), len(self.inputs)))
        D[3, 0], radius1 = self.geometry_slopes(phi, kin)
        if p.fidelity == 3:
            self._two_clearance_jacobian(x, u, D)
            return D
        D[4, 0] = radius1
        J = p.rocker_inertia
        if p.fidelity == 0:
            g3 = self.kinematics_jerk(phi)
            T = J * g2 * w * w - tau_load
            D[0] = (-g2 * T - g1 * J * g3 * w * w, -2.0 * g1 * J * g2 * w, g1)
            D[1, 0] = g1
            D[2, :2] = (g2 * w, g1)
            return D
        gamma, omega = float(x[0]), float(x[1])
        if p.fidelity == 1:
            k, c = p.stiffness, p.damping
            T = k * (g - gamma) + c * (g1 * w - omega)
            D[0, :2] = (-g2 * T - g1 * (k * g1 + c * g2 * w), -g1 * c * g1)
            return D
        R, R1 = (self.geometry(phi, kin)[1], radius1) if p.mechanism == 0 else (p.follower_arm, 0.0)
        q, qd, k, m = self._pin(g, g1, R, w, x)
        F, F_q, F_qd, F_m = self._force_slopes(q, qd, p.clearance, k, m, x[2], x[4])
        F_k = (F - m * F_m) / k
        F_R = F_k * (-2.0 * k * k * R / p.stiffness) + F_m * (-2.0 * m / R)
        q_phi = R1 * (g - gamma) + R * g1
        qd_phi = R1 * (g1 * w - omega) + R * g2 * w
        dF = np.array([F_q * q_phi + F_qd * qd_phi + F_R * R1, F_qd * R * g1, 0.0])
        D[0] = g1 * R * dF
        D[0, 0] += (g2 * R + g1 * R1) * F
        if F != 0.0:
            D[5] = math.copysign(1.0, F) * dF
        return D


class CamRockerBatch(variants.Vectorised):
    """Variants of :class:`CamRockerModel` stepped together (fmus.physics.variants): the law, the kinematics and the
    geometry of the rigid level (fidelity 0), the elastic transmission (fidelity 1, RK4 on each variant's own
    sub-steps) and the Kelvin-Voigt play (fidelity 2: exponential steps, a variant with a contact event in the step
    handed to its own scalar model) on arrays, the model's own methods.  Level 2 with the other contact laws and
    level 3 run each variant's scalar model.  A disc cam's pressure angle and roller radius are left out when no
    one reads them (``rows``): both are finite wherever the kinematics are."""
    attributes = ("branch", "kulisa", "cycle", "psi0", "r_min", "r_max")

    @classmethod
    def refuses(cls, models):
        p = models[0].p
        if p.fidelity == 3:
            return "level 3's two clearances"
        if p.fidelity == 2 and not (p.contact_law == contact.KELVIN_VOIGT and models[0].exact_contact):
            return "level 2's RK4 sub-steps of the Hunt-Crossley family"
        return None

    @classmethod
    def key(cls, model):
        """The law and its phases (or the groove's base four-bar): objects built from real parameters."""
        p = model.p
        if p.mechanism == 0:
            return (p.law_n, p.law_km, p.lambda1, p.lambda2, p.lambda3, p.dwell)
        return (p.law_n, p.law_km, p.phase_forward, p.phase_return, p.dwell, p.phi_start)

    def __init__(self, models):
        super().__init__(models)
        self.v._rigid_at = variants.last_call(self.v._rigid_kinematics)
        self._law_only = variants.last_call(lambda phi: (self.v.kinematics(phi), (0.0, 0.0)))
        self.v._kv_zeta = np.array([contact.kelvin_voigt_zeta(m.p.restitution) for m in self.models])
        self.v._exp_step = np.array([m._exp_step for m in self.models])

    def output(self, t, X, U, rows=None):
        v = self.v
        if rows is not None and v.p.mechanism == 1 and not {3, 4} & set(rows):
            memo = v._rigid_at                 # the rigid law alone: no geometry asked for
            v._rigid_at = self._law_only
            try:
                return v.m.stack(v.output(t, X, U))
            finally:
                v._rigid_at = memo
        return v.m.stack(v.output(t, X, U))

    def advance(self, t0, h, X, U):
        v = self.v
        x = np.array(X, dtype=float)
        if v.p.fidelity == 0:
            return x
        if v.p.fidelity == 2:
            return self._advance_kelvin_voigt(t0, h, X, U)

        def acc(t, gamma, omega):
            return v._acceleration(t, gamma, omega, x, U, t0, v._kin)

        x[0], x[1] = integrate_batch.rk4_pairs(acc, t0, h, v.max_substep, x[0], x[1])
        return x

    def _advance_kelvin_voigt(self, t0, h, X, U):
        """Level 2, Kelvin-Voigt (:meth:`KelvinVoigtPin._advance_kelvin_voigt`) on arrays: each variant's exponential
        steps in the contact mode of their start, on its own count of steps; a variant whose mode or wall changes
        within a step (a contact event, located by bisection), whose jet is not finite, or whose contact begins on
        a step boundary, takes the whole communication step with its own scalar model."""
        v = self.v
        phi0, w, tau = U[0], U[1], U[2]
        x = np.array(X, dtype=float)
        gamma, omega, flag = x[0], x[1], x[4]
        n = integrate_batch.substeps(h, v._exp_step)
        top, low = int(n.max()), int(n.min())
        t = t0 + 0.0 * n
        co = v._kv_coefficients(phi0 + w * (t - t0), w)
        alone = np.zeros(self.n, dtype=bool)
        for i in range(top):
            live = i < n
            t_end = np.where(i < n - 1, t0 + (i + 1) * h / n, t0 + h)
            side, mode = v._kv_mode(gamma, omega, co)
            jet = v._kv_jet(gamma, omega, tau, co, mode)
            alone |= ~np.isfinite(jet[3]) & live

            co_end = v._kv_coefficients(phi0 + w * (t_end - t0), w)

            def acc(tt, g, om, mode=mode, co_end=co_end, t_end=t_end):
                # the step's end: t + (t_end - t) is t_end exactly, wherever t and t_end are within a factor 2
                same = tt == t_end
                co_tt = co_end if same.all() else v._kv_coefficients(phi0 + w * (tt - t0), w)
                return v._kv_acceleration(g, om, tau, co_tt, mode)

            g1, o1 = integrate_batch.exprb32_pair(acc, t, t_end - t, gamma, omega, jet)
            side1, mode1 = v._kv_mode(g1, o1, co_end)
            changed = (side1 != side) | (mode1 != mode) | ((side1 != 0.0) & (flag == 0.0))
            if i < low:         # every variant takes this step
                alone |= changed
                gamma, omega, flag, t, co = g1, o1, np.where(side1 == 0.0, 0.0, flag), t_end, co_end
                continue
            alone |= live & changed
            gamma, omega = np.where(live, g1, gamma), np.where(live, o1, omega)
            flag = np.where(live & (side1 == 0.0), 0.0, flag)
            t = np.where(live, t_end, t)
            co = tuple(np.where(live, a, b) for a, b in zip(co_end, co))
        x[0], x[1], x[4] = gamma, omega, flag
        return self.by_scalar(alone, t0, h, X, U, x)


CamRockerModel.Batch = CamRockerBatch
