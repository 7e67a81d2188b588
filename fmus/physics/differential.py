"""James planetary differential (paper B, seed 004, §2.2.3-2.2.5, 2.2.7): ring z3, carrier b, sun z5.

Standard signed Willis form (speeds signed, positive in one common sense of rotation)::

    (w_sun - w_c) / (w_ring - w_c) = -k,   k = z_ring / z_sun        =>  w_sun = -k*w_ring + (1 + k)*w_c

This is MSL ``Modelica.Mechanics.Rotational.Components.IdealPlanetary`` with ``ratio = z_ring/z_sun``
(there ``(1 + ratio)*w_carrier = w_sun + ratio*w_ring``).  Mapping to the paper's convention (paper B
gives the ring and the satellites rotations in the *negative* sense, omega3 = -w_ring, omega4 = -w_planet,
omega5 = w_sun, omega_b = w_c): i^b_53 = (w_sun - w_c)/(w_ring - w_c) = -k (= -3 for k = 3, eq. 8) and
i^3_5b = (w_sun/w_c)|w_ring=0 = 1 + k (= 4, eq. 11); eq. (12) omega5 = k*omega3 + (1 + k)*omega_b is the
same relation.  Planet (absolute, eq. 13): w_planet = (z_ring/z_planet)*w_ring + (1 - z_ring/z_planet)*w_c.

Static torques (massless, ideal gearing; T_* = external torque applied TO each shaft of the gear set):
T_ring = k*T_sun, T_c = -(1 + k)*T_sun, so T_sun + T_ring + T_c = 0 and sum(T*w) = 0 (paper B table:
M3 = (z3/z5)*M5, M_b = (1 + z3/z5)*M5 = M3 + M5).  Mesh losses (optional ``efficiency`` eta < 1) act
in the carrier frame, where the set is an ordinary gear pair sun-ring: the side receiving relative power
gets eta times what the other side gives, so T_ring = eta*k*T_sun when relative power flows sun -> ring
and T_ring = k*T_sun/eta otherwise (switching on the sign of the relative power; lossless when the
relative speed is zero).  The carrier torque keeps the static balance T_c = -(T_sun + T_ring).

Port mapping (bond convention of fmus.slave): ring and carrier are motion-IN ports, so ring.tau and
carrier.tau are the reactions on the drivers: ring.tau = -T_ring, carrier.tau = -T_c.  sun is a
motion-OUT port, sun.tau is the torque the load exerts on the sun shaft.

fidelity 0 (rigid): sun.phi, sun.w from Willis; T_sun = sun.tau (massless sun).
fidelity 1 (compliant mesh): the kinematic sun angle phi_k = -k*phi_ring + (1+k)*phi_c drives the sun
inertia ``sun_inertia`` through the mesh stiffness ``c_alpha`` and damping ``d_mesh`` reduced to the sun:
mesh_torque M = c_alpha*(phi_k - phi_sun) + d_mesh*(w_k - w_sun), J_sun*dw_sun/dt = M + sun.tau, and the
gear set sees T_sun = -M.  Both levels share the state (phi_sun, w_sun); at fidelity 0 it is overwritten
with the kinematic values at each step (so outputs never depend on it).

Reversing pair at the ring (``ring_sense = -1``, ``ring_offset``): the ring gear turns as
``ring_offset - ring.phi`` at ``-ring.w``, and the port torque is reversed, so the power ring.tau*ring.w is kept.
A drive whose ring is driven against the input's sense (seed 004: the four-bar rocker and the cam follower
turn the same way, the differential adds them only in opposite senses) so needs only plain connections, which
every FMI importer applies the same way (OMSimulator and CoFmuPy drop an SSP LinearTransformation).

Angles of all three shafts are measured from a common zero (paper B: both inputs start together from
their extreme positions).  Ring and carrier positions are extrapolated inside a communication step with
their (held) speeds.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import integrate
from . import integrate_batch, variants
from .base import Model, ParameterError, Params, Signal, param
from .mathns import SCALAR


@dataclass(frozen=True)
class JamesDifferentialParams(Params):
    c_alpha: float = param(1.0e5, "N.m/rad", "mesh torsional stiffness reduced to the sun (fidelity 1)",
                           low=0.0, low_open=True)
    d_mesh: float = param(10.0, "N.m.s/rad", "mesh damping reduced to the sun (fidelity 1)", low=0.0)
    sun_inertia: float = param(0.02, "kg.m2", "inertia of the sun shaft with pinion z6 (fidelity 1)",
                               low=0.0, low_open=True)
    efficiency: float = param(1.0, "1", "basic (carrier-fixed) mesh efficiency sun-ring, 1 = lossless",
                              low=0.0, low_open=True, high=1.0)
    z_ring: int = param(72, "", "teeth of the internal ring gear z3 (seed gives only z3/z5 = 3)", low=12, high=2000)
    z_planet: int = param(24, "", "teeth of each planet (satellite) z4", low=6, high=2000)
    z_sun: int = param(24, "", "teeth of the sun gear z5", low=6, high=2000)
    n_planets: int = param(3, "", "number of planets a_p (seed: 3)", low=1, high=64)
    fidelity: int = param(0, "", "0: rigid kinematic; 1: compliant mesh with sun inertia", choices=(0, 1))
    ring_sense: int = param(1, "", "1: the ring turns as its input; -1: through a reversing pair "
                            "(ring angle = ring_offset - ring.phi, ring.tau reversed, power kept)", choices=(1, -1))
    ring_offset: float = param(0.0, "rad", "ring angle when the ring input is at 0 (a reversing pair's zero)")

    def check(self) -> None:
        if self.z_ring != self.z_sun + 2 * self.z_planet:
            raise ParameterError("z_ring", self.z_ring,
                                 f"coaxiality needs z_ring = z_sun + 2*z_planet = {self.z_sun + 2 * self.z_planet}")
        if (self.z_ring + self.z_sun) % self.n_planets:
            raise ParameterError("n_planets", self.n_planets,
                                 f"assembly needs (z_ring + z_sun)/n_planets integer, (z_ring + z_sun) = {self.z_ring + self.z_sun}")
        if self.n_planets > 1 and not (self.z_sun + self.z_planet) * math.sin(math.pi / self.n_planets) > self.z_planet + 2:
            raise ParameterError("n_planets", self.n_planets,
                                 "neighbourhood condition (z_sun + z_planet)*sin(pi/n_planets) > z_planet + 2 fails")


def willis_sun_speed(w_ring: float, w_carrier: float, k: float) -> float:
    """Sun speed from the signed Willis equation (w_s - w_c)/(w_r - w_c) = -k."""
    return -k * w_ring + (1.0 + k) * w_carrier


def static_torques(t_sun: float, w_ring: float, w_carrier: float, k: float, eta: float = 1.0, m=SCALAR):
    """External torques (T_ring, T_carrier) that hold the massless gear set in equilibrium with T_sun (``m``: the
    math namespace, fmus.physics.mathns: one variant or arrays over many)."""
    if m.scalar:
        if eta == 1.0:
            t_ring = k * t_sun
        else:
            # relative power entering the sun shaft (carrier frame): T_sun*(w_s - w_c) = T_sun*(-k)*(w_r - w_c)
            p_rel_sun = -t_sun * k * (w_ring - w_carrier)
            t_ring = eta * k * t_sun if p_rel_sun > 0.0 else k * t_sun / eta
    else:
        p_rel_sun = -t_sun * k * (w_ring - w_carrier)
        t_ring = m.where(eta == 1.0, k * t_sun, m.where(p_rel_sun > 0.0, eta * k * t_sun, k * t_sun / eta))
    return t_ring, -(t_sun + t_ring)


class JamesDifferentialModel(Model):
    Params = JamesDifferentialParams
    inputs = ("ring.phi", "ring.w", "carrier.phi", "carrier.w", "sun.tau")
    outputs = ("ring.tau", "carrier.tau", "sun.phi", "sun.w", "power_ring", "power_carrier", "power_sun",
               "planet_speed", "mesh_torque")
    states = (Signal("phi_sun", "rad", "angle of the sun shaft"),
              Signal("w_sun", "rad/s", "angular velocity of the sun shaft"))

    def __init__(self, p: JamesDifferentialParams):
        super().__init__(p)
        self.k = p.z_ring / p.z_sun
        self.kp = p.z_ring / p.z_planet

    def substep_limit(self) -> float:
        p = self.p
        if p.fidelity == 0:
            return math.inf
        rate = max(math.sqrt(p.c_alpha / p.sun_inertia), p.d_mesh / p.sun_inertia)
        return 0.25 / rate

    def ring(self, u) -> tuple[float, float]:
        """Angle and speed of the ring gear itself from the ring port's inputs (reversing pair applied)."""
        s = self.p.ring_sense
        return s * u[0] + self.p.ring_offset, s * u[1]

    def kinematic(self, u, dt: float = 0.0):
        k = self.k
        phi_r, w_r = self.ring(u)
        phi_r, phi_c, w_c = phi_r + w_r * dt, u[2] + u[3] * dt, u[3]
        return -k * phi_r + (1.0 + k) * phi_c, -k * w_r + (1.0 + k) * w_c

    def initial_state(self, u):
        return np.array(self.kinematic(u))

    def mesh(self, x, u, dt: float = 0.0) -> float:
        phi_k, w_k = self.kinematic(u, dt)
        return self.p.c_alpha * (phi_k - x[0]) + self.p.d_mesh * (w_k - x[1])

    def derivatives(self, t, x, u, t0):
        return np.array([x[1], (self.mesh(x, u, t - t0) + u[4]) / self.p.sun_inertia])

    def advance(self, t0, h, x, u):
        """Fidelity 1 in one exponential step (integrate.exprb32_pair with its jet in closed form): with the
        inputs held, the sun on its mesh is a linear oscillator forced linearly in time (the kinematic angle
        phi_k advances at w_k), which that step integrates exactly whatever the mesh stiffness -- no sub-steps
        and no stability limit (``substep_limit`` stays the mesh's time scale, for the reference solver)."""
        p = self.p
        if p.fidelity == 0:
            return self.m.stack(self.kinematic(u, h))
        j = p.sun_inertia

        def acc(t, q, v):
            return (self.mesh((q, v), u, t - t0) + u[4]) / j
        q, v = float(x[0]), float(x[1])
        jet = (acc(t0, q, v), -p.c_alpha / j, -p.d_mesh / j, p.c_alpha * self.kinematic(u)[1] / j)
        return np.array(integrate.exprb32_pair(acc, t0, h, q, v, jet))

    def output(self, t, x, u):
        k, p = self.k, self.p
        w_r, w_c = self.ring(u)[1], u[3]
        if p.fidelity == 0:
            phi_s, w_s = self.kinematic(u)
            m = -u[4]
        else:
            phi_s, w_s = x[0], x[1]
            m = self.mesh(x, u)
        t_ring, t_c = static_torques(-m, w_r, w_c, k, p.efficiency, self.m)
        ring_tau, carrier_tau = -t_ring, -t_c
        return (p.ring_sense * ring_tau, carrier_tau, phi_s, w_s, -ring_tau * w_r, -carrier_tau * w_c, -u[4] * w_s,
                self.kp * w_r + (1.0 - self.kp) * w_c, m)

    def output_jacobian(self, t, x, u):
        """From the output's equations: the mesh torque m (fidelity 0: -sun.tau; 1: the mesh law on the kinematic
        sun motion), the static torques ring.tau = f k m, carrier.tau = -(1 + f k) m with the efficiency factor f
        of the power's direction (constant on each side of its switch), and the powers as products."""
        k, p, s = self.k, self.p, self.p.ring_sense
        e = np.eye(5)
        d_phik = -k * s * e[0] + (1.0 + k) * e[2]      # the kinematic sun angle and speed
        d_wk = -k * s * e[1] + (1.0 + k) * e[3]
        w_r, w_c = s * u[1], u[3]
        if p.fidelity == 0:
            m, dm = -u[4], -e[4]
            d_phis, d_ws, w_s = d_phik, d_wk, self.kinematic(u)[1]
        else:
            m, dm = self.mesh(x, u), p.c_alpha * d_phik + p.d_mesh * d_wk
            d_phis, d_ws, w_s = np.zeros(5), np.zeros(5), x[1]
        f = 1.0
        if p.efficiency != 1.0:     # static_torques: the sun's relative power -t_sun k (w_r - w_c), t_sun = -m
            f = p.efficiency if m * k * (w_r - w_c) > 0.0 else 1.0 / p.efficiency
        d_ring, d_carrier = f * k * dm, -(1.0 + f * k) * dm
        ring_tau, carrier_tau = f * k * m, -(1.0 + f * k) * m
        return np.array([s * d_ring, d_carrier, d_phis, d_ws,
                         -(d_ring * w_r + ring_tau * s * e[1]), -(d_carrier * w_c + carrier_tau * e[3]),
                         -(e[4] * w_s + u[4] * d_ws), self.kp * s * e[1] + (1.0 - self.kp) * e[3], dm])


