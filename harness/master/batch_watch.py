"""The divergence detector of a scalar run (:mod:`harness.master.divergence`) on a batch of variants:
:class:`DivergenceScreen`, an observer of :class:`harness.master.batch.BatchMaster`.

A scalar run is stopped by its :class:`~harness.master.divergence.DivergenceDetector` when the power on a bond grows
and the coupling feeds it; a batch must stop the same variants, or its results would not be theirs.  The screen
keeps the detector's books for every (bond, variant) on arrays (block peaks and flows, the energy error at block
ends, the running maxima of the first half, the three quarters' window maxima) and, at each block end, applies
the detector's tests (fast growth, growth, geometric growth with its confirmation) to every variant at once.  A
variant the detector would stop is stopped here at the same point (:meth:`BatchMaster._fail`: taken out of the
batch); the batch's caller then runs it on its own, so its result, its message and its time are the scalar run's
own.  A variant whose bonds still grow geometrically at the end of the run (the detector's ``finish``, a warning
in ``attrs["suspect"]``) is named by :meth:`flagged`, for the same reason.

The energy-creation test sums the flows of the newest quarter in the detector's order (numpy's reduction along
the blocks adds them one after the other, as ``sum`` does) and is evaluated only for the variants whose amplitude
already passes a growth test.  The input events' grace periods do not arise (a batch has no input signals).
"""
from __future__ import annotations

import numpy as np

from harness.master.divergence import DivergenceOptions, _quarters, for_master
from harness.master.observers import Observer


class _WindowMax:
    """The largest of ``rows[a:b]`` per element for windows whose bounds never move back, as a queue of two stacks:
    the rows entered since the last transfer folded into one running maximum, the older ones held as suffix maxima
    (computed once, when the window's start reaches them): each row costs about two elementwise maxima in all,
    whatever the window's length.  numpy's maximum propagates NaN as its max does: the same values."""

    def __init__(self, shape):
        self.a = self.b = self.mid = 0
        self.zero = np.zeros(shape)
        self.suffix: dict[int, np.ndarray] = {}     # i in [a, mid): the largest of rows[i:mid]
        self.back = None                            # the largest of rows[mid:b]

    def max(self, rows: list, a: int, b: int) -> np.ndarray:
        if b <= a:
            self.a = self.b = self.mid = b
            self.suffix, self.back = {}, None
            return self.zero
        if a >= self.b:                             # no overlap with the last window: from scratch
            self.a = self.b = self.mid = a
            self.suffix, self.back = {}, None
        for i in range(self.b, b):
            self.back = rows[i] if self.back is None else np.maximum(self.back, rows[i])
        self.b = b
        for i in range(self.a, min(a, self.mid)):
            del self.suffix[i]
        self.a = a
        if a >= self.mid:                           # the front is used up: the rows since the transfer move there
            self.suffix, acc = {}, None
            for i in range(self.b - 1, a - 1, -1):
                acc = rows[i] if acc is None else np.maximum(rows[i], acc)
                self.suffix[i] = acc
            self.mid, self.back = self.b, None
        front = self.suffix[a]
        return front if self.back is None else np.maximum(front, self.back)

    def take(self, columns) -> None:
        """Keep only ``columns`` (an index of the rows' columns: the variants still in the batch)."""
        self.zero = self.zero[columns]
        self.suffix = {i: s[columns] for i, s in self.suffix.items()}
        self.back = None if self.back is None else self.back[columns]


