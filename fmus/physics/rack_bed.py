"""Pinion and rack driving the flat bed (taler) of a flat-bed press (seed 004: z6 and the bed rack).

The pinion belongs to the differential (its sun-gear shaft): port ``pinion`` is motion in, the output
``pinion.tau`` is the reaction of the rack on the pinion.  Pinion pitch radius R = module*z_pinion/2.

Forces on the bed (positive forward)

    m_T*a = F_mesh - F_friction(v) - F_load(s, v)
    F_friction = mu*m_T*g*tanh(v/v_reg) + d_visc*v                      (smoothed Coulomb + viscous guideway)
    F_load     = F_print*g_zone(s)*max(0, tanh(v/v_reg))                  (printing load)

Printing-load profile (the seeds give none; choice documented here): the impression force F_print acts
against the motion only while the bed moves forward (v > 0, switched on smoothly over v_reg) inside the
printing zone [s_print_start, s_print_end]; g_zone rises from 0 to 1 over the first ``ramp`` metres of the
zone and falls back over its last ``ramp`` metres with the cubic smoothstep 3*x**2 - 2*x**3, so the force
is continuous in s.  The zone must be at least 2*ramp long.  F_load*v >= 0 always (it only dissipates).

Fidelity levels
  1  (default) elastic rack mesh between the pinion pitch point R*phi and the bed (state s, v):
     F_mesh = c_mesh*(R*phi - s) + d_mesh*(R*w - v).  Inside a communication step the pinion angle is
     extrapolated linearly, phi(t) = pinion.phi + pinion.w*(t - t0).  Initial state: s = R*pinion.phi,
     v = R*pinion.w (mesh relaxed).
  0  rigid mesh: s = R*pinion.phi, v = R*pinion.w (direct functions of the inputs).  The acceleration is
     the backward difference of the pinion speed inputs received at the starts of the last two
     communication steps, a = R*(w(t_k) - w(t_k-1))/(t_k - t_k-1), kept in a state entry: first order and
     lagging by about one communication step; 0 until two inputs have been seen.
     F_mesh = m_T*a + F_friction(v) + F_load(s, v).
Both levels: pinion.tau = -R*F_mesh, mesh_force = F_mesh (force of the pinion on the rack).

End stop (a jam; fidelity 1 only: the bed needs its own state): with ``stop_stiffness`` > 0 the bed runs into
a stiff stop at ``stop_position`` that blocks its forward motion past it (:class:`.contact.EndStop`, a
Kelvin-Voigt contact of stated stiffness and damping), m_T*a = F_mesh - F_friction - F_load - F_stop:
F_stop = max(k_s (s - s_stop) + d_s v, 0) while s > s_stop (``stop_catch`` = 0: it cannot pull, the bed may
rebound), or k_s (s - s_stop) + d_s v from the instant the bed reached it on (``stop_catch`` = 1: the bed
wedged, the state ``stop_caught``).  The stiffness is tunable: a jam sets it while the bed is short of the stop
(a stop set inside the bed's path pushes it back at once).  0 (default): no stop, the equations above exactly.

Default data (representative; seed 004 gives no bed mass, pinion radius or printing load): bed 250 kg,
module 4 mm with 25 teeth (R = 50 mm), mesh stiffness 4e8 N/m (about 14 N/(mm*um) per mm of face width,
ISO 6336 single-pair value, times 30 mm), 10 % mesh damping ratio, lubricated slideway mu = 0.05,
impression force 500 N over a 0.6 m zone.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import integrate
from . import integrate_batch, variants
from .base import Model, ParameterError, Params, Signal, param
from .contact import EndStop

GRAVITY = 9.80665


@dataclass(frozen=True)
class RackBedParams(Params):
    fidelity: int = param(1, "", "0: rigid rack mesh (bed acceleration from the input history); "
                          "1: elastic rack mesh (bed has its own state)", choices=(0, 1))
    m_T: float = param(250.0, "kg", "reduced mass of the bed (taler)", low=0.0, low_open=True)
    module: float = param(0.004, "m", "gear module of pinion and rack", low=0.0, low_open=True)
    z_pinion: int = param(25, "", "number of pinion teeth", low=5)
    c_mesh: float = param(4.0e8, "N/m", "rack mesh stiffness (fidelity 1)", low=0.0, low_open=True)
    d_mesh: float = param(6.3e4, "N.s/m", "rack mesh damping (fidelity 1)", low=0.0)
    mu: float = param(0.05, "1", "guideway friction coefficient", low=0.0)
    v_reg: float = param(0.01, "m/s", "regularisation speed of friction and load switching", low=0.0,
                         low_open=True)
    d_visc: float = param(100.0, "N.s/m", "viscous guideway damping", low=0.0)
    F_print: float = param(500.0, "N", "printing (impression) load force against forward motion", low=0.0)
    s_print_start: float = param(0.1, "m", "bed position where the printing zone begins")
    s_print_end: float = param(0.7, "m", "bed position where the printing zone ends")
    ramp: float = param(0.02, "m", "length of the smooth load ramps at both ends of the zone", low=0.0,
                        low_open=True)
    stop_position: float = param(0.0, "m", "bed position of an end stop (a jam) that blocks the bed's forward "
                                 "motion past it")
    stop_stiffness: float = param(0.0, "N/m", "stiffness of the end stop (0: no stop; a jam sets it while the bed "
                                  "is short of the stop; fidelity 1)", low=0.0)
    stop_damping: float = param(0.0, "N.s/m", "damping of the end stop while it acts", low=0.0)
    stop_catch: int = param(0, "", "0: an end stop (pushes back, never pulls: the bed may rebound); 1: a catch (the "
                            "bed, once at the stop, is held there both ways: wedged)", choices=(0, 1))

    def check(self):
        if not self.s_print_end - self.s_print_start >= 2.0 * self.ramp:
            raise ParameterError("s_print_end", self.s_print_end,
                                 f"must be >= s_print_start + 2*ramp = {self.s_print_start + 2.0 * self.ramp:g} m")
        if self.stop_stiffness > 0.0 and self.fidelity == 0:
            raise ParameterError("stop_stiffness", self.stop_stiffness, "an end stop needs the bed's own state: "
                                 "fidelity 1 (the rigid mesh of fidelity 0 has none)", low=0.0)


class RackBedModel(EndStop, Model):
    """Pinion-rack-bed; see the module docstring."""
    Params = RackBedParams
    stop_signals = ("bed.s", "bed.v")
    inputs = ("pinion.phi", "pinion.w")
    outputs = ("pinion.tau", "bed.s", "bed.v", "bed.a", "mesh_force")
    states = (Signal("s", "m", "bed position (fidelity 1; fidelity 0: R*phi extrapolated to the step end)"),
              Signal("v", "m/s", "bed velocity"),
              Signal("w_last", "rad/s", "pinion speed input at the start of the last step (fidelity 0)"),
              Signal("h_last", "s", "length of the last communication step (fidelity 0)"),
              Signal("a_est", "m/s2", "bed acceleration estimated from the pinion speed inputs (fidelity 0)"),
              Signal("stop_caught", "1", "1 once the bed has reached a catching end stop (stop_catch = 1), else 0"))

    def __init__(self, p: RackBedParams):
        p.validate()
        self.R = 0.5 * p.module * p.z_pinion
        self.F_coulomb = p.mu * p.m_T * GRAVITY
        super().__init__(p)

    # -- force laws ----------------------------------------------------------------------------------------
    def friction(self, v: float, th=None) -> float:
        """Guideway friction [N] at bed speed v (``th``: tanh(v / v_reg) when the caller has it)."""
        p = self.p
        return self.F_coulomb * (self.m.tanh(v / p.v_reg) if th is None else th) + p.d_visc * v

    def zone(self, s: float) -> float:
        """Printing-zone profile g_zone(s) in [0, 1] (cubic smoothstep ramps at both ends)."""
        p, m = self.p, self.m
        x = m.minimum(m.maximum((s - p.s_print_start) / p.ramp, 0.0), 1.0)
        y = m.minimum(m.maximum((p.s_print_end - s) / p.ramp, 0.0), 1.0)
        return x * x * (3.0 - 2.0 * x) * y * y * (3.0 - 2.0 * y)

    def printing_load(self, s: float, v: float, th=None) -> float:
        """Printing load [N] at bed position s and speed v (``th``: tanh(v / v_reg) when the caller has it)."""
        p, m = self.p, self.m
        if m.scalar:
            if v <= 0.0 or p.F_print == 0.0:
                return 0.0
            return p.F_print * self.zone(s) * (math.tanh(v / p.v_reg) if th is None else th)
        off = (v <= 0.0) | (p.F_print == 0.0)
        if off.all():
            return np.zeros_like(v)
        th = m.tanh(v / p.v_reg) if th is None else th
        return m.where(off, 0.0, p.F_print * self.zone(s) * th)

    # -- Model interface -----------------------------------------------------------------------------------
    def substep_limit(self) -> float:
        p = self.p
        if p.fidelity == 0:
            return math.inf
        w_mesh = math.sqrt(p.c_mesh / p.m_T)
        rate = (p.d_mesh + p.d_visc + (self.F_coulomb + p.F_print) / p.v_reg) / p.m_T
        limit = min(0.25 / w_mesh, 0.5 / rate if rate > 0.0 else math.inf)   # a bed without damping or friction
        return min(limit, self.stop_substep(p.m_T, p.c_mesh, p.d_mesh + p.d_visc)) if self.has_stop else limit

    def initial_state(self, u):
        return np.array([self.R * u[0], self.R * u[1], u[1], 0.0, 0.0, 0.0])

    def _acceleration(self, t, s, v, u, t0, caught: float = 0.0) -> float:
        p = self.p
        f_mesh = p.c_mesh * (self.R * (u[0] + u[1] * (t - t0)) - s) + p.d_mesh * (self.R * u[1] - v)
        if self.has_stop:                # the stop's push on the bed joins the mesh's
            f_mesh += self.stop_load(s, v, caught)
        th = self.m.tanh(v / p.v_reg)
        return (f_mesh - self.friction(v, th) - self.printing_load(s, v, th)) / p.m_T

    def derivatives(self, t, x, u, t0):
        if self.p.fidelity == 0:
            return np.zeros(6)
        return np.array([x[1], self._acceleration(t, x[0], x[1], u, t0, x[5]), 0.0, 0.0, 0.0, 0.0])

    def ode_form(self):
        """Fidelity 0 takes the bed's acceleration from the input history (the last step's speed and size are
        states): no ODE a host could integrate; nor is a catching end stop's memory."""
        if self.p.fidelity == 0:
            return "fidelity 0's bed acceleration comes from the input history (w_last, h_last), not an ODE"
        return self.stop_ode_form()

    def advance(self, t0, h, x, u):
        if self.p.fidelity == 1:
            # RK4 on (s, v) in plain floats: the base class's rk4 numbers without an array per stage
            x = np.array(x, dtype=float)
            if self.has_stop and self.p.stop_catch:     # a catch: its memory kept after each sub-step
                n = integrate.substeps(h, self.max_substep)
                dt = h / n
                for i in range(n):
                    x[0], x[1] = integrate.rk4_pair(lambda t, s, v: self._acceleration(t, s, v, u, t0, x[5]),
                                                    t0 + i * dt, dt, float(x[0]), float(x[1]))
                    x[5] = self.stop_caught(x[0], x[5])
                return x
            x[0], x[1] = integrate.rk4_pairs(lambda t, s, v: self._acceleration(t, s, v, u, t0), t0, h,
                                             self.max_substep, float(x[0]), float(x[1]))
            return x
        m = self.m
        if m.scalar:
            a_est = self.R * (u[1] - x[2]) / x[3] if x[3] > 0.0 else 0.0
        else:
            a_est = m.where(x[3] > 0.0, self.R * (u[1] - x[2]) / m.where(x[3] > 0.0, x[3], 1.0), 0.0)
        return m.stack((self.R * (u[0] + u[1] * h), self.R * u[1], u[1], h, a_est, 0.0))

    def output(self, t, x, u):
        p = self.p
        if p.fidelity == 0:
            s, v, a = self.R * u[0], self.R * u[1], x[4]
            f_mesh = p.m_T * a + self.friction(v) + self.printing_load(s, v)
        else:
            s, v = x[0], x[1]
            f_mesh = p.c_mesh * (self.R * u[0] - s) + p.d_mesh * (self.R * u[1] - v)
            f_bed = f_mesh + self.stop_load(s, v, x[5]) if self.has_stop else f_mesh
            a = (f_bed - self.friction(v) - self.printing_load(s, v)) / p.m_T
        return (-self.R * f_mesh, s, v, a, f_mesh)

    # -- the direct feed-through (output_jacobian) -----------------------------------------------------------
    def friction_slope(self, v: float) -> float:
        """d friction / d v."""
        th = math.tanh(v / self.p.v_reg)
        return self.F_coulomb / self.p.v_reg * (1.0 - th * th) + self.p.d_visc

    def zone_slope(self, s: float) -> float:
        """d zone / d s (the smoothstep's slope 6x(1 - x) is 0 where the clipping starts, so no case at the ends)."""
        p = self.p
        x = min(max((s - p.s_print_start) / p.ramp, 0.0), 1.0)
        y = min(max((p.s_print_end - s) / p.ramp, 0.0), 1.0)
        return (6.0 * x * (1.0 - x) * y * y * (3.0 - 2.0 * y) - x * x * (3.0 - 2.0 * x) * 6.0 * y * (1.0 - y)) / p.ramp

    def printing_load_slopes(self, s: float, v: float) -> tuple[float, float]:
        """(d printing_load / d s, d printing_load / d v)."""
        p = self.p
        if v <= 0.0 or p.F_print == 0.0:
            return 0.0, 0.0
        th = math.tanh(v / p.v_reg)
        return p.F_print * self.zone_slope(s) * th, p.F_print * self.zone(s) * (1.0 - th * th) / p.v_reg

    def output_jacobian(self, t, x, u):
        """Fidelity 0: s = R phi, v = R w and the mesh force carries the friction and printing load at them
        (a is the state); fidelity 1: the mesh force c (R phi - s) + d (R w - v) and the acceleration it gives."""
        p, R = self.p, self.R
        if p.fidelity == 0:
            s, v = R * u[0], R * u[1]
            dl_ds, dl_dv = self.printing_load_slopes(s, v)
            df = np.array([dl_ds * R, (self.friction_slope(v) + dl_dv) * R])
            ds, dv, da = np.array([R, 0.0]), np.array([0.0, R]), np.zeros(2)
        else:
            df = np.array([p.c_mesh * R, p.d_mesh * R])
            ds, dv, da = np.zeros(2), np.zeros(2), df / p.m_T
        return np.array([-R * df, ds, dv, da, df])

    def mesh_energy(self, x, phi: float) -> float:
        """Elastic energy of the rack mesh [J] (fidelity 1)."""
        stretch = self.R * phi - x[0]
        return 0.5 * self.p.c_mesh * stretch * stretch