class JamesDifferentialBatch(variants.Vectorised):
    """Variants of :class:`JamesDifferentialModel` together: its kinematics, mesh and static torques on arrays, the
    compliant mesh's exponential step (fidelity 1) too."""
    attributes = ("k", "kp")

    def output(self, t, X, U, rows=None):
        v = self.v
        if rows is not None and set(rows) <= {0, 1, 2, 3} and v.p.fidelity == 0:   # powers and mesh unread
            k = v.k
            w_r, w_c = v.ring(U)[1], U[3]
            phi_s, w_s = v.kinematic(U)
            t_ring, t_c = static_torques(U[4], w_r, w_c, k, v.p.efficiency, v.m)
            Y = np.zeros((len(v.outputs), self.n))
            Y[0], Y[1], Y[2], Y[3] = v.p.ring_sense * -t_ring, -t_c, phi_s, w_s
            return Y
        return v.m.stack(v.output(t, X, U))

    def advance(self, t0, h, X, U):
        v = self.v
        p = v.p
        if p.fidelity == 0:
            return v.advance(t0, h, X, U)
        j = p.sun_inertia

        def acc(t, q, w):
            return (v.mesh((q, w), U, t - t0) + U[4]) / j
        q, w = X[0], X[1]
        jet = (acc(t0, q, w), -p.c_alpha / j, -p.d_mesh / j, p.c_alpha * v.kinematic(U)[1] / j)
        return v.m.stack(integrate_batch.exprb32_pair(acc, t0, h, q, w, jet))


JamesDifferentialModel.Batch = JamesDifferentialBatch
