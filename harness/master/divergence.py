"""Divergence of a coupled run, judged on the power bonds against the run's own scale.

A co-simulation that loses coupling stability makes the power that flows through its power bonds grow
geometrically, fed by energy the coupling itself creates (``P_out - P_in`` integrated over time,
:class:`harness.results.BondLog`'s ``energy_error``).  The detector judges that growth against the run's own
scale, not a fixed number.

:class:`DivergenceDetector` is fed every accepted communication point (``update(t, bond_log, h)``) and told of
each time event of the run's input signals (``event(t, bond_log)``: no verdict for ``min_blocks`` blocks after
it, the energy error booked over them excused, so a load step or a stop is not read as divergence).  It cuts
the run into blocks of ``block`` steps and keeps, per bond and block, the peak power ``max(|P_out|, |P_in|)``
[W], the energy that flowed through the bond ``integral |P_out| dt`` [J] and the accumulated energy error
[J].  At the end of each block a bond is DIVERGING when its power grew AND the coupling fed that growth:

* fast growth (from ``min_blocks`` / 2 = 8 blocks on): the newest block's peak power exceeds ``fast`` (1e3) times the peak power
  of the first half of the run so far (an amplitude 32 times its start), or
* growth (from ``min_blocks`` = 16 blocks on): the peak power of the newest ``late`` (2) blocks exceeds
  ``growth`` (10) times the peak power over the first half of the blocks so far (the run's own scale,
  including its first period; power = amplitude squared);
* a bond's reference peak power is at least ``floor`` (1e-3) times the largest peak power of any bond in
  the first half of the run, so a bond that carries almost nothing is not judged on its own tiny scale;
* a growth by more than 1/``rest`` (1e9) is a start from numerical rest (a cut or load beginning on a bond
  that carried no power: ``spine_knife``), not the growth of a running state; an instability that starts
  from round-off is caught once the reference window has left the rest;
* and the coupling created more than ``creation`` (5 %) of the energy that flowed through the bond over the
  last quarter of the blocks, beyond half a step's worth of the bond's power (half the largest step times the
  peak power, over that quarter): a drive spinning up or a cut starting raises the power of a stable run but
  the coupling creates no energy then, except once, when the effort jumps within a step and a coupling that
  samples it a step late books about half that jump times the step (``spine_knife`` under ``jacobi-sampled``,
  its cut starting: 6 % of the little energy that had flowed since, which stopped it at every step from 1e-5
  to 5e-5 s); a diverging coupling creates energy step after step.  (On the Gauss-Seidel, zero-order-hold
  two-inertia runs the bond's energy error stays near zero while the amplitude grows: the geometric test
  below stops those.)
* the verdict must hold at ``persist`` (1) consecutive block ends.

A second test needs no energy bookkeeping: GEOMETRIC growth.  Split the blocks so far into quarters; when the
peak power grows by more than ``geometric`` (2) from the second quarter to the third AND from the third to the
fourth, at a steady rate (the second ratio between 0.7 times and the square of the first), the bond is
watched; it is stopped if the same holds again once the run is 1.5 times as long as when first seen, the
power not having fallen in between.  An unstable mode grows so; a spin-up or a cut saturates, a resonance
under periodic forcing grows polynomially (a linearly growing amplitude gives at most x2.25, then x1.78), and
a machine's periodic load that rises within its first cycle (bed_drive's return stroke) falls again before
the confirmation.  Bonds near rest are not judged: below ``floor`` times the largest peak power of the run,
or below ``quiet`` (1e-6) times the bond's nominal power (the declared ``nominal`` of its effort times that of
its flow, FMI's default 1 where none is declared).  This is what stops Gauss-Seidel with zero-order hold,
whose bond energy error stays near zero while the amplitude grows.  A truly unstable physical system (negative
damping) would be stopped too: ``DivergenceOptions(geometric=None)`` switches the test off.  A run that ENDS
while a bond is still watched, its confirmation not yet due, is reported, not stopped (:meth:`finish`; the
result is kept complete and carries the line in ``attrs["suspect"]``): when both ratios still pass
``geometric`` and the growth did not slow from the third quarter to the fourth (the fourth ratio at least
``end_rate`` (0.9) times the third).  A start from rest growing as a power of time slows by at least 0.75
wherever both its ratios pass 2 ((4/3)^k against (3/2)^k), but a drive cut short in its first machine cycle
need not (bed_drive stopped at 1 s, its return stroke: x3.09 then x2.91), so only a longer run tells it from
an instability; ``end_rate=None`` switches the report off.

Tuned on the two stability maps (``docs/images/stability_two_inertia_inertia.csv`` and
``stability_bed_drive_fourbar_rocker_inertia.csv``): no stop at any step the maps judge stable, a stop on
clearly unstable steps (``tests/test_divergence.py`` states which: all of both maps, the two-inertia study
running 90 periods, since at 60 its three slowest Gauss-Seidel zero-order-hold points grew too slowly to be
confirmed; (1 % let a
start-up transient of the bed drive at 5e-5 s trip the test); the most violent
blow-ups, which pass 1e12 within the first 8 blocks and are stopped by the master's blow-up check instead).  A run that
is only just beyond the boundary grows too slowly to be stopped within the maps' run lengths; the studies'
own criteria judge those.

A stability study's run with fewer steps than 2 x ``min_blocks`` blocks of ``block`` steps gets blocks of fewer
steps (:func:`harness.studies.trial.study_options`; at least one step per block): such runs of 27-37 large
steps reached torques of 1e4 N.m unjudged with blocks of 4.  Plain runs keep ``block``: a drive's first few
dozen steps from rest grow x10 and more, which a block of one step would judge.

The detector raises :class:`Diverged` (a :class:`~harness.errors.SimulationError`) with one line naming the
time, the bond, the instance and effort variable on its motion-input side, and the evidence.
:func:`harness.run.simulate` runs it on every run with power bonds (``RunOptions.divergence``; None switches
it off), so the stability studies, which judge incomplete runs unstable, use the same detector.
A system without power bonds is guarded only by the non-finite / blow-up check of the master.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from harness.errors import SimulationError
from harness.master.clock import NS
from harness.master.observers import Observer


class Diverged(SimulationError):
    """The run diverged (coupling instability); ``evidence`` is the one-line reason without the time."""


@dataclass(frozen=True)
class DivergenceOptions:
    """Thresholds of :class:`DivergenceDetector` (module docstring).  ``block``: steps per block;
    ``min_blocks``: blocks before the first verdict; ``late``: newest blocks compared with the second quarter;
    ``growth``: ratio of peak powers [-]; ``creation``: energy created / energy transmitted [-]."""
    block: int = 4
    min_blocks: int = 16
    late: int = 2
    growth: float = 10.0
    creation: float | None = 0.05
    fast: float = 1e3
    floor: float = 1e-3
    persist: int = 1
    rest: float = 1e-9
    geometric: float | None = 2.0
    quiet: float = 1e-6
    end_rate: float | None = 0.9
    suspect_creation: float = 1e-3

    def __post_init__(self):
        for name in ("block", "min_blocks", "late", "persist"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"DivergenceOptions.{name} = {v!r} is not admissible: must be an integer >= 1")
        for name in ("growth", "creation", "fast", "floor", "rest", "geometric", "quiet", "end_rate",
                     "suspect_creation"):
            v = getattr(self, name)
            if v is None and name in ("creation", "geometric", "end_rate"):
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"DivergenceOptions.{name} = {v!r} is not admissible: must be a positive number")


def _quarters(nb: int) -> tuple[tuple[int, int], ...]:
    """Block ranges of the second, third and fourth quarters of ``nb`` blocks (the geometric test's)."""
    return (nb // 4, nb // 2), (nb // 2, (3 * nb) // 4), ((3 * nb) // 4, nb)


class _WindowMax:
    """The largest of ``peaks[a:b][j]`` for a window [a, b) whose bounds never move back (a monotone deque of
    block indices, amortised O(1) per block); 0.0 for an empty window, as the test takes it."""
    __slots__ = ("end", "dq")

    def __init__(self):
        self.end = 0
        self.dq: deque = deque()

    def max(self, peaks: list, j: int, a: int, b: int) -> float:
        dq = self.dq
        for i in range(self.end, b):
            v = peaks[i][j]
            while dq and not peaks[dq[-1]][j] > v:  # drop what v ties or beats: max() keeps the first largest
                dq.pop()
            dq.append(i)
        if b > self.end:
            self.end = b
        while dq and dq[0] < a:
            dq.popleft()
        return peaks[dq[0]][j] if dq and b > a else 0.0


class DivergenceDetector:
    """Online divergence test on the power bonds of one run (module docstring).

    ``labels``: bond labels ``"a.port->b.port"``; ``efforts``: per bond the ``(instance, variable)`` of the
    effort output on its motion-input side, named in the message."""

    def __init__(self, labels: list[str], efforts: list[tuple[str, str]], options: DivergenceOptions | None = None,
                 nominal: list[float] | None = None):
        self.labels = list(labels)
        self.efforts = list(efforts)
        self.opts = options or DivergenceOptions()
        n = len(self.labels)
        # per bond: nominal power [W] = declared nominal of its effort x nominal of its flow (FMI's default 1)
        self.nominal = list(nominal) if nominal is not None else [1.0] * n
        self.n = n
        self._k = 0                      # steps in the current block
        self._h = 0.0                    # largest step in the current block [s]
        self.steps_max: list[float] = []  # per block, its largest step [s]
        self._t_block = 0.0              # start time of the current block
        self._peak = [0.0] * n
        self._flow = [0.0] * n
        self.peaks: list[list[float]] = []   # per block, per bond
        self.flows: list[list[float]] = []
        self.energies: list[list[float]] = [[0.0] * n]  # energy error at block boundaries (first: t = 0)
        self._grace_end = -1             # after an event: the last block end given no verdict (event)
        self._excused = [0.0] * n        # energy error booked in the events' grace blocks, not counted
        self._raw = [0.0] * n            # the bond log's energy error at the last block end
        self.times: list[float] = [0.0]                 # block boundaries [s]
        self._flagged = [False] * n      # diverging at this block end
        self._streak = [0] * n           # consecutive block ends a bond has been diverging
        self._why: list = [None] * n
        self._geo_since: list = [None] * n  # when steady geometric growth was first seen (see _judge)
        # running maxima, so a verdict costs O(1) per block, not O(blocks): per block k, the largest peak
        # of each bond over blocks 0..k and of all bonds over blocks 0..k (same fold as max() over a slice)
        self._cummax: list[list[float]] = []
        self._cummax_all: list[float] = []
        # the geometric test's quarters [nb/4, nb/2), [nb/2, 3nb/4), [3nb/4, nb): their bounds only move
        # forward, so each keeps a sliding-window maximum per bond
        self._quarters = [[_WindowMax() for _ in range(n)] for _ in range(3)]

    def event(self, t: float, bond_log) -> None:
        """A time event at ``t`` [s] (an input stepped: a motor switched off, a brake commanded, a load put on).
        The step it puts on the bonds' power and the energy the coupling books on the transient it excites are
        the event's, not growth: the detector gives no verdict for ``min_blocks`` blocks from here (the time a
        run gets from its start) and excuses the energy error booked over them; the peaks before the event stay
        the run's scale.  A coupling that keeps creating energy after that is judged as at any other time."""
        if not self.n:
            return
        self._grace_end = len(self.peaks) + self.opts.min_blocks

    def update(self, t: float, bond_log, h: float) -> None:
        """One accepted communication point at ``t`` [s] after a step of ``h`` [s]; ``bond_log`` the master's
        rows P_out, P_in, energy error.  Raises :class:`Diverged`."""
        if not self.n:
            return
        p_out, p_in, energy = bond_log.tolist()
        peak, flow = self._peak, self._flow
        for j in range(self.n):
            a, b = abs(p_out[j]), abs(p_in[j])
            m = a if a > b else b
            if m > peak[j] or m != m:
                peak[j] = m
            flow[j] += a * h
        self._k += 1
        if h > self._h:
            self._h = h
        if self._k < self.opts.block:
            return
        self.steps_max.append(self._h)
        self._h = 0.0
        self.peaks.append(peak)
        if self._cummax:
            prev, prev_all = self._cummax[-1], self._cummax_all[-1]
            self._cummax.append([b if b > a else a for a, b in zip(prev, peak)])  # max(a, b), NaN alike
            self._cummax_all.append(max(prev_all, max(peak)))
        else:
            self._cummax.append(list(peak))
            self._cummax_all.append(max(peak))
        self.flows.append(flow)
        grace = len(self.peaks) <= self._grace_end
        if grace:  # after an event (see event): the energy booked since the last block end is excused
            self._excused = [x + e - r for x, e, r in zip(self._excused, energy, self._raw)]
        self._raw = list(energy)
        self.energies.append([e - x for e, x in zip(energy, self._excused)])
        self.times.append(t)
        self._peak, self._flow, self._k = [0.0] * self.n, [0.0] * self.n, 0
        if not grace:
            self._judge(t)

    def _judge(self, t: float) -> None:
        o = self.opts
        nb = len(self.peaks)
        # a bond that carries a negligible share of the run's power is not judged on its own scale
        floor = o.floor * self._cummax_all[max(1, nb // 2) - 1]
        if nb >= max(4, o.min_blocks // 2):
            half = nb // 2
            for j in range(self.n):
                first, last = max(self._cummax[half - 1][j], floor), self.peaks[-1][j]
                if o.fast * first < last < first / o.rest and self._creates(j, nb):
                    self._flag(t, j, first, last, self.times[0], self.times[half], o.fast, nb)
        q2 = nb // 2
        tail = self.peaks[nb - o.late:]
        for j in range(self.n if nb >= max(o.min_blocks, 4 * o.late) else 0):
            late = max([p[j] for p in tail])
            early = max(self._cummax[q2 - 1][j], floor)
            if not o.growth * early < late < early / o.rest:  # false for NaN (the master's finite check names those)
                continue
            if not self._creates(j, nb):
                continue
            self._flag(t, j, early, late, self.times[0], self.times[q2], o.growth, nb)
        if nb >= o.min_blocks and o.geometric is not None:
            # geometric growth over three consecutive quarters (Q2 -> Q3 -> Q4), the rate not dying out: the
            # signature of an unstable mode, whatever the coupling's energy bookkeeping says (Gauss-Seidel with
            # zero-order hold moves energy through the bond with almost no error on it and still grows);
            # spin-ups and cuts saturate, a resonance under periodic forcing grows polynomially (power x2.25
            # at most from Q2 to Q3 for a linearly growing amplitude)
            (a2, b2), (a3, b3), (a4, b4) = _quarters(nb)
            w2, w3, w4 = self._quarters
            peaks = self.peaks
            scale = o.floor * self._cummax_all[-1]  # a bond near rest is not judged (cut onsets)
            for j in range(self.n):
                p2, p3, p4 = w2[j].max(peaks, j, a2, b2), w3[j].max(peaks, j, a3, b3), w4[j].max(peaks, j, a4, b4)
                if p2 < scale or p2 < o.quiet * self.nominal[j] or p3 <= 0.0:
                    continue  # near rest: on the run's scale, or on the bond's declared nominal power
                r3, r4 = p3 / p2, p4 / p3
                # the same rate in both quarters (at least 0.7 times the first ratio, at most its square):
                # steady exponential growth
                if not (r3 > o.geometric and r4 > o.geometric and 0.7 * r3 < r4 < r3 * r3):
                    if r3 < 1.0 or r4 < 1.0:
                        self._geo_since[j] = None  # the growth stopped
                    continue
                # confirmed only if it holds again once the run is 1.5 times as long as when it first held, the
                # power not having fallen in between, AND the ratio per quarter has grown with the quarters
                # (x^1.5 for exponential growth, asked: x^1.25): a machine's periodic load (a return stroke in
                # the first cycle) grows within one period and then repeats; a start from rest grows as a
                # power of t, by the same ratio per quarter however long the run; an unstable mode keeps
                # growing exponentially
                since = self._geo_since[j]
                rate = min(r3, r4)
                if since is None:
                    self._geo_since[j] = (t, rate)
                elif (t - self.times[0] >= 1.5 * (since[0] - self.times[0]) and rate >= since[1] ** 1.25
                      and not self._flagged[j]):
                    self._flagged[j] = True
                    self._why[j] = (self._geometric_evidence, (p2, p3, p4, self.times[nb // 4],
                                                              self.times[nb // 2], self.times[(3 * nb) // 4]))
        self._streak = [s + 1 if f else 0 for s, f in zip(self._streak, self._flagged)]
        self._flagged = [False] * self.n
        for j in range(self.n):
            if self._streak[j] >= o.persist:
                evidence, args = self._why[j]
                self._stop(t, j, evidence(j, nb, *args))

    def finish(self, t: float) -> str:
        """The run reached its stop time at ``t``.  A bond still growing geometrically then (the quarters'
        test holds at the end, see :meth:`_judge`), its confirmation not yet due, not slowing down from the
        third quarter to the fourth (``end_rate``), and fed by the coupling (it created more than
        ``suspect_creation`` of the energy that flowed through the bond over the second half of the run) is
        reported: one line, '' if none.  Not a stop: an instability only a longer run confirms grows so (at 60
        periods, the two-inertia map's slowest Gauss-Seidel points: x2.16, x2.16, the coupling creating 0.6 %).
        A drive cut short in its first machine cycle grows so too (bed_drive at 1 s, its return stroke: x3.09,
        x2.91) but with the coupling creating 1e-3 J of 146 J: not reported."""
        o = self.opts
        nb = len(self.peaks)
        if o.geometric is None or o.end_rate is None or nb < o.min_blocks:
            return ""
        bounds = _quarters(nb)
        for j in range(self.n):
            if self._geo_since[j] is None:
                continue
            p2, p3, p4 = (max(p[j] for p in self.peaks[a:b]) for a, b in bounds)
            if p2 > 0.0 and p3 > 0.0 and p3 / p2 > o.geometric and p4 / p3 >= max(o.geometric, o.end_rate * p3 / p2):
                half = nb // 2
                created = self.energies[nb][j] - self.energies[half][j]
                if created <= o.suspect_creation * sum(f[j] for f in self.flows[half:]):
                    continue  # a growth the coupling does not feed is the machine's own (a first cycle, a run-up)
                inst, var = self.efforts[j]
                return (f"t = {t:.9g} s: instance {inst}: output {var}: the power on bond {self.labels[j]} was still "
                        f"growing geometrically at the end of the run, {p2:.3g} W -> {p3:.3g} W -> {p4:.3g} W per "
                        f"quarter (x{p3 / p2:.3g}, x{p4 / p3:.3g}): a start-up or first machine cycle still under "
                        f"way, or an instability; a longer run tells")
        return ""

    def _flag(self, t, j, early, late, t0, t1, limit, nb):
        if not self._flagged[j]:
            self._flagged[j] = True
            self._why[j] = (self._growth_evidence, (early, late, t0, t1, limit))

    def _creates(self, j: int, nb: int) -> bool:
        """Whether the coupling created more than ``creation`` of the energy that flowed through bond j over
        the last quarter of the blocks (at least the newest block), beyond half a step's worth of its power
        (half the largest step times the peak power over that quarter: a jump of the effort within one step,
        sampled a step late, books about that much once)."""
        c = self.opts.creation
        if c is None:
            return True
        q3 = min((3 * nb) // 4, nb - 1)
        created = self.energies[nb][j] - self.energies[q3][j]
        flowed = sum(f[j] for f in self.flows[q3:])
        one_step = 0.5 * max(self.steps_max[q3:]) * max(p[j] for p in self.peaks[q3:])
        return created - one_step > c * flowed

    def _geometric_evidence(self, j, nb, p2, p3, p4, t2, t3, t4) -> str:
        return (f"the run diverged on power bond {self.labels[j]}: its peak power grew geometrically, "
                f"{p2:.3g} W ({t2:.4g}-{t3:.4g} s) -> {p3:.3g} W (to {t4:.4g} s) -> {p4:.3g} W "
                f"(x{p3 / p2:.3g}, x{p4 / p3:.3g}; limit x{self.opts.geometric:g} each)")

    def _stop(self, t, j, evidence):
        inst, var = self.efforts[j]
        err = Diverged(f"t = {t:.9g} s: instance {inst}: output {var}: {evidence}", time=t, instance=inst,
                       variable=var)
        err.evidence = evidence
        raise err

    def _growth_evidence(self, j, nb, early, late, t0, t1, limit) -> str:
        q3 = min((3 * nb) // 4, nb - 1)
        created = self.energies[nb][j] - self.energies[q3][j]
        flowed = sum(f[j] for f in self.flows[q3:])
        evidence = (f"the run diverged on power bond {self.labels[j]}: its peak power grew from {early:.3g} W "
                    f"({t0:.4g}-{t1:.4g} s) to {late:.3g} W (x{late / early if early > 0 else math.inf:.3g}, "
                    f"limit x{limit:g}); the coupling created {created:.3g} J since {self.times[q3]:.4g} s "
                    f"({created / flowed if flowed > 0 else math.inf:.0%} of the {flowed:.3g} J that flowed "
                    f"through it)")
        return evidence


class DivergenceWatch(Observer):
    """The detector as an observer of the run loop (:class:`harness.master.observers.Observer`): fed every accepted
    point; raises :class:`Diverged` to stop the run; at a completed end keeps the detector's verdict in
    ``suspect`` ('' if none)."""

    def __init__(self, master, options: DivergenceOptions | None = None):
        self.detector = for_master(master, options)
        self.suspect = ""

    def on_start(self, master, t_ns):
        self.detector.times[0] = t_ns / NS  # its first block boundary: the start of the run
        self.start_ns = t_ns

    def on_event(self, master, t_ns):
        if t_ns > self.start_ns:            # an input step after the start: the detector's grace
            self.detector.event(t_ns / NS, master.bond_log)

    def on_step(self, master, t_prev_ns, t_ns):
        self.detector.update(t_ns / NS, master.bond_log, (t_ns - t_prev_ns) / NS)

    def on_end(self, master, t_ns, completed):
        if completed:
            self.suspect = self.detector.finish(t_ns / NS)


def for_master(master, options: DivergenceOptions | None = None) -> DivergenceDetector:
    """A detector for the bonds of a :class:`harness.master.Master`."""
    efforts, nominal = [], []
    for (_, w_out, _, tau_out) in master._bonds:
        inst, var = master.signal_names[tau_out].split(".", 1)
        efforts.append((inst, var))
        scale = 1.0
        for name in (master.signal_names[tau_out], master.signal_names[w_out]):
            i, v = name.split(".", 1)
            declared = getattr(master.fmus[i].variables.get(v), "nominal", None)
            scale *= abs(float(declared)) if declared not in (None, "") and float(declared) != 0.0 else 1.0
        nominal.append(scale)
    return DivergenceDetector(master.bond_labels, efforts, options, nominal)


def replay(bond_log, options: DivergenceOptions | None = None, efforts=None) -> str:
    """Run the detector over a finished result's :class:`harness.results.BondLog`; the one-line reason if it
    diverged, else ''.  (Runs of :func:`harness.run.simulate` are already judged online; this serves results
    computed with the detector off.)"""
    import numpy as np

    labels = list(bond_log.labels)
    efforts = efforts or [tuple(lbl.split("->")[1].split(".", 1)) for lbl in labels]
    det = DivergenceDetector(labels, efforts, options)
    t = bond_log.time
    rows = np.stack([bond_log.p_out, bond_log.p_in, bond_log.energy], axis=1)
    try:
        for k in range(1, len(t)):
            det.update(float(t[k]), rows[k], float(t[k] - t[k - 1]))
    except Diverged as e:
        return str(e)
    return ""


def diverged(df) -> bool:
    """True if a result was stopped by the divergence detector (or, run without it, would have been)."""
    if not df.attrs.get("complete", True) and df.attrs.get("diverged"):
        return True
    log = df.attrs.get("bonds")
    if log is None or not getattr(log, "labels", None) or df.attrs.get("divergence_checked"):
        return False
    return bool(replay(log))


__all__ = ["Diverged", "DivergenceOptions", "DivergenceDetector", "for_master", "replay", "diverged"]
