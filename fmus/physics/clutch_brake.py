"""Flywheel on a compliant main shaft with a combined clutch-brake (the press's emergency stop on the main shaft).

Mechanical presses stop through a combined clutch-brake on the main (crank) shaft: one command (a pneumatic
valve) opens the clutch, which parts the flywheel (and the motor and belt behind it) from the crank side, and
applies the brake, which stops the crank side alone (../shared/reference/press-engineering-facts.md,
"Stopping").  This is :mod:`fmus.physics.flywheel_shaft` (the compliant shaft, fidelity 1) with that device
between the shaft and the crank side:

* input ``clutch_brake`` >= 0.5 commands it; ``cb_delay`` [s] after the command (its timer, the state
  ``cb_timer``, restarts when the command is released) the clutch opens and the brake acts with the torque
  ``cb_torque`` [N.m] (0: no clutch-brake, the plain flywheel shaft);
* open: the shaft transmits nothing (``shaft_torque`` = 0); the flywheel side turns on under the belt's torque
  alone, J1 dw1/dt = pulley.tau; the brake is Coulomb friction on the crank side, J2 dw2/dt = crank.tau + aux.tau
  - cb_torque sign(w2) while it slides; at rest it holds while |crank.tau + aux.tau| <= cb_torque (output
  ``clutch_brake_torque``: the sliding friction or the holding reaction);
* released again, the clutch closes with the shaft's twist of that instant as its new zero (the state
  ``cb_offset``), so it closes without a jump of torque.

Over a step of held torques the motion is exact: the closed shaft is the flywheel shaft's exact solution; the
open one is two constant accelerations, the crank side's stop located where its speed reaches zero.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .base import ParameterError, Signal, param
from .flywheel_shaft import FlywheelShaftModel, FlywheelShaftParams

TIMER, OFFSET = 5, 6      # state indices of the clutch-brake's timer and the closed clutch's twist offset


@dataclass(frozen=True)
class ClutchBrakeShaftParams(FlywheelShaftParams):
    fidelity: int = param(1, "", "1: torsionally compliant shaft (2 DOF) with the clutch-brake", choices=(1,))
    cb_torque: float = param(0.0, "N.m", "brake torque of the clutch-brake on the crank side (0: none)", low=0.0)
    cb_delay: float = param(0.03, "s", "time from the command (input clutch_brake >= 0.5) to the clutch open and "
                            "the brake acting", low=0.0)

    def check(self):
        super().check()
        if not math.isfinite(self.cb_torque):
            raise ParameterError("cb_torque", self.cb_torque, "must be finite")


class ClutchBrakeShaftModel(FlywheelShaftModel):
    """The flywheel shaft with a combined clutch-brake; see the module docstring."""
    Params = ClutchBrakeShaftParams
    inputs = FlywheelShaftModel.inputs + ("clutch_brake",)
    outputs = FlywheelShaftModel.outputs + ("clutch_brake_torque",)
    states = FlywheelShaftModel.states + (
        Signal("cb_timer", "s", "time since the clutch-brake was commanded (0 while released)"),
        Signal("cb_offset", "rad", "the closed clutch's twist zero (the twist where it last closed)"))
    input_memory = True   # advance(t, 0.0, x, u): a released command restarts the timer and closes the clutch

    def initial_state(self, u):
        return np.concatenate([super().initial_state(u), [0.0, 0.0]])

    def is_open(self, x, u) -> bool:
        """Whether the clutch is open and the brake acts at the state x under the held inputs u."""
        return self.p.cb_torque > 0.0 and u[3] >= 0.5 and x[TIMER] >= self.p.cb_delay

    def _closed(self, x) -> np.ndarray:
        """x as the plain flywheel shaft sees it: the crank angle shifted by the clutch's twist offset."""
        y = np.array(x[:TIMER], dtype=float)
        y[2] += x[OFFSET]
        return y

    def _back(self, y, x) -> np.ndarray:
        out = np.array(x, dtype=float)
        out[:TIMER] = y
        out[2] -= x[OFFSET]
        return out

    def friction(self, w2: float, drive: float) -> float:
        """The brake's torque on the crank side: sliding, -cb_torque sign(w2); at rest, the reaction to the other
        torques ``drive`` while they stay within cb_torque, else the sliding one in their sense."""
        t_b = self.p.cb_torque
        if w2 != 0.0:
            return -t_b * math.copysign(1.0, w2)
        return -drive if abs(drive) <= t_b else -t_b * math.copysign(1.0, drive)

    def derivatives_open(self, t, x, u, friction: float) -> np.ndarray:
        """dx/dt with the clutch open and the brake's torque ``friction`` on the crank side."""
        return np.array([x[1], u[0] / self.J1, x[3], (u[1] + u[2] + friction) / self.J2, 0.0,
                         1.0 if u[3] >= 0.5 else 0.0, 0.0])

    def derivatives(self, t, x, u, t0):
        if self.is_open(x, u):
            return self.derivatives_open(t, x, u, self.friction(x[3], u[1] + u[2]))
        dx = np.zeros(len(self.states))
        dx[:TIMER] = super().derivatives(t, self._closed(x), u, t0)
        dx[TIMER] = 1.0 if (self.p.cb_torque > 0.0 and u[3] >= 0.5) else 0.0
        return dx

    def ode_form(self):
        if self.p.cb_torque > 0.0:
            return ("ClutchBrakeShaft with a clutch-brake: its timer restarts and its clutch closes when the command "
                    "is released, a memory the inputs set (advance(t, 0.0, x, u)), not an ODE")
        return None

    def advance(self, t0, h, x, u):
        x = np.array(x, dtype=float)
        commanded = self.p.cb_torque > 0.0 and u[3] >= 0.5
        if h == 0.0 or not commanded:       # released: the clutch closes at the twist it has, the timer restarts
            if x[TIMER] >= self.p.cb_delay and self.p.cb_torque > 0.0 and x[TIMER] > 0.0:
                x[OFFSET] = x[0] - x[2]
            x[TIMER] = 0.0
            if h == 0.0:
                return x
            return self._back(super().advance(t0, h, self._closed(x), u), x)
        t_open = min(h, max(0.0, self.p.cb_delay - x[TIMER]))   # from t0: when the clutch opens in this step
        timer = x[TIMER] + h
        if t_open > 0.0:
            x = self._back(super().advance(t0, t_open, self._closed(x), u), x)
        if t_open < h:
            x = self._advance_open(h - t_open, x, u)
        x[TIMER] = timer
        return x

    def _advance_open(self, h, x, u):
        """Both sides over h with the clutch open: the flywheel side at constant acceleration, the crank side
        braked (its stop located where its speed reaches zero, held there while the brake holds)."""
        a1 = u[0] / self.J1
        x[0] += x[1] * h + 0.5 * a1 * h * h
        x[1] += a1 * h
        drive = u[1] + u[2]
        left = h
        for _ in range(3):            # slide, stop, (break loose and slide the other way): at most these pieces
            if left <= 0.0:
                break
            f = self.friction(x[3], drive)
            a2 = (drive + f) / self.J2
            if x[3] != 0.0 and a2 * x[3] < 0.0 and -x[3] / a2 < left:    # the slide ends inside: stop there
                dt = -x[3] / a2
                x[2] += x[3] * dt + 0.5 * a2 * dt * dt
                x[3] = 0.0
                left -= dt
                continue
            x[2] += x[3] * left + 0.5 * a2 * left * left
            x[3] += a2 * left
            left = 0.0
        return x

    def output(self, t, x, u):
        if self.is_open(x, u):
            kinetic = 0.5 * (self.J1 * x[1] * x[1] + self.J2 * x[3] * x[3])
            brake = self.friction(x[3], u[1] + u[2])
            return (x[0], x[1], x[2], x[3], x[2], x[3], 0.0, 0.0, kinetic, 0.0, brake)
        return tuple(super().output(t, self._closed(x), u)) + (0.0,)

    def output_jacobian(self, t, x, u):
        """The holding brake's reaction follows the torques on the crank side; every other output is a function
        of the state."""
        d = np.zeros((len(self.outputs), len(self.inputs)))
        if self.is_open(x, u) and x[3] == 0.0 and abs(u[1] + u[2]) <= self.p.cb_torque:
            d[-1, 1] = d[-1, 2] = -1.0
        return d
