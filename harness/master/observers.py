"""Observers of a run: what watches the loop of :meth:`harness.master.Master.run` without steering it.

An :class:`Observer` is told of the run's start, each input event, each accepted communication point and the
end (libcosim's observer habit).  It may read the master (``y``, ``bond_log``, ``t_ns``, the counters) and its
FMUs' values, keep what it likes and raise to stop the run (a :class:`~harness.errors.SimulationError`:
the divergence watch does), or set ``finished`` to end it as complete before its stop time (a stop that has
settled: :class:`harness.run.settling.Settling`); it must not set inputs, step FMUs or change the master's
state.  The run's
observers, in the order the loop calls them:

:class:`Recording`                  the result rows (a :class:`harness.results.Recorder`), at the start and at
                                    every recording point;
:class:`harness.master.divergence.DivergenceWatch`  the divergence detector on the power bonds;
:class:`ProgressBar`                a tqdm bar on stderr.

The power bonds' energy bookkeeping (``Master.bond_log``) is not an observer: it is part of each master step
(rolled back with it, read by the ECCO step control within a step), and observers read its result.
"""
from __future__ import annotations

import sys

from harness.master.clock import NS

__all__ = ["Observer", "Recording", "ProgressBar"]


class Observer:
    """The interface; every method does nothing by default.  Times are integer nanoseconds.  ``finished``
    (checked after each accepted step by observers whose ``can_finish`` is True): the run ends there,
    complete."""

    can_finish = False
    finished = False

    def on_start(self, master, t_ns: int) -> None:
        """The master is initialized at ``t_ns``, before the first step."""

    def on_event(self, master, t_ns: int) -> None:
        """An input event at ``t_ns`` (a step of an input signal), before the step from it."""

    def on_step(self, master, t_prev_ns: int, t_ns: int) -> None:
        """A communication step from ``t_prev_ns`` to ``t_ns`` was accepted; the master holds its outputs."""

    def on_end(self, master, t_ns: int, completed: bool) -> None:
        """The run ended at ``t_ns`` (``completed``: it reached its stop time; else it raised and that
        exception follows)."""


class Recording(Observer):
    """Rows of ``recorder`` at the start, every ``sample_ns`` from ``start_ns`` (None: every accepted point) and
    at ``stop_ns``."""

    def __init__(self, recorder, start_ns: int, stop_ns: int, sample_ns: int | None = None):
        self.recorder, self.start_ns, self.stop_ns, self.sample_ns = recorder, start_ns, stop_ns, sample_ns

    def on_start(self, master, t_ns):
        self.recorder.record(t_ns / NS)

    def on_step(self, master, t_prev_ns, t_ns):
        self.last_ns = t_ns
        if self.sample_ns is None or (t_ns - self.start_ns) % self.sample_ns == 0 or t_ns >= self.stop_ns:
            self.recorder.record(t_ns / NS)
            self.recorded_ns = t_ns

    recorded_ns = last_ns = None

    def on_end(self, master, t_ns, completed):
        if completed and self.recorded_ns != self.last_ns and self.last_ns is not None:  # ended early: its last row
            self.recorder.record(t_ns / NS)


class ProgressBar(Observer):
    """A tqdm bar of simulated seconds on stderr (``enabled`` None: only when stderr is a terminal; shown
    after 2 s), updated every 64 steps."""

    def __init__(self, total_ns: int, enabled: bool | None = None):
        self.total_ns, self.enabled = total_ns, enabled
        self.bar = None
        self.steps = self.shown = 0

    def on_start(self, master, t_ns):
        self.shown = t_ns
        enabled = sys.stderr.isatty() if self.enabled is None else self.enabled
        if not enabled:
            return
        try:
            from tqdm import tqdm
        except ImportError:  # pragma: no cover
            return
        self.bar = tqdm(total=self.total_ns / NS, unit="s", delay=2.0, file=sys.stderr, leave=False,
                        bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s [{elapsed}<{remaining}]")

    def on_step(self, master, t_prev_ns, t_ns):
        self.steps += 1
        if self.bar is not None and (self.steps & 63) == 0:
            self.bar.update((t_ns - self.shown) / NS)
            self.shown = t_ns

    def on_end(self, master, t_ns, completed):
        if self.bar is not None:
            self.bar.close()