class DivergenceScreen(Observer):
    """The detector's decisions for every variant of a batch (module docstring); ``options`` as the scalar run's
    (:class:`~harness.master.divergence.DivergenceOptions`)."""

    def __init__(self, master, options: DivergenceOptions | None = None):
        self.master = master
        self.opts = o = options or DivergenceOptions()
        det = for_master(master, o)       # the scalar detector's bonds and nominal powers
        self.nominal = np.array(det.nominal)[:, None]
        nb, n = len(master.bond_labels), master.n
        self.shape = (nb, n)
        self.k = 0
        self.h = 0.0
        self.peak = np.zeros(self.shape)
        self.flow = np.zeros(self.shape)
        self.peaks: list = []         # per block: peak power per (bond, variant)
        self.flows: list = []
        self.energies: list = [np.zeros(self.shape)]
        self.steps_max: list = []
        self.times: list = [0.0]
        self.half = np.zeros(self.shape)  # max of the peaks over blocks [0, nb // 2)
        self.half_n = 0
        self.all = np.zeros(n)            # max over bonds and blocks so far
        self.streak = np.zeros(self.shape, dtype=int)
        self.since_t = np.full(self.shape, np.nan)
        self.since_rate = np.full(self.shape, np.nan)
        self.quarters = [_WindowMax(self.shape) for _ in range(3)]
        self.cols = np.arange(n)          # the variants (master columns at the start) the rows hold

    # -- observer ------------------------------------------------------------------------------------------------
    def on_start(self, master, t_ns):
        from harness.master.clock import NS

        self.times[0] = t_ns / NS

    def on_step(self, master, t_prev_ns, t_ns):
        from harness.master.clock import NS

        if master.n != self.peak.shape[1]:
            self._follow(master)
        p_out, p_in, energy = master.bond_log
        a, b = np.abs(p_out), np.abs(p_in)
        m = np.where(a > b, a, b)
        self.peak = np.where((m > self.peak) | (m != m), m, self.peak)
        h = (t_ns - t_prev_ns) / NS
        self.flow = self.flow + a * h
        self.k += 1
        self.h = max(self.h, h)
        if self.k < self.opts.block:
            return
        self.steps_max.append(self.h)
        self.peaks.append(self.peak)
        self.flows.append(self.flow)
        self.energies.append(np.array(energy))
        t = t_ns / NS
        self.times.append(t)
        nb = len(self.peaks)
        while self.half_n < nb // 2:      # fold the block that entered the first half
            self.half = np.where(self.peaks[self.half_n] > self.half, self.peaks[self.half_n], self.half)
            self.half_n += 1
        self.all = np.maximum(self.all, self.peak.max(axis=0))
        self.peak, self.flow, self.k, self.h = np.zeros(self.shape), np.zeros(self.shape), 0, 0.0
        stop = self._judge(t, nb)
        self._forget(nb)
        for k in np.flatnonzero(stop).tolist():
            master._fail(k, t, "the divergence screen: the scalar run's detector stops it here")

    def _forget(self, nb: int) -> None:
        """Free the blocks no test reads again (the quarters start at nb // 4, the creation test and the end's at
        nb // 2 at the earliest; both only move forward): a long run of many variants keeps about half its books."""
        for rows, first in ((self.peaks, nb // 4 - 1), (self.flows, nb // 2 - 1), (self.energies, nb // 2 - 1)):
            for i in range(getattr(self, "_freed", {}).get(id(rows), 0), max(0, first)):
                rows[i] = None
            self.__dict__.setdefault("_freed", {})[id(rows)] = max(0, first)

    def _follow(self, master) -> None:
        """Keep the rows of the variants still in the batch (the master dropped some)."""
        keep = np.searchsorted(self.cols, master.alive)
        self.cols = master.alive.copy()
        take = (slice(None), keep)
        for name in ("peak", "flow", "half", "streak", "since_t", "since_rate"):
            setattr(self, name, getattr(self, name)[take])
        self.all = self.all[keep]
        for rows in (self.peaks, self.flows, self.energies):
            rows[:] = [r[take] if r is not None else None for r in rows]
        for w in self.quarters:
            w.take(take)
        self.shape = self.peak.shape

    # -- the detector's tests ------------------------------------------------------------------------------------
    def _judge(self, t: float, nb: int) -> np.ndarray:
        o = self.opts
        flagged = np.zeros(self.shape, dtype=bool)
        floor_half = o.floor * (self.half.max(axis=0) if nb >= 2 else self.peaks[0].max(axis=0))
        early = np.where(floor_half > self.half, floor_half, self.half)   # max(first half's peak, floor)
        if nb >= max(4, o.min_blocks // 2):
            last = self.peaks[-1]
            flagged |= self._creates((o.fast * early < last) & (last < early / o.rest), nb)
        if nb >= max(o.min_blocks, 4 * o.late):
            late = np.max(np.stack(self.peaks[nb - o.late:]), axis=0)
            flagged |= self._creates((o.growth * early < late) & (late < early / o.rest), nb)
        if nb >= o.min_blocks and o.geometric is not None:
            flagged |= self._geometric(t, nb, flagged)
        self.streak = np.where(flagged, self.streak + 1, 0)
        return (self.streak >= o.persist).any(axis=0)

    def _creates(self, candidate: np.ndarray, nb: int) -> np.ndarray:
        """The detector's ``_creates`` where ``candidate`` (bond x variant) holds, False elsewhere."""
        c = self.opts.creation
        if c is None or not candidate.any():
            return candidate
        out = np.zeros(self.shape, dtype=bool)
        bonds, cols = np.nonzero(candidate)
        q3 = min((3 * nb) // 4, nb - 1)
        created = self.energies[nb][bonds, cols] - self.energies[q3][bonds, cols]
        flowed = np.sum(np.stack([f[bonds, cols] for f in self.flows[q3:nb]]), axis=0)
        one_step = 0.5 * max(self.steps_max[q3:]) * np.max(np.stack([p[bonds, cols] for p in self.peaks[q3:nb]]),
                                                            axis=0)
        out[bonds, cols] = created - one_step > c * flowed
        return out

    def _geometric(self, t: float, nb: int, flagged: np.ndarray) -> np.ndarray:
        o = self.opts
        (a2, b2), (a3, b3), (a4, b4) = _quarters(nb)
        p2 = self.quarters[0].max(self.peaks, a2, b2)
        p3 = self.quarters[1].max(self.peaks, a3, b3)
        p4 = self.quarters[2].max(self.peaks, a4, b4)
        scale = o.floor * self.all
        judged = ~((p2 < scale) | (p2 < o.quiet * self.nominal) | (p3 <= 0.0))
        r3 = np.where(judged, p3 / np.where(p2 == 0.0, 1.0, p2), 0.0)
        r4 = np.where(judged, p4 / np.where(p3 == 0.0, 1.0, p3), 0.0)
        steady = judged & (r3 > o.geometric) & (r4 > o.geometric) & (0.7 * r3 < r4) & (r4 < r3 * r3)
        stopped = judged & ~steady & ((r3 < 1.0) | (r4 < 1.0))
        self.since_t = np.where(stopped, np.nan, self.since_t)
        self.since_rate = np.where(stopped, np.nan, self.since_rate)
        rate = np.minimum(r3, r4)
        first = steady & np.isnan(self.since_t)
        from fmus.physics.mathns import VECTOR

        again = steady & ~np.isnan(self.since_t)
        confirmed = again & (t - self.times[0] >= 1.5 * (self.since_t - self.times[0])) & ~flagged
        if confirmed.any():
            need = VECTOR.pow(np.where(confirmed, self.since_rate, 1.0), 1.25)
            confirmed &= rate >= need
        self.since_t = np.where(first, t, self.since_t)
        self.since_rate = np.where(first, rate, self.since_rate)
        return confirmed

    # -- the end ---------------------------------------------------------------------------------------------------
    def flagged(self) -> dict:
        """{variant (the master's column at the start): one line} of the completed variants the detector's
        ``finish`` would report (a bond still growing geometrically at the end, the coupling feeding it)."""
        o = self.opts
        nb = len(self.peaks)
        if o.geometric is None or o.end_rate is None or nb < o.min_blocks:
            return {}
        (a2, b2), (a3, b3), (a4, b4) = _quarters(nb)
        p2, p3, p4 = (np.max(np.stack(self.peaks[a:b]), axis=0) for a, b in ((a2, b2), (a3, b3), (a4, b4)))
        watched = ~np.isnan(self.since_t)
        with np.errstate(all="ignore"):
            grows = watched & (p2 > 0.0) & (p3 > 0.0) & (p3 / p2 > o.geometric) & (
                p4 / p3 >= np.maximum(o.geometric, o.end_rate * p3 / p2))
        if not grows.any():
            return {}
        half = nb // 2
        created = self.energies[nb] - self.energies[half]
        flowed = np.sum(np.stack(self.flows[half:]), axis=0)
        fed = grows & ~(created <= o.suspect_creation * flowed)
        return {int(self.cols[k]): "its bonds still grew geometrically at the end of the run"
                for k in np.flatnonzero(fed.any(axis=0)).tolist()}


__all__ = ["DivergenceScreen"]
