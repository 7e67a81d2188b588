"""Small components for testing the co-simulation master (not press-drive physics).

``Gain``: a pure direct feed-through ``y = clip(k*u + offset, -limit, limit)`` plus the time integral of its
input (a state, so that rollback is observable).  Two Gains in a ring form an algebraic loop whose
solution is known in closed form: ``y1 = (k1*offset2 + offset1) / (1 - k1*k2)`` (no saturation).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import Model, Params, Signal, param


@dataclass(frozen=True)
class GainParams(Params):
    k: float = param(0.5, "1", "gain from u to y")
    offset: float = param(0.0, "1", "constant added to the output")
    limit: float = param(1e6, "1", "magnitude limit of the output y (saturation)", low=0.0, low_open=True)
    q0: float = param(0.0, "s", "initial value of the integral")


class GainModel(Model):
    """y = clip(k*u + offset, -limit, limit) (direct feed-through); d(integral)/dt = u."""
    Params = GainParams
    inputs = ("u",)
    outputs = ("y", "integral")
    states = (Signal("q", "s", "state: time integral of the input u"),)

    def initial_state(self, u):
        return np.array([self.p.q0])

    def derivatives(self, t, x, u, t0):
        return np.array([u[0]])

    def advance(self, t0, h, x, u):
        return np.array([x[0] + h * u[0]])  # exact for the held input

    def output(self, t, x, u):
        p = self.p
        y = p.k * u[0] + p.offset
        return (min(p.limit, max(-p.limit, y)), float(x[0]))

    def output_jacobian(self, t, x, u):
        """dy/du = k inside the limits, 0 where y is saturated; the integral is the state."""
        p = self.p
        inside = -p.limit < p.k * u[0] + p.offset < p.limit
        return np.array([[p.k if inside else 0.0], [0.0]])
