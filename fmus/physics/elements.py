"""Elementary rotational elements: a rigid inertia and an inertia behind a spring-damper.

Together they form the classic two-inertia co-simulation benchmark (force-displacement coupling across
the FMU boundary): ``Inertia`` takes a torque and returns motion, ``SpringInertia`` takes motion and returns
the spring torque.  Sign convention of every bond (see fmus.slave): ``tau`` is the torque the motion-input component exerts
on the motion-output component's flange; ``tau * w`` is the power flowing into the motion-output side.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import integrate_batch, variants
from .base import Model, Params, Signal, param


@dataclass(frozen=True)
class InertiaParams(Params):
    J: float = param(0.01, "kg.m2", "moment of inertia", low=0.0, low_open=True)
    c_ground: float = param(0.0, "N.m/rad", "stiffness of a spring from the inertia to the frame", low=0.0)
    d_ground: float = param(0.0, "N.m.s/rad", "viscous damping to the frame", low=0.0)
    tau_drive: float = param(0.0, "N.m", "constant external torque driving the inertia")
    phi0: float = param(0.0, "rad", "initial angle")
    w0: float = param(0.0, "rad/s", "initial angular velocity")


class InertiaModel(Model):
    """J*dw/dt = tau_drive - c_ground*phi - d_ground*w + flange.tau   (flange: motion out)."""
    Params = InertiaParams
    inputs = ("flange.tau",)
    outputs = ("flange.phi", "flange.w")
    states = (Signal("phi", "rad", "angle of the inertia"), Signal("w", "rad/s", "angular velocity of the inertia"))

    def initial_state(self, u):
        return np.array([self.p.phi0, self.p.w0])

    def derivatives(self, t, x, u, t0):
        p = self.p
        return np.array([x[1], (p.tau_drive - p.c_ground * x[0] - p.d_ground * x[1] + u[0]) / p.J])

    def output(self, t, x, u):
        return (x[0], x[1])

    def output_jacobian(self, t, x, u):
        """The flange's motion is the state: no feed-through from the torque."""
        return np.zeros((2, 1))

    def energy(self, x) -> float:
        """Kinetic plus ground-spring energy [J]."""
        return 0.5 * self.p.J * x[1] ** 2 + 0.5 * self.p.c_ground * x[0] ** 2


@dataclass(frozen=True)
class SpringInertiaParams(Params):
    J: float = param(0.01, "kg.m2", "moment of inertia behind the spring", low=0.0, low_open=True)
    c: float = param(100.0, "N.m/rad", "coupling spring stiffness", low=0.0)
    d: float = param(0.0, "N.m.s/rad", "coupling damping", low=0.0)
    c_ground: float = param(0.0, "N.m/rad", "stiffness from the inertia to the frame", low=0.0)
    d_ground: float = param(0.0, "N.m.s/rad", "viscous damping to the frame", low=0.0)
    phi0: float = param(0.0, "rad", "initial angle of the inertia")
    w0: float = param(0.0, "rad/s", "initial angular velocity of the inertia")


class SpringInertiaModel(Model):
    """Inertia J driven through a spring-damper from a motion-input flange.

    The spring torque on the inertia is s = c*(drive.phi - phi) + d*(drive.w - w); J*dw/dt = s -
    c_ground*phi - d_ground*w.  The reaction on the driving flange is drive.tau = -s (a direct function of
    the inputs).
    """
    Params = SpringInertiaParams
    inputs = ("drive.phi", "drive.w")
    outputs = ("drive.tau",)
    states = (Signal("phi", "rad", "angle of the inertia"), Signal("w", "rad/s", "angular velocity of the inertia"))

    def initial_state(self, u):
        return np.array([self.p.phi0, self.p.w0])

    def spring_torque(self, x, u) -> float:
        return self.p.c * (u[0] - x[0]) + self.p.d * (u[1] - x[1])

    def derivatives(self, t, x, u, t0):
        p = self.p
        return np.array([x[1], (self.spring_torque(x, u) - p.c_ground * x[0] - p.d_ground * x[1]) / p.J])

    def output(self, t, x, u):
        return (-self.spring_torque(x, u),)

    def output_jacobian(self, t, x, u):
        """drive.tau = -(c*(phi_in - phi) + d*(w_in - w)): -c and -d."""
        return np.array([[-self.p.c, -self.p.d]])

    def energy(self, x, u) -> float:
        p = self.p
        return 0.5 * p.J * x[1] ** 2 + 0.5 * p.c * (u[0] - x[0]) ** 2 + 0.5 * p.c_ground * x[0] ** 2


class _Rk4Batch(variants.Vectorised):
    """Variants of a model whose step is the base class's RK4 on its derivatives: those on arrays."""

    def output(self, t, X, U, rows=None):
        return self.v.m.stack(self.v.output(t, X, U))

    def advance(self, t0, h, X, U):
        return integrate_batch.rk4(self.v.derivatives, t0, h, np.array(X, dtype=float), U, self.v.max_substep)


InertiaModel.Batch = _Rk4Batch
SpringInertiaModel.Batch = _Rk4Batch
