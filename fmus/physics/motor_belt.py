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

Supply and brake (inputs ``supply`` and ``brake``; transients: start-up, speed change, emergency stop)
  ``supply`` is the supply frequency over its rated value (1: the nameplate's 50 Hz; 0: switched off).  A
  frequency converter keeps the flux (V/f constant), so the Kloss curve keeps its breakdown torque M_k and
  its breakdown slip SPEED s_k*w_sync, and moves with the synchronous speed supply*w_sync:
  M = 2*M_k*W*W_k/(W**2 + W_k**2) with the slip speed W = supply*w_sync - w_m and W_k = s_k*w_sync (at
  supply = 1 this is the Kloss law above).  supply <= 0: no torque (the motor is off).  Fidelity 0 (the
  ideal source) turns at supply*w_rated.
  ``brake`` >= 0.5 commands a spring-applied brake on the rotor (motor side: it holds the whole drive
  through the belt).  It engages ``brake_delay`` seconds after the command (its timer, the state
  ``brake_timer``, restarts when the command is released) with the holding torque ``holding_torque``: Coulomb
  friction, -holding_torque*sign(w_m) while the rotor turns; at rest it holds while the other torques on the
  rotor stay within holding_torque.  Inside a sub-step the rotor's stop is located (the speed's zero by linear
  interpolation, exact for a constant deceleration) and the rotor is held from there.  A brake needs the
  rotor's own dynamics (fidelity 1 or 2); at fidelity 0 a holding_torque is refused.

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
from . import integrate_batch, variants
from .base import Model, ParameterError, Params, Signal, param
from .variants import Vectorised

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
    holding_torque: float = param(0.0, "N.m", "holding torque of the rotor brake (0: no brake; fidelity 1, 2)",
                                low=0.0)
    brake_delay: float = param(0.0, "s", "time from the brake command (input brake >= 0.5) to full torque",
                               low=0.0)

    def check(self):
        if not self.w_rated < self.w_sync:
            raise ParameterError("w_rated", self.w_rated, f"must be < w_sync = {self.w_sync:g} rad/s")
        if self.fidelity == 0 and self.holding_torque > 0.0:
            raise ParameterError("holding_torque", self.holding_torque,
                                 "must be 0 at fidelity 0 (the ideal speed source sets the rotor speed): use "
                                 "fidelity 1 or 2 for a brake")


