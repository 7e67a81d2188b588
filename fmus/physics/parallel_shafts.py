"""Two identical shafts in parallel between a drive and a knife (seed 003, Poliudov & Knysh, Fig. 3; spec
knife_drive.md sections 2.6-2.9).

The seed's dynamic model of the spine-knife drive: a double-crank parallelogram whose two cranks sit on two
identical shafts.  The driving shaft S1 joins the drive end (angle phi0, flywheel + belt pulley, port
``pulley``) to the cranks; the driven shaft S2 joins the second flywheel J1 (angle phi2) to the cranks; the
V-belt between the two flywheels (stiffness c2, damping b2) is there only to keep the parallelogram from
flipping into an antiparallelogram.  Both cranks turn with the coupler that carries the knife, so both shafts
end on one node, the knife (angle phi1, inertia J_red of every moving mass reduced to it, port ``crank``).

    drive J0 (phi0) --[S1: c1, b1]-------------------- knife J_red (phi1) <- crank.tau (M_dist's reaction)
        |                                              |
        +--[belt: c2, b2]-- flywheel J1 (phi2) --[S2: c1, b1]

Each shaft: c1 = G*pi*d^4/(32*l) (solid round shaft, polar moment pi*d^4/32).  In parallel they give the
seed's reduced stiffness C_red = 2*c1 = G*pi*d^4/(16*l) (its printed 16).  Damping from the seed's
dissipation coefficient psi (mu_red = 0.5, Poliudov 1993): b_red = psi*sqrt(C_red*J_red)/(2*pi), i.e.
n = b_red/(2 J_red) = p*psi/(4*pi) with p = sqrt(C_red/J_red); each shaft carries half, b1 = b_red/2.

Equations (shaft torques T1 = c1*(phi0 - phi1) + b1*(w0 - w1), T2 = c1*(phi2 - phi1) + b1*(w2 - w1), belt
torque Tb = c2*(phi0 - phi2) + b2*(w0 - w2))

    J0*dw0/dt = pulley.tau - T1 - Tb,   J1*dw2/dt = Tb - T2,   J_red*dw1/dt = crank.tau + aux.tau + T1 + T2.

With a rigid motor (w0 constant) these are the seed's eq. (10) in dphi = phi1 - phi0, dphi1 = phi2 - phi0,
dphi2 = phi1 - phi2: (10b) is the flywheel's equation as printed; (10a) as printed lacks the driven shaft's
torque on the knife (c1*dphi2 + b1*dphi2'), which is kept here (spec A2) -- without it the two shafts would
not be in parallel and C_red would not be 2*c1.  ``eq10_frequencies`` gives the two natural frequencies of
that rigid-motor system in closed form.

Drive end.  ``rigid_drive = 0``: the inertia J_drive, turned by the torque on port ``pulley`` (a motor and
belt, MotorBelt).  ``rigid_drive = 1``: the seed's motor D, "absolutely rigid": the drive end turns at w0 from
phi0, whatever the torque on ``pulley`` (its row of the equations is phi0'' = 0, the limit J_drive -> infinity);
leave ``pulley`` unconnected.  With it, fidelity 1 is the seed's eq. (10) exactly.

Fidelity levels
  0  the seed's reduction to eq. (11): the cranks drive each other through the coupler, so both shaft ends
     turn alike, phi2 = phi0 (the belt and J1 follow the drive end rigidly): J_red*dphi'' + b_red*dphi' +
     C_red*dphi = M_dist with C_red = 2*c1, b_red = 2*b1; the drive end carries J0 + J1.
  1  eq. (10): the driven shaft S2 through the flywheel J1 and the elastic V-belt (two elastic degrees of
     freedom besides the rotation of the whole).

End stop (a jam): with ``stop_stiffness`` > 0 the knife runs into a stiff stop at the knife angle
``stop_position`` (an absolute angle phi1, whole turns counted from phi0) that blocks its forward rotation past
it (:class:`.contact.EndStop`, a Kelvin-Voigt contact of stated stiffness and damping): J_red*dw1/dt gains
-max(k_s (phi1 - phi_stop) + d_s w1, 0) while phi1 > phi_stop (``stop_catch`` = 0: it cannot pull, the knife
may rebound), or -(k_s (phi1 - phi_stop) + d_s w1) from the instant the knife reached it on (``stop_catch`` = 1:
the knife caught, the state ``stop_caught``).  A step in which the knife is short of the stop at both ends and
not caught is the exact step below; one that touches it is integrated with RK4 on sub-steps sized by the stop's
and the shafts' frequency on J_red.  0 (default): no stop, the linear system exactly.

Integration is exact for inputs held over a step: the system is linear, x' = A x + B u, so
x(t0 + h) = E x(t0) + F u with [[E, F], [0, I]] = exp([[A, B], [0, 0]] h), computed once per step size by
scaling and squaring of the Taylor series (numpy only; the rotation of the whole makes A singular, which the
series does not mind), on the matrix balanced by measuring the rates in units of the stiffest mode.  Any step is stable, however stiff the shafts.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import integrate
from .base import Model, Params, Signal, param
from .contact import EndStop


def shaft_stiffness(G: float, d: float, l: float) -> float:
    """c1 = G*pi*d^4/(32*l) [N.m/rad]: one solid round shaft."""
    return G * math.pi * d ** 4 / (32.0 * l)


def eq10_frequencies(J_red: float, J1: float, c1: float, c2: float) -> tuple[float, float]:
    """Undamped natural frequencies [rad/s] (low, high) of eq. (10) with the motor rigid: the roots of
    det(K - w^2 M) = 0 for M = diag(J_red, J1), K = [[2 c1, -c1], [-c1, c1 + c2]] in (dphi, dphi1)."""
    a, b = 2.0 * c1 / J_red, (c1 + c2) / J1
    root = math.sqrt((a - b) ** 2 + 4.0 * c1 * c1 / (J_red * J1))
    return math.sqrt(0.5 * (a + b - root)), math.sqrt(0.5 * (a + b + root))


def expm(M: np.ndarray) -> np.ndarray:
    """Matrix exponential: scaling to a 1-norm <= 0.5, 20 Taylor terms (Horner; truncation < 1e-25), squaring."""
    norm = float(np.max(np.sum(np.abs(M), axis=0)))
    s = max(0, int(math.ceil(math.log2(norm / 0.5)))) if norm > 0.5 else 0
    X = M / 2.0 ** s
    eye = np.eye(M.shape[0])
    total = eye
    for k in range(20, 0, -1):
        total = eye + X @ total / k
    for _ in range(s):
        total = total @ total
    return total


@dataclass(frozen=True)
class ParallelShaftsParams(Params):
    fidelity: int = param(1, "", "0: eq. (11), shaft ends turn alike (phi2 = phi0); 1: eq. (10), driven shaft through "
                                 "the flywheel J1 and the V-belt", choices=(0, 1))
    J_drive: float = param(0.2, "kg.m2", "flywheel + belt pulley on the driving shaft's drive end (port pulley)",
                           low=0.0, low_open=True)
    J_flywheel: float = param(0.2, "kg.m2", "flywheel J1 on the driven shaft's end (angle phi2)", low=0.0,
                              low_open=True)
    J_red: float = param(4.0e-3, "kg.m2", "moment of inertia of the masses reduced to the knife (ports crank, aux)",
                         low=0.0, low_open=True)
    G: float = param(8.1e10, "Pa", "shear modulus of the shafts (steel)", low=0.0, low_open=True)
    d: float = param(0.05, "m", "diameter of each shaft", low=0.0, low_open=True)
    l: float = param(0.6, "m", "length of each shaft", low=0.0, low_open=True)
    psi: float = param(0.5, "1", "dissipation coefficient mu_red of the shafts (seed 003: 0.5)", low=0.0, high=12.0)
    belt_stiffness: float = param(500.0, "N.m/rad", "torsional stiffness c2 of the V-belt between the flywheels",
                                  low=0.0, low_open=True)
    belt_damping: float = param(0.75, "N.m.s/rad", "torsional damping b2 of the V-belt", low=0.0)
    rigid_drive: int = param(0, "", "0: the drive end is an inertia J_drive turned by the torque on port pulley; 1: the "
                             "drive end turns at w0 whatever that torque (the seed's absolutely rigid motor D)",
                             choices=(0, 1))
    w0: float = param(2.0 * math.pi * 600.0 / 60.0, "rad/s", "initial angular velocity of every part (600 rpm)")
    phi0: float = param(0.0, "rad", "initial angle of every part")
    stop_position: float = param(0.0, "rad", "knife angle phi1 of an end stop (a jam) that blocks the knife's "
                                 "forward rotation past it: an absolute angle, whole turns counted")
    stop_stiffness: float = param(0.0, "N.m/rad", "stiffness of the end stop on the knife (0: no stop)", low=0.0)
    stop_damping: float = param(0.0, "N.m.s/rad", "damping of the end stop while it acts", low=0.0)
    stop_catch: int = param(0, "", "0: an end stop (pushes back, never pulls: the knife may rebound); 1: a catch (the "
                            "knife, once at the stop, is held there both ways: stuck in the block)", choices=(0, 1))


class ParallelShaftsModel(EndStop, Model):
    """Drive end, flywheel J1 and knife joined by two shafts and a belt; see the module docstring."""
    Params = ParallelShaftsParams
    stop_signals = ("crank.phi", "crank.w")
    inputs = ("pulley.tau", "crank.tau", "aux.tau")
    outputs = ("pulley.phi", "pulley.w", "crank.phi", "crank.w", "aux.phi", "aux.w", "shaft_torque",
               "shaft_twist", "driven_twist", "belt_twist", "kinetic_energy", "potential_energy", "dissipation")
    states = (Signal("phi_drive", "rad", "angle of the drive end (phi0)"),
              Signal("w_drive", "rad/s", "angular velocity of the drive end"),
              Signal("phi_knife", "rad", "angle of the cranks and knife (phi1)"),
              Signal("w_knife", "rad/s", "angular velocity of the cranks and knife"),
              Signal("phi_flywheel", "rad", "angle of the flywheel J1 on the driven shaft (phi2)"),
              Signal("w_flywheel", "rad/s", "angular velocity of the flywheel J1"),
              Signal("stop_caught", "1", "1 once the knife has reached a catching end stop (stop_catch = 1), else 0"))

    def __init__(self, p: ParallelShaftsParams):
        p.validate()
        self.c1 = shaft_stiffness(p.G, p.d, p.l)
        self.C_red = 2.0 * self.c1
        self.b_red = p.psi * math.sqrt(self.C_red * p.J_red) / (2.0 * math.pi)
        self.b1 = 0.5 * self.b_red
        self.A, self.B = self._matrices(p)
        self._steps: dict[tuple[float, bool], tuple[np.ndarray, np.ndarray]] = {}
        super().__init__(p)

    def _matrices(self, p: ParallelShaftsParams) -> tuple[np.ndarray, np.ndarray]:
        """x' = A x + B u in x = (phi0, w0, phi1, w1, phi2, w2), u = (pulley.tau, crank.tau + aux.tau)."""
        c1, b1 = self.c1, self.b1
        K = np.zeros((3, 3))             # stiffness and damping between the nodes 0 (drive), 1 (knife), 2 (flywheel)
        D = np.zeros((3, 3))
        if p.fidelity == 0:              # phi2 = phi0: both shafts from the drive end, J1 rides on it
            links = [(0, 1, 2.0 * c1, 2.0 * b1)]
            inertia = np.array([p.J_drive + p.J_flywheel, p.J_red, 1.0])
        else:
            links = [(0, 1, c1, b1), (2, 1, c1, b1), (0, 2, p.belt_stiffness, p.belt_damping)]
            inertia = np.array([p.J_drive, p.J_red, p.J_flywheel])
        for i, j, c, b in links:
            for m, v in ((K, c), (D, b)):
                m[i, i] += v
                m[j, j] += v
                m[i, j] -= v
                m[j, i] -= v
        A = np.zeros((6, 6))
        B = np.zeros((6, 2))
        for i in range(3):
            A[2 * i, 2 * i + 1] = 1.0
            A[2 * i + 1, 0::2] = -K[i] / inertia[i]
            A[2 * i + 1, 1::2] = -D[i] / inertia[i]
        B[1, 0] = 1.0 / inertia[0]
        B[3, 1] = 1.0 / p.J_red
        if p.rigid_drive:                # phi0'' = 0: the drive end is held at w0, pulley.tau moves nothing
            A[1] = 0.0
            B[1] = 0.0
        if p.fidelity == 0:              # the flywheel row repeats the drive end's
            A[4:6] = A[0:2]
            B[4:6] = B[0:2]
        return A, B

    def substep_limit(self) -> float:
        """Exact steps (inf) without a stop; with one, the RK4 sub-step of the knife node between the stop and
        the two shafts."""
        if not self.has_stop:
            return math.inf
        return self.stop_substep(self.p.J_red, self.C_red, self.b_red)

    def initial_state(self, u):
        p = self.p
        return np.array([p.phi0, p.w0, p.phi0, p.w0, p.phi0, p.w0, 0.0])

    def derivatives(self, t, x, u, t0):
        dx = np.zeros(7)
        dx[:6] = self.A @ x[:6] + self.B @ np.array([u[0], u[1] + u[2]])
        if self.has_stop:
            dx[3] += self.stop_load(x[2], x[3], x[6]) / self.p.J_red
        return dx

    def ode_form(self):
        return self.stop_ode_form()

    def step_matrices(self, h: float, caught: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """(E, F) of x(t0 + h) = E x(t0) + F u for inputs held over h (cached per h; a step controller's many
        sizes are kept to the last 16).  h is taken to the picosecond: a host whose time doubles wander an ulp
        off its grid (libcosim) would otherwise compute a new exponential every step, and the stiff shafts
        (|A h| ~ 4e4 at 1 ms) turn that ulp into ~1e-11 of the result over 50 steps.  ``caught``: with the knife
        held by a catch, a linear spring and damper to the stop's angle on it (u then ends with a 1 that carries
        the stop's angle)."""
        h = round(h * 1e12) / 1e12
        key = (h, caught)
        if key not in self._steps:
            if len(self._steps) >= 16:
                self._steps.pop(next(iter(self._steps)))
            A, B = self._caught_matrices() if caught else (self.A, self.B)
            n, m = B.shape
            # rates in units of the stiffest mode (w/Omega): the matrix is then balanced (entries ~ Omega*h);
            # unbalanced (c/J ~ 4e7 beside 1), the series loses the rigid rotation's last digits and the
            # energy balance of a run drifts by 0.3 % of what the shafts dissipate
            omega = math.sqrt(float(np.max(np.abs(A[1::2, 0::2]))))
            scale = np.ones(n + m)
            scale[1:6:2] = 1.0 / omega
            aug = np.zeros((n + m, n + m))
            aug[:n, :n] = A * h
            aug[:n, n:] = B * h
            e = expm(scale[:, None] * aug / scale[None, :]) / scale[:, None] * scale[None, :]
            self._steps[key] = (e[:n, :n], e[:n, n:])
        return self._steps[key]

    def _caught_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """(A, B) with the knife held by the catch: J_red w1' gains -k_s (phi1 - phi_stop) - d_s w1, the stop's
        angle entering through a third input held at 1."""
        p = self.p
        A = self.A.copy()
        A[3, 2] -= p.stop_stiffness / p.J_red
        A[3, 3] -= p.stop_damping / p.J_red
        B = np.zeros((6, 3))
        B[:, :2] = self.B
        B[3, 2] = p.stop_stiffness * p.stop_position / p.J_red
        return A, B

    def advance(self, t0, h, x, u):
        """Exact solution over [t0, t0 + h] for inputs held over the step (module docstring: a step that touches
        the stop on RK4 sub-steps; with the knife caught, exact again)."""
        if h == 0.0:
            return np.array(x, dtype=float)
        torque = u[1] + u[2]
        if self.has_stop and x[6] >= 0.5:
            E, F = self.step_matrices(h, caught=True)
            return np.append(E @ x[:6] + F @ np.array([u[0], torque, 1.0]), 1.0)
        E, F = self.step_matrices(h)
        end = np.append(E @ x[:6] + F @ np.array([u[0], torque]), x[6])
        if self.has_stop and (self.stop_penetration(x[2]) > 0.0 or self.stop_penetration(end[2]) > 0.0):
            return self._advance_at_stop(t0, h, np.array(x, dtype=float), u)
        return end

    def _advance_at_stop(self, t0, h, x, u):
        """RK4 on sub-steps over a step that touches the stop, the catch's memory kept after each sub-step."""
        n = integrate.substeps(h, self.max_substep)
        dt = h / n
        for i in range(n):
            x = integrate.rk4(self.derivatives, t0 + i * dt, dt, x, u, math.inf)
            x[6] = self.stop_caught(x[2], x[6])
        return x

    def output(self, t, x, u):
        p = self.p
        q1, q1d = x[0] - x[2], x[1] - x[3]          # driving shaft S1
        q2, q2d = x[4] - x[2], x[5] - x[3]          # driven shaft S2
        qb, qbd = x[4] - x[0], x[5] - x[1]          # belt (the seed's dphi1)
        torque = self.c1 * (q1 + q2) + self.b1 * (q1d + q2d)
        if p.fidelity == 0:              # phi2 = phi0 exactly (the state rows agree only to round-off)
            q2, q2d, qb = q1, q1d, 0.0
            torque = self.C_red * q1 + self.b_red * q1d
            kinetic = 0.5 * ((p.J_drive + p.J_flywheel) * x[1] ** 2 + p.J_red * x[3] ** 2)
            potential = 0.5 * self.C_red * q1 * q1
            dissipation = self.b_red * q1d * q1d
        else:
            kinetic = 0.5 * (p.J_drive * x[1] ** 2 + p.J_red * x[3] ** 2 + p.J_flywheel * x[5] ** 2)
            potential = 0.5 * (self.c1 * (q1 * q1 + q2 * q2) + p.belt_stiffness * qb * qb)
            dissipation = self.b1 * (q1d * q1d + q2d * q2d) + p.belt_damping * qbd * qbd
        if self.has_stop:                # the stop's elastic energy, and the power its damping takes
            energy = self.stop_energy(x[2], x[6])
            if energy > 0.0:             # the damping's share of the stop's load, times the knife's speed
                elastic = p.stop_stiffness * self.stop_penetration(x[2])
                potential += energy
                dissipation += (-self.stop_load(x[2], x[3], x[6]) - elastic) * x[3]
        return (x[0], x[1], x[2], x[3], x[2], x[3], torque, q1, q2, qb, kinetic, potential, dissipation)

    def output_jacobian(self, t, x, u):
        """Every output is a function of the state (the torques only drive it): no feed-through."""
        return np.zeros((len(self.outputs), len(self.inputs)))
