"""Runs that end when the drive has settled: a stop at rest (:class:`Settling`), a run at a steady cycle
(:class:`Steady`, for ``size``).

A stop's quantities (:mod:`harness.reporting.stops`) must not depend on how long the run was asked to be, so
:func:`harness.run.simulate_scenario` runs a ``stop`` scenario past its stop time, up to its limit
(:attr:`harness.specs.Scenario.settle_limit`, default :data:`LIMIT` times its stop time), and
:class:`Settling` ends it once it has settled:

* the *band*: :data:`BAND` (1 %) of the main shaft's speed at the stop command (its first change);
* *first standstill*: the first communication point after the command at which |w| is inside the band;
* *settled*: |w| has stayed inside the band for ``hold`` seconds without a break (:data:`HOLD`, 0.25 s, or
  the scenario's ``settle_hold``), so a ring-down that leaves the band again is waited out.

The run ends at the first point that is both settled and at or past the stop time asked (a longer run asked
is run whole).  One that reaches its limit unsettled ends there, complete, and its quantities say so.
"""
from __future__ import annotations

from harness.master.clock import NS
from harness.master.observers import Observer

BAND = 0.01      # share of the main shaft's speed at the stop command: inside it the shaft is at rest
HOLD = 0.25      # s: how long the speed stays inside the band before the drive counts as settled
LIMIT = 4.0      # a stop's run goes on to at most this many times its stop time (its own limit, if it states one)


class Settling(Observer):
    """Ends a stop's run when the main shaft (output ``column``) has settled after the command at ``command_ns``
    and the run has reached ``asked_ns`` (module docstring)."""

    can_finish = True

    def __init__(self, column: str, command_ns: int, asked_ns: int, hold: float = HOLD, band: float = BAND):
        self.column, self.command_ns, self.asked_ns = column, command_ns, asked_ns
        self.hold_ns, self.band = round(hold * NS), band
        self.index = None
        self.limit_speed = None     # rad/s: the band's half width, from the speed at the command
        self.inside_since = None    # ns: since when |w| is inside the band without a break

    def on_start(self, master, t_ns):
        if self.column not in master.signal_index:
            raise ValueError(f"the main shaft's speed {self.column!r} is not an output of the system: a stop "
                             f"cannot be run until it settles")
        self.index = master.signal_index[self.column]
        self.limit_speed = self.band * abs(float(master.y[self.index]))

    def on_step(self, master, t_prev_ns, t_ns):
        w = abs(float(master.y[self.index]))
        if t_ns <= self.command_ns:
            self.limit_speed = self.band * w     # the speed at the command: the last point at or before it
            return
        if w > self.limit_speed:
            self.inside_since = None
            return
        if self.inside_since is None:
            self.inside_since = t_ns
        if t_ns - self.inside_since >= self.hold_ns and t_ns >= self.asked_ns:
            self.finished = True


class Steady(Observer):
    """Ends a run once the main shaft runs steadily: the mean speed of its last complete machine cycle (``angle``
    output passing ``origin + k * cycle_angle``, interpolated between points) within half of ``settle`` of the
    cycle's before, so that :func:`harness.reporting.quantities.detect_cycles` (within ``settle``) finds the last
    cycle steady.  ``size`` runs each point with it instead of a stop time guessed beforehand."""

    can_finish = True

    def __init__(self, angle: str, origin: float = 0.0, cycle_angle: float = 6.283185307179586,
                 settle: float = 1e-3):
        self.angle, self.origin, self.cycle_angle, self.settle = angle, origin, cycle_angle, settle
        self.bounds: list[float] = []
        self.sense = 0.0
        self.previous = None     # (t, angle) of the last point

    def on_start(self, master, t_ns):
        if self.angle not in master.signal_index:
            raise ValueError(f"the main shaft's angle {self.angle!r} is not an output of the system: a run cannot "
                             f"end at a steady cycle")
        self.index = master.signal_index[self.angle]
        self.previous = (t_ns / NS, float(master.y[self.index]))
        self.start = self.previous[1]

    def on_step(self, master, t_prev_ns, t_ns):
        import math

        t, a = t_ns / NS, float(master.y[self.index])
        t0, a0 = self.previous
        self.previous = (t, a)
        if not self.sense:
            self.sense = math.copysign(1.0, a - self.start) if a != self.start else 0.0
            if not self.sense:
                return
        k0 = math.floor((a0 - self.origin) * self.sense / self.cycle_angle)
        k1 = math.floor((a - self.origin) * self.sense / self.cycle_angle)
        if k1 <= k0:
            return
        boundary = self.origin + self.sense * k1 * self.cycle_angle
        self.bounds.append(t0 + (boundary - a0) / (a - a0) * (t - t0))
        if len(self.bounds) >= 4:      # three complete cycles: the last two compared
            d1, d2 = self.bounds[-2] - self.bounds[-3], self.bounds[-1] - self.bounds[-2]
            if abs(d2 - d1) <= 0.5 * self.settle * d1:
                self.finished = True