class RackBedBatch(variants.Vectorised):
    """Variants of :class:`RackBedModel` stepped together (fmus.physics.variants): the model's own mesh, friction
    and printing load on arrays."""
    attributes = ("R", "F_coulomb")

    @classmethod
    def key(cls, model):
        return (model.has_stop,)

    @classmethod
    def refuses(cls, models):
        if any(m.has_stop for m in models):
            return "an end stop (a jam) on the bed: each variant's own model"
        return None

    def __init__(self, models):
        super().__init__(models)
        self.v.p.stop_stiffness = 0.0           # every variant's (refuses): the view's has_stop a plain False

    def output(self, t, X, U, rows=None):
        v = self.v
        if rows is not None and v.p.fidelity == 1 and 3 not in rows:   # the mesh alone (the acceleration unread)
            p = v.p
            f_mesh = p.c_mesh * (v.R * U[0] - X[0]) + p.d_mesh * (v.R * U[1] - X[1])
            Y = np.zeros((len(v.outputs), self.n))
            Y[0], Y[1], Y[2], Y[4] = -v.R * f_mesh, X[0], X[1], f_mesh
            return Y
        return v.m.stack(v.output(t, X, U))

    def advance(self, t0, h, X, U):
        v = self.v
        if v.p.fidelity != 1:
            return v.advance(t0, h, X, U)
        x = np.array(X, dtype=float)
        x[0], x[1] = integrate_batch.rk4_pairs(lambda t, s, w: v._acceleration(t, s, w, U, t0), t0, h, v.max_substep,
                                        x[0], x[1])
        return x


RackBedModel.Batch = RackBedBatch
