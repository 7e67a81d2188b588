"""Flywheel on a torsionally compliant main shaft (seed 003, knife_drive.md sections 2.6-2.9).

Two inertias joined by a solid round shaft:

* flywheel side J1 = J_flywheel (flywheel + driven belt pulley), port ``pulley`` (motion out, input
  ``pulley.tau`` = torque of the belt);
* crank side J2 = J_crank + J_flywheel2, ports ``crank`` and ``aux`` (both motion out with the same
  motion; inputs ``crank.tau`` and ``aux.tau`` are added; an unconnected input stays 0).

Shaft stiffness c = G*pi*d**4/(32*l) (one solid round shaft, polar moment pi*d**4/32).  Seed 003 prints
16 instead of 32 because its reduced stiffness is that of two identical shafts in parallel (knife_drive.md
section 2.9); here there is one shaft.  Damping from seed 003's energy dissipation (loss) coefficient psi
(knife_drive.md section 2.8): b = psi*sqrt(c*J)/(2*pi) with the reduced inertia of the two-mass
oscillator J = J1*J2/(J1 + J2) (the seed uses its single reduced inertia J_red); damping ratio
zeta = psi/(4*pi), so psi < 4*pi keeps the shaft underdamped (bound: psi <= 12).  Default psi = 0.5 is the
value the seed adopts from Poliudov 1993.

Equations (shaft torque T = c*(phi1 - phi2) + b*(w1 - w2), transmitted from the flywheel to the crank)

    J1*dw1/dt = pulley.tau - T,       J2*dw2/dt = crank.tau + aux.tau + T.

Fidelity levels
  0  rigid shaft: one inertia J1 + J2, all ports carry the same motion; shaft_twist = 0 and shaft_torque is
     the torque the rigid shaft transmits, (J2*pulley.tau - J1*(crank.tau + aux.tau))/(J1 + J2), evaluated
     with the inputs of the last completed step (kept in a state entry, so no output depends directly on
     an input).
  1  compliant shaft, two degrees of freedom.

Integration is exact for inputs held over a step: the motion splits into the rigid-body motion of the
centre of inertia (constant acceleration) and the relative coordinate q = phi1 - phi2, a damped
oscillator J*q'' + b*q' + c*q = J*(pulley.tau/J1 - (crank.tau + aux.tau)/J2) solved in closed form.  So
any step size is stable, however stiff the shaft.

Default data (representative, the seeds give none): steel shaft G = 81 GPa, d = 50 mm, l = 0.6 m;
flywheel 1.5 kg.m2, crank side 0.3 kg.m2; main-shaft speed 100 rpm.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .base import Model, Params, Signal, last_call, param
from .variants import Vectorised


@dataclass(frozen=True)
class FlywheelShaftParams(Params):
    fidelity: int = param(1, "", "0: rigid shaft (1 DOF); 1: torsionally compliant shaft (2 DOF)", choices=(0, 1))
    J_flywheel: float = param(1.5, "kg.m2", "flywheel + driven pulley inertia (port pulley)", low=0.0,
                              low_open=True)
    J_crank: float = param(0.3, "kg.m2", "crank-side inertia (ports crank and aux)", low=0.0, low_open=True)
    J_flywheel2: float = param(0.0, "kg.m2", "optional second flywheel on the crank side", low=0.0)
    G: float = param(8.1e10, "Pa", "shear modulus of the shaft material (steel)", low=0.0, low_open=True)
    d: float = param(0.05, "m", "shaft diameter", low=0.0, low_open=True)
    l: float = param(0.6, "m", "shaft length between flywheel and crank", low=0.0, low_open=True)
    psi: float = param(0.5, "1", "energy dissipation (loss) coefficient of the shaft (seed 003: 0.5)",
                       low=0.0, high=12.0)
    w0: float = param(2.0 * math.pi * 100.0 / 60.0, "rad/s", "initial angular velocity (100 rpm)")
    phi0: float = param(0.0, "rad", "initial angle")


class FlywheelShaftModel(Model):
    """Flywheel + compliant shaft; see the module docstring."""
    Params = FlywheelShaftParams
    inputs = ("pulley.tau", "crank.tau", "aux.tau")
    outputs = ("pulley.phi", "pulley.w", "crank.phi", "crank.w", "aux.phi", "aux.w",
               "shaft_torque", "shaft_twist", "kinetic_energy", "potential_energy")
    states = (Signal("phi_flywheel", "rad", "angle of the flywheel side"),
              Signal("w_flywheel", "rad/s", "angular velocity of the flywheel side"),
              Signal("phi_crank", "rad", "angle of the crank side"),
              Signal("w_crank", "rad/s", "angular velocity of the crank side"),
              Signal("rigid_shaft_torque", "N.m", "shaft torque of the rigid level over the last step"))

    def __init__(self, p: FlywheelShaftParams):
        p.validate()
        self.J1 = p.J_flywheel
        self.J2 = p.J_crank + p.J_flywheel2
        self.Jt = self.J1 + self.J2
        self.J_red = self.J1 * self.J2 / self.Jt
        self.c = p.G * math.pi * p.d ** 4 / (32.0 * p.l)
        self.b = p.psi * math.sqrt(self.c * self.J_red) / (2.0 * math.pi)
        self.omega = math.sqrt(self.c / self.J_red)          # undamped natural frequency of the shaft mode
        self.sigma = 0.5 * self.b / self.J_red                # decay rate
        self.omega_d = math.sqrt(self.omega ** 2 - self.sigma ** 2)
        super().__init__(p)
        self._constants = last_call(self.step_constants)   # the same h step after step

    def step_constants(self, h):
        """(exp(-sigma h), cos(omega_d h), sin(omega_d h)): the shaft mode's decay and turn over a step h."""
        m = self.m
        return m.exp(-self.sigma * h), m.cos(self.omega_d * h), m.sin(self.omega_d * h)

    def initial_state(self, u):
        p = self.p
        return np.array([p.phi0, p.w0, p.phi0, p.w0, 0.0])

    def shaft_torque(self, x) -> float:
        if self.p.fidelity == 0:
            return x[4]
        return self.c * (x[0] - x[2]) + self.b * (x[1] - x[3])

    def derivatives(self, t, x, u, t0):
        t_crank = u[1] + u[2]
        if self.p.fidelity == 0:
            a = (u[0] + t_crank) / self.Jt
            return np.array([x[1], a, x[3], a, 0.0])
        ts = self.c * (x[0] - x[2]) + self.b * (x[1] - x[3])
        return np.array([x[1], (u[0] - ts) / self.J1, x[3], (t_crank + ts) / self.J2, 0.0])

    def ode_form(self):
        """Fidelity 0 keeps the rigid shaft's torque as a state set at each step's end from the held torques (a
        step quantity, derivative 0 in ``derivatives``): no ODE a host could integrate."""
        if self.p.fidelity == 0:
            return "fidelity 0's shaft torque is a state set at each step's end (rigid_shaft_torque), not an ODE"
        return None

    def advance(self, t0, h, x, u):
        """Exact solution over [t0, t0+h] for inputs held over the step."""
        J1, J2, Jt = self.J1, self.J2, self.Jt
        tp, tc = u[0], u[1] + u[2]
        a = (tp + tc) / Jt
        big_phi = (J1 * x[0] + J2 * x[2]) / Jt
        big_w = (J1 * x[1] + J2 * x[3]) / Jt
        phi_c = big_phi + big_w * h + 0.5 * a * h * h
        w_c = big_w + a * h
        if self.p.fidelity == 0:
            return self.m.stack((phi_c, w_c, phi_c, w_c, (J2 * tp - J1 * tc) / Jt))
        q_p = (tp / J1 - tc / J2) / (self.omega * self.omega)   # static twist under the held torques
        e0 = x[0] - x[2] - q_p
        v0 = x[1] - x[3]
        sg, wd = self.sigma, self.omega_d
        decay, cs, sn = self._constants(h)
        q = q_p + decay * (e0 * cs + (v0 + sg * e0) / wd * sn)
        qd = decay * (v0 * cs - (self.omega * self.omega * e0 + sg * v0) / wd * sn)
        k1, k2 = J2 / Jt, J1 / Jt
        return self.m.stack((phi_c + k1 * q, w_c + k1 * qd, phi_c - k2 * q, w_c - k2 * qd, 0.0))

    def output(self, t, x, u):
        twist = x[0] - x[2]
        kinetic = 0.5 * (self.J1 * x[1] * x[1] + self.J2 * x[3] * x[3])
        potential = 0.5 * self.c * twist * twist if self.p.fidelity == 1 else 0.0
        return (x[0], x[1], x[2], x[3], x[2], x[3], self.shaft_torque(x),
                twist if self.p.fidelity == 1 else 0.0, kinetic, potential)

    def output_jacobian(self, t, x, u):
        """Every output is a function of the state (the torques only drive it): no feed-through."""
        return np.zeros((len(self.outputs), len(self.inputs)))


class FlywheelShaftBatch(Vectorised):
    """Variants of :class:`FlywheelShaftModel` stepped together (fmus.physics.variants): the model's closed-form
    step and outputs on arrays, the step constants of each variant computed once per step size."""
    attributes = ("J1", "J2", "Jt", "J_red", "c", "b", "omega", "sigma", "omega_d")

    def __init__(self, models):
        super().__init__(models)
        self.v._constants = last_call(self.v.step_constants)

    def output(self, t, X, U, rows=None):
        if rows is not None and max(rows) < 6:    # the motions alone (states; the torque and energies unread)
            Y = np.zeros((len(self.v.outputs), self.n))
            Y[:6] = X[[0, 1, 2, 3, 2, 3]]
            return Y
        return self.v.m.stack(self.v.output(t, X, U))

    def advance(self, t0, h, X, U):
        return self.v.advance(t0, h, X, U)


FlywheelShaftModel.Batch = FlywheelShaftBatch
