"""A stop runs until the drive has settled: the observer that ends a stop's run there.

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
