"""Generic motion-input loads: a torque load for a rotating link (e.g. the feeder head).

TorqueLoad takes the motion of a flange and returns its reaction on the driver::

    flange.tau = -(T_const + T_coulomb*tanh(w/w_reg) + d*w + c*(phi - phi_ref))

``tanh`` regularises Coulomb friction (it is within 1 % of sign(w) for |w| > 2.65*w_reg).  The load has no
state.  With T_const = c = 0 it only dissipates: flange.tau * flange.w <= 0.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import variants
from .base import Model, Params, param


@dataclass(frozen=True)
class TorqueLoadParams(Params):
    fidelity: int = param(0, "", "model level; 0: static torque law (the only level)", choices=(0,))
    T_const: float = param(0.0, "N.m", "constant load torque (positive opposes positive rotation)")
    T_coulomb: float = param(0.0, "N.m", "Coulomb friction torque", low=0.0)
    w_reg: float = param(0.01, "rad/s", "regularisation speed of the Coulomb friction (tanh)", low=0.0,
                         low_open=True)
    d: float = param(0.0, "N.m.s/rad", "viscous damping coefficient", low=0.0)
    c: float = param(0.0, "N.m/rad", "stiffness of a return spring to phi_ref", low=0.0)
    phi_ref: float = param(0.0, "rad", "angle at which the return spring is relaxed")


class TorqueLoadModel(Model):
    """Static load: flange.tau = -(T_const + T_coulomb*tanh(w/w_reg) + d*w + c*(phi - phi_ref))."""
    Params = TorqueLoadParams
    inputs = ("flange.phi", "flange.w")
    outputs = ("flange.tau",)
    states = ()

    def load_torque(self, phi: float, w: float) -> float:
        """Torque the load opposes to the motion [N.m] (the reaction on the driver is its negative)."""
        p = self.p
        return p.T_const + p.T_coulomb * self.m.tanh(w / p.w_reg) + p.d * w + p.c * (phi - p.phi_ref)

    def output(self, t, x, u):
        return (-self.load_torque(u[0], u[1]),)

    def output_jacobian(self, t, x, u):
        """-(c, T_coulomb/w_reg*(1 - tanh^2(w/w_reg)) + d)."""
        p = self.p
        th = math.tanh(u[1] / p.w_reg)
        return np.array([[-p.c, -(p.T_coulomb / p.w_reg * (1.0 - th * th) + p.d)]])

    def advance(self, t0, h, x, u):
        return x


class TorqueLoadBatch(variants.Vectorised):
    """Variants of :class:`TorqueLoadModel` together: its torque law on arrays (it has no state)."""

    def output(self, t, X, U, rows=None):
        return np.atleast_2d(-self.v.load_torque(U[0], U[1]))

    def advance(self, t0, h, X, U):
        return X


TorqueLoadModel.Batch = TorqueLoadBatch
