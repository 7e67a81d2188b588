"""Asynchronous (induction) motor driving a pulley through a V-belt.

The driven pulley belongs to another component (the flywheel): its angle and speed are inputs (port
``pulley``, motion in) and the output ``pulley.tau`` is the torque the belt exerts on it (> 0 when driving).

Belt.  The belt is a spring-damper along the pitch line between the motor pulley (radius r_m) and the driven
pulley (radius r_d).  Its stretch is

    x = r_m*phi_m - r_d*(phi_d + theta_c),     F = c_belt*x + d_belt*dx/dt,

where ``c_belt`` [N/m] is the effective stiffness of the pre-tensioned belt (tight and slack span together)
and ``theta_c`` is the creep angle (fidelity 2, else 0).  Reduced to the driven pulley the belt is a
torsional spring c_belt*r_d**2 [N.m/rad] with damping d_belt*r_d**2.  Torque on the driven pulley
``pulley.tau = F*r_d``; the belt loads the motor shaft with ``belt_torque = F*r_m``.

Inside a communication step the driven pulley angle is extrapolated linearly from its inputs,
phi_d(t) = pulley.phi + pulley.w*(t - t0) (FMI 2.0 gives no input derivatives; the input speed is held).

Fidelity levels
  0  ideal speed source: the rotor turns at the rated speed, phi_m = phi_m(0) + w_rated*t; the motor torque
     is whatever the belt demands (motor_torque = belt_torque).
  1  Kloss static characteristic M(s) = 2*M_k/(s/s_k + s_k/s) = 2*M_k*s*s_k/(s**2 + s_k**2), slip
     s = (w_sync - w_m)/w_sync, with the rotor inertia J_motor (motor pulley included):
     J_motor*dw_m/dt = M(s) - F*r_m.  M_n = P_rated/w_rated, s_n = 1 - w_rated/w_sync,
     M_k = breakdown_ratio*M_n and s_k = s_n*(lambda + sqrt(lambda**2 - 1)) (the root with s_k > s_n, i.e.
     rated point on the stable branch), so that M(s_n) = M_n and max M = M(s_k) = M_k.
  2  fidelity 1 + belt creep (elastic slip).  The belt slips over the driven pulley at the rate
     d(theta_c)/dt = xi*(r_m/r_d)*|w_m| with xi = creep*F_el/F_rated, F_el = c_belt*x the elastic belt
     force and F_rated = M_n/r_m the rated belt force.  ``creep`` is the slip ratio at rated load
     (V-belts: 1-2 %).  In steady state w_d = (r_m/r_d)*w_m*(1 - xi).  Choice: the slip is driven by the
     elastic force only (no algebraic loop through the damper); |w_m| makes the creep dissipative in
     both directions of rotation.

Electric power (all levels): power_electrical = air-gap power / efficiency = M*w_sync/efficiency while
motoring (M >= 0) and M*w_sync*efficiency while braking (M < 0: the machine returns power to the grid).
power_mechanical = M*w_m.

Default data: a 2.2 kW, 4-pole, 50 Hz squirrel-cage motor of the 4A90L4 catalogue class (n_n = 1425 rpm,
n_sync = 1500 rpm, M_k/M_n = 2.2, J = 0.0056 kg.m2 plus about 0.0014 kg.m2 for the motor pulley,
efficiency 0.80), the size that drives small flat-bed and platen presses.  Belt: one SPZ V-belt, pulleys
100 mm / 500 mm (ratio 5), effective stiffness 2e5 N/m.  These are representative values, not seed data:
seed 002 only names "electric motor -> belt drive 1 -> gears 2-3 -> main shaft" and seed 003 takes the
motor as an absolutely rigid speed source (our fidelity 0).

Initial state: the motor pulley starts at phi_m = ratio*pulley.phi (ratio = r_d/r_m), so the belt force is
zero relative to the initial pulley angle; the rotor speed starts at w_start (negative: w_rated).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import integrate
from .base import Model, ParameterError, Params, Signal, param

RPM = 2.0 * math.pi / 60.0


@dataclass(frozen=True)
class MotorBeltParams(Params):
    fidelity: int = param(1, "", "0: ideal speed source + elastic belt; 1: Kloss motor with rotor inertia + "
                          "elastic belt; 2: level 1 + belt creep", choices=(0, 1, 2))
    P_rated: float = param(2200.0, "W", "rated (nameplate) shaft power", low=0.0, low_open=True)
    w_rated: float = param(1425.0 * RPM, "rad/s", "rated speed (1425 rpm)", low=0.0, low_open=True)
    w_sync: float = param(1500.0 * RPM, "rad/s", "synchronous speed (1500 rpm: 4 poles, 50 Hz)", low=0.0,
                          low_open=True)
    breakdown_ratio: float = param(2.2, "1", "breakdown torque / rated torque M_k/M_n", low=1.0, low_open=True)
    efficiency: float = param(0.80, "1", "stator efficiency: air-gap power / electrical power", low=0.0,
                              low_open=True, high=1.0)
    J_motor: float = param(0.007, "kg.m2", "rotor + motor pulley moment of inertia", low=0.0, low_open=True)
    d_motor_pulley: float = param(0.10, "m", "pitch diameter of the motor pulley", low=0.0, low_open=True)
    d_driven_pulley: float = param(0.50, "m", "pitch diameter of the driven pulley", low=0.0, low_open=True)
    c_belt: float = param(2.0e5, "N/m", "effective longitudinal belt stiffness (both spans)", low=0.0,
                          low_open=True)
    d_belt: float = param(200.0, "N.s/m", "belt damping along the pitch line", low=0.0)
    creep: float = param(0.015, "1", "elastic slip ratio of the belt at rated belt force (fidelity 2)",
                         low=0.0, high=0.2)
    w_start: float = param(-1.0, "rad/s", "initial motor speed (fidelity 1, 2); negative: w_rated")

    def check(self):
        if not self.w_rated < self.w_sync:
            raise ParameterError("w_rated", self.w_rated, f"must be < w_sync = {self.w_sync:g} rad/s")


class MotorBeltModel(Model):
    """Induction motor + V-belt; see the module docstring for the equations of each fidelity level."""
    Params = MotorBeltParams
    inputs = ("pulley.phi", "pulley.w")
    outputs = ("pulley.tau", "motor_speed", "motor_torque", "power_electrical", "power_mechanical",
               "belt_torque")
    states = (Signal("phi_motor", "rad", "rotor angle"),
              Signal("w_motor", "rad/s", "rotor angular velocity"),
              Signal("theta_creep", "rad", "accumulated creep of the belt over the driven pulley"))

    def __init__(self, p: MotorBeltParams):
        p.validate()
        self.r_m = 0.5 * p.d_motor_pulley
        self.r_d = 0.5 * p.d_driven_pulley
        self.ratio = self.r_d / self.r_m
        self.M_n = p.P_rated / p.w_rated
        self.s_n = 1.0 - p.w_rated / p.w_sync
        lam = p.breakdown_ratio
        self.M_k = lam * self.M_n
        self.s_k = self.s_n * (lam + math.sqrt(lam * lam - 1.0))
        self.F_rated = self.M_n / self.r_m
        self.creep_gain = (p.creep / self.F_rated * (self.r_m / self.r_d)) if p.fidelity == 2 else 0.0
        super().__init__(p)

    # -- laws ----------------------------------------------------------------------------------------------
    def kloss_torque(self, w_m: float) -> float:
        """Kloss static characteristic M(s) = 2*M_k*s*s_k/(s**2 + s_k**2) [N.m] at rotor speed w_m."""
        s = (self.p.w_sync - w_m) / self.p.w_sync
        return 2.0 * self.M_k * s * self.s_k / (s * s + self.s_k * self.s_k)

    def _belt(self, x, phi_d: float, w_d: float):
        """(belt force F, elastic part F_el, creep rate) for rotor state x and driven pulley motion."""
        p = self.p
        f_el = p.c_belt * (self.r_m * x[0] - self.r_d * (phi_d + x[2]))
        creep_rate = self.creep_gain * f_el * abs(x[1])
        force = f_el + p.d_belt * (self.r_m * x[1] - self.r_d * (w_d + creep_rate))
        return force, creep_rate

    # -- Model interface -----------------------------------------------------------------------------------
    def substep_limit(self) -> float:
        p = self.p
        if p.fidelity == 0:
            return math.inf
        w_belt = math.sqrt(p.c_belt * self.r_m ** 2 / p.J_motor)
        # real decay rates: belt damping + slope of the Kloss curve at s = 0 (its steepest point) on the
        # rotor, and the creep relaxation d(theta_c')/d(theta_c) at 1.5 times the synchronous speed
        rate = (p.d_belt * self.r_m ** 2 + 2.0 * self.M_k / (self.s_k * p.w_sync)) / p.J_motor
        rate += self.creep_gain * p.c_belt * self.r_d * 1.5 * p.w_sync
        return min(0.25 / w_belt, 0.5 / rate)

    def initial_state(self, u):
        p = self.p
        w0 = p.w_rated if (p.fidelity == 0 or p.w_start < 0.0) else p.w_start
        return np.array([self.ratio * u[0], w0, 0.0])

    def _rates(self, t, x, u, t0) -> tuple[float, float]:
        """(rotor acceleration [rad/s2], creep rate [rad/s]) at levels 1, 2 for the rotor state x."""
        force, creep_rate = self._belt(x, u[0] + u[1] * (t - t0), u[1])
        return (self.kloss_torque(x[1]) - force * self.r_m) / self.p.J_motor, creep_rate

    def derivatives(self, t, x, u, t0):
        p = self.p
        if p.fidelity == 0:
            return np.array([p.w_rated, 0.0, 0.0])
        return np.array([x[1], *self._rates(t, x, u, t0)])

    def advance(self, t0, h, x, u):
        if self.p.fidelity != 1:
            return super().advance(t0, h, x, u)
        # level 1 has no creep (its rate is 0): RK4 on (phi_motor, w_motor) in plain floats, the base class's
        # numbers without an array per stage
        x = np.array(x, dtype=float)
        theta = x[2]

        def acc(t, phi, w):
            return self._rates(t, (phi, w, theta), u, t0)[0]

        x[0], x[1] = integrate.rk4_pairs(acc, t0, h, self.max_substep, float(x[0]), float(x[1]))
        return x

    def output(self, t, x, u):
        p = self.p
        force, _ = self._belt(x, u[0], u[1])
        belt_torque = force * self.r_m
        motor_torque = belt_torque if p.fidelity == 0 else self.kloss_torque(x[1])
        air_gap = motor_torque * p.w_sync
        p_el = air_gap / p.efficiency if air_gap >= 0.0 else air_gap * p.efficiency
        return (force * self.r_d, x[1], motor_torque, p_el, motor_torque * x[1], belt_torque)

    def output_jacobian(self, t, x, u):
        """The belt force's slopes in the driven pulley's motion (the creep rate follows the elastic force), and
        at fidelity 0, where the motor torque is the belt's, the powers that follow it."""
        p = self.p
        force, _ = self._belt(x, u[0], u[1])
        d_force = np.array([-p.c_belt * self.r_d * (1.0 - p.d_belt * self.r_d * self.creep_gain * abs(x[1])),
                            -p.d_belt * self.r_d])
        d_belt = d_force * self.r_m
        d_motor = d_belt if p.fidelity == 0 else np.zeros(2)
        air_gap = (force * self.r_m if p.fidelity == 0 else self.kloss_torque(x[1])) * p.w_sync
        d_el = d_motor * p.w_sync * (1.0 / p.efficiency if air_gap >= 0.0 else p.efficiency)
        return np.array([d_force * self.r_d, np.zeros(2), d_motor, d_el, d_motor * x[1], d_belt])

    def belt_energy(self, x, phi_d: float) -> float:
        """Elastic energy of the belt [J]."""
        stretch = self.r_m * x[0] - self.r_d * (phi_d + x[2])
        return 0.5 * self.p.c_belt * stretch * stretch