class MotorBeltModel(Model):
    """Induction motor + V-belt; see the module docstring for the equations of each fidelity level."""
    Params = MotorBeltParams
    inputs = ("pulley.phi", "pulley.w", "supply", "brake")
    outputs = ("pulley.tau", "motor_speed", "motor_torque", "power_electrical", "power_mechanical",
               "belt_torque", "brake_torque")
    states = (Signal("phi_motor", "rad", "rotor angle"),
              Signal("w_motor", "rad/s", "rotor angular velocity"),
              Signal("theta_creep", "rad", "accumulated creep of the belt over the driven pulley"),
              Signal("brake_timer", "s", "time since the brake was commanded (0 while released)"))
    input_memory = True  # advance(t, 0.0, x, u) restarts the brake's timer when its command is released

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
    def kloss_torque(self, w_m: float, supply: float = 1.0) -> float:
        """Kloss static characteristic M(s) = 2*M_k*s*s_k/(s**2 + s_k**2) [N.m] at rotor speed w_m; at another
        supply frequency (``supply`` times the rated one, flux kept) the same curve in the slip speed
        (module docstring); 0 when the supply is off."""
        m = self.m
        if m.scalar:
            if supply == 1.0:
                return self._kloss_rated(w_m)
            return 0.0 if supply <= 0.0 else self._kloss_supplied(w_m, supply)
        rated = supply == 1.0
        if rated.all():
            return self._kloss_rated(w_m)
        return m.where(rated, self._kloss_rated(w_m), m.where(supply <= 0.0, 0.0, self._kloss_supplied(w_m, supply)))

    def _kloss_rated(self, w_m):
        """The Kloss torque at the rated supply, in the slip s (as the characteristic is written)."""
        s = (self.p.w_sync - w_m) / self.p.w_sync
        return 2.0 * self.M_k * s * self.s_k / (s * s + self.s_k * self.s_k)

    def _kloss_supplied(self, w_m, supply):
        """The Kloss torque at another supply frequency, in the slip speed (flux kept)."""
        slip = supply * self.p.w_sync - w_m
        slip_k = self.s_k * self.p.w_sync
        return 2.0 * self.M_k * slip * slip_k / (slip * slip + slip_k * slip_k)

    def brake_engaged(self, x, u) -> bool:
        """Whether the brake acts at the state x under the held inputs u."""
        if self.m.scalar:
            return self.p.holding_torque > 0.0 and u[3] >= 0.5 and x[3] >= self.p.brake_delay
        return (self.p.holding_torque > 0.0) & (u[3] >= 0.5) & (x[3] >= self.p.brake_delay)

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
        w0 = p.w_rated * u[2] if p.fidelity == 0 else (p.w_rated if p.w_start < 0.0 else p.w_start)
        return np.array([self.ratio * u[0], w0, 0.0, 0.0])

    def _rates(self, t, x, u, t0, friction: float = 0.0) -> tuple[float, float]:
        """(rotor acceleration [rad/s2], creep rate [rad/s]) at levels 1, 2 for the rotor state x, with a
        friction torque ``friction`` [N.m] acting on the rotor."""
        force, creep_rate = self._belt(x, u[0] + u[1] * (t - t0), u[1])
        return (self.kloss_torque(x[1], u[2]) - force * self.r_m + friction) / self.p.J_motor, creep_rate

    def derivatives(self, t, x, u, t0):
        friction = 0.0
        if self.brake_engaged(x, u):
            drive = self.rotor_torque_at_rest(t, x, u, t0) if x[1] == 0.0 else 0.0
            friction = self.friction(x[1], drive)
        return self.derivatives_with(t, x, u, t0, friction)

    def friction(self, w_m: float, drive: float) -> float:
        """The engaged brake's torque on the rotor [N.m]: sliding, -holding_torque*sign(w_m); at rest, the reaction
        to the rotor's other torques ``drive`` while they stay within the holding torque, else the sliding one."""
        t_b, m = self.p.holding_torque, self.m
        if m.scalar:
            if w_m != 0.0:
                return -t_b * math.copysign(1.0, w_m)
            return -drive if abs(drive) <= t_b else -t_b * math.copysign(1.0, drive)
        return m.where(w_m != 0.0, -t_b * m.copysign(1.0, w_m),
                       m.where(m.fabs(drive) <= t_b, -drive, -t_b * m.copysign(1.0, drive)))

    def derivatives_with(self, t, x, u, t0, friction: float = 0.0):
        """dx/dt with a given friction torque on the rotor (the brake's, as the caller decides)."""
        m = self.m
        timer_rate = 1.0 * (u[3] >= 0.5)     # 1 while the brake is commanded (a bool times 1.0: no call)
        if self.p.fidelity == 0:
            return m.stack((self.p.w_rated * u[2], 0.0, 0.0, timer_rate))
        return m.stack((x[1], *self._rates(t, x, u, t0, friction), timer_rate))

    def ode_form(self):
        if self.p.holding_torque > 0.0:
            return ("MotorBelt with a brake: its timer restarts when the brake command is released, a memory "
                    "the inputs set (advance(t, 0.0, x, u)), not an ODE")
        return None

    def advance(self, t0, h, x, u):
        p = self.p
        x = np.array(x, dtype=float)
        if h == 0.0:  # the memory the inputs set at once: a released brake restarts its timer
            x[3] = x[3] if u[3] >= 0.5 else 0.0
            return x
        if p.fidelity == 0:
            x = integrate.rk4(self.derivatives_with, t0, h, x, u, self.max_substep)
            x[3] = x[3] if u[3] >= 0.5 else 0.0
            return x
        if p.holding_torque == 0.0 or u[3] < 0.5:
            x[3] = 0.0
            return self._advance_free(t0, h, x, u)
        t_engage = min(h, max(0.0, p.brake_delay - x[3]))  # from t0: when the brake takes hold in this step
        timer = x[3] + h
        if t_engage > 0.0:
            x = self._advance_free(t0, t_engage, x, u)
        if t_engage < h:
            x[3] = p.brake_delay
            x = self._advance_braked(t0, t0 + t_engage, h - t_engage, x, u)
        x[3] = timer
        return x

    def _advance_free(self, t0, h, x, u):
        """The rotor without the brake over [t0, t0 + h] (t0: the time the inputs were given)."""
        if self.p.fidelity != 1:
            return integrate.rk4(self.derivatives_with, t0, h, x, u, self.max_substep)
        # level 1 has no creep (its rate is 0): RK4 on (phi_motor, w_motor) in plain floats, the base class's
        # numbers without an array per stage
        theta = x[2]

        def acc(t, phi, w):
            return self._rates(t, (phi, w, theta), u, t0)[0]

        x[0], x[1] = integrate.rk4_pairs(acc, t0, h, self.max_substep, float(x[0]), float(x[1]))
        return x

    def _advance_braked(self, t0, ts, h, x, u):
        """The rotor with the brake engaged over [ts, ts + h] (inputs given at t0): RK4 sub-steps with the
        friction's sign fixed to the sliding direction; a sub-step in which the speed would change sign ends
        the slide at the speed's zero (linear interpolation) and the rotor sticks while the brake holds."""
        p = self.p
        n = integrate.substeps(h, self.max_substep)
        dt = h / n
        for i in range(n):
            t = ts + i * dt
            if x[1] == 0.0:
                drive = self.rotor_torque_at_rest(t, x, u, t0)
                if abs(drive) <= p.holding_torque:
                    continue  # held: the brake's reaction balances the rotor (the belt's creep follows |w_m| = 0)
                direction = math.copysign(1.0, drive)
            else:
                direction = math.copysign(1.0, x[1])
            friction = -p.holding_torque * direction

            def f(tt, xx, uu, tt0, friction=friction):
                return self.derivatives_with(tt, xx, uu, tt0, friction)

            x_new = integrate.rk4(f, t, dt, x, u, math.inf)
            if x_new[1] * direction < 0.0:  # the slide ends inside the sub-step: stop there and hold
                share = x[1] / (x[1] - x_new[1])
                x_new[0] = x[0] + 0.5 * x[1] * share * dt
                x_new[1] = 0.0
            x = x_new
        return x

    def rotor_torque_at_rest(self, t, x, u, t0) -> float:
        """Motor plus belt torque on the rotor at its state x, the brake excepted [N.m]."""
        return self._rates(t, x, u, t0)[0] * self.p.J_motor

    def _brake_torque(self, x, u, motor_torque: float, belt_torque: float) -> float:
        """Torque of the brake on the rotor [N.m]: the sliding friction, or at rest the reaction that holds."""
        if self.m.scalar:
            return self.friction(x[1], motor_torque - belt_torque) if self.brake_engaged(x, u) else 0.0
        return self.m.where(self.brake_engaged(x, u), self.friction(x[1], motor_torque - belt_torque), 0.0)

    def output(self, t, x, u):
        p = self.p
        force, _ = self._belt(x, u[0], u[1])
        belt_torque = force * self.r_m
        motor_torque = belt_torque if p.fidelity == 0 else self.kloss_torque(x[1], u[2])
        air_gap = motor_torque * p.w_sync * u[2]
        if self.m.scalar:
            p_el = air_gap / p.efficiency if air_gap >= 0.0 else air_gap * p.efficiency
        else:
            p_el = self.m.where(air_gap >= 0.0, air_gap / p.efficiency, air_gap * p.efficiency)
        return (force * self.r_d, x[1], motor_torque, p_el, motor_torque * x[1], belt_torque,
                self._brake_torque(x, u, motor_torque, belt_torque))

    def kloss_supply_slope(self, w_m: float, supply: float) -> float:
        """d kloss_torque / d supply [N.m] at rotor speed w_m (0 while the supply is off)."""
        if supply <= 0.0:
            return 0.0
        slip = supply * self.p.w_sync - w_m
        slip_k = self.s_k * self.p.w_sync
        denominator = slip * slip + slip_k * slip_k
        return 2.0 * self.M_k * slip_k * (slip_k * slip_k - slip * slip) / (denominator * denominator) * self.p.w_sync

    def output_jacobian(self, t, x, u):
        """The belt force's slopes in the driven pulley's motion (the creep rate follows the elastic force); the
        motor torque's in the supply (at fidelity 0, where the motor torque is the belt's, in the pulley's
        motion), the powers that follow it, and the holding brake's reaction at rest."""
        p = self.p
        force, _ = self._belt(x, u[0], u[1])
        d_force = np.array([-p.c_belt * self.r_d * (1.0 - p.d_belt * self.r_d * self.creep_gain * abs(x[1])),
                            -p.d_belt * self.r_d, 0.0, 0.0])
        d_belt = d_force * self.r_m
        if p.fidelity == 0:
            motor_torque, d_motor = force * self.r_m, d_belt
        else:
            motor_torque = self.kloss_torque(x[1], u[2])
            d_motor = np.array([0.0, 0.0, self.kloss_supply_slope(x[1], u[2]), 0.0])
        air_gap = motor_torque * p.w_sync * u[2]
        gain = p.w_sync * (1.0 / p.efficiency if air_gap >= 0.0 else p.efficiency)
        d_el = gain * (d_motor * u[2] + np.array([0.0, 0.0, motor_torque, 0.0]))
        brake = self._brake_torque(x, u, motor_torque, force * self.r_m)
        holding = self.brake_engaged(x, u) and x[1] == 0.0 and abs(brake) < p.holding_torque
        d_brake = -(d_motor - d_belt) if holding else np.zeros(4)
        return np.array([d_force * self.r_d, np.zeros(4), d_motor, d_el, d_motor * x[1], d_belt, d_brake])

    def belt_energy(self, x, phi_d: float) -> float:
        """Elastic energy of the belt [J]."""
        stretch = self.r_m * x[0] - self.r_d * (phi_d + x[2])
        return 0.5 * self.p.c_belt * stretch * stretch


class MotorBeltBatch(Vectorised):
    """Variants of :class:`MotorBeltModel` stepped together (fmus.physics.variants): the model's own rates, belt and
    Kloss law on arrays; a variant whose brake is commanded (it may engage and stick within the step) takes the
    step with its own scalar model."""
    attributes = ("r_m", "r_d", "ratio", "M_n", "s_n", "M_k", "s_k", "F_rated", "creep_gain")

    def output(self, t, X, U, rows=None):
        v = self.v
        if rows is not None and set(rows) <= {0, 1, 5}:    # the belt alone (the motor's torque and powers unread)
            force, _ = v._belt(X, U[0], U[1])
            Y = np.zeros((len(v.outputs), self.n))
            Y[0], Y[1], Y[5] = force * v.r_d, X[1], force * v.r_m
            return Y
        return v.m.stack(v.output(t, X, U))

    def advance(self, t0, h, X, U):
        v = self.v
        x = np.array(X, dtype=float)
        if h == 0.0:
            x[3] = np.where(U[3] >= 0.5, x[3], 0.0)
            return x
        if v.p_scalar.fidelity == 0:
            x = integrate_batch.rk4(lambda *a: v.derivatives_with(*a), t0, h, x, U, v.max_substep)
            x[3] = np.where(U[3] >= 0.5, x[3], 0.0)
            return x
        braking = (v.p.holding_torque != 0.0) & (U[3] >= 0.5)
        x[3] = 0.0
        if v.p_scalar.fidelity != 1:
            x = integrate_batch.rk4(lambda *a: v.derivatives_with(*a), t0, h, x, U, v.max_substep)
        else:
            theta = x[2]

            def acc(t, phi, w):
                return v._rates(t, (phi, w, theta), U, t0)[0]

            x[0], x[1] = integrate_batch.rk4_pairs(acc, t0, h, v.max_substep, x[0], x[1])
        return self.by_scalar(braking, t0, h, X, U, x)


MotorBeltModel.Batch = MotorBeltBatch
