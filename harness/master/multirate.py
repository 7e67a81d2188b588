"""Each FMU at its own rate (multirate): an instance's communication step a whole multiple of the run's base step.

An instance declared with ``Instance(..., step=...)`` (or a Simulator's ``stepSize`` in an OspSystemStructure.xml,
or OSP's ``osp:StepSizeHint`` on an SSP component) steps once every ``rate = step / base step`` base steps, with
one ``do_step`` of ``rate`` base steps; an instance without a step takes the base step.  What the masters that
hold rates (``jacobi``, ``jacobi-sampled``, ``gauss-seidel``; the iterating and correcting masters refuse rates by
name) do with them:

* **Its own points.**  A slow instance is at a communication point of its own only at the start and end of its
  step.  In between, its FMU is already at the end of its step (FMI's ``doStep`` goes the whole way at once),
  so nothing is read from it and nothing is set into it: its outputs in the signal vector, in the recorded
  rows (other variables too) and in every consumer's history keep the values of its last point, with that
  point's time.
* **Held inputs of the slow side.**  At the start of its step a slow instance takes held inputs for the whole
  ``[t, t + rate*h]``: with ``jacobi`` and ``gauss-seidel`` the master's extrapolation (:mod:`~harness.master.
  extrapolation`) of each source's newest samples, evaluated at the middle of the slow step (order 0: the newest
  sample itself).  ``gauss-seidel`` takes the newest samples, including those of sources stepped before it in
  this base step (at ``t + h``).
* **Extrapolation of the slow side.**  A fast instance holds a slow source's output as that source's newest
  sample (order 0), or extrapolates the polynomial through the slow source's own samples, which lie a slow
  step apart, to the middle of its fast step (order >= 1).  A slow source's new samples appear only when the
  master's time reaches the end of its step, never earlier.
* **libcosim's rule** (``jacobi-sampled``, which samples as libcosim does): a connection passes its value only
  at the base steps that are whole multiples of BOTH ends' rates (libcosim's ``fixed_step_algorithm``: the
  transfer when the step counter is a multiple of ``lcm(source rate, target rate)``), and a target holds the
  last value passed (order 0; extrapolation is refused).  For rates that divide one another this is the newest
  sample; for rates 2 and 3 a rate-3 target sees the rate-2 source's value of the last multiple of 6.
* Integer, Boolean, String and Enumeration connections pass at the base steps that are multiples of both
  ends' rates, under every master.

Master time stays integer nanoseconds: an instance's step ends at ``t_ns + rate * h_ns``.  A slow instance's last
step may reach past the stop time, as in libcosim: the run ends at its stop time, and the slow instance's values
there are those of its last own point (its FMU is set up with the end of that step as its stop time).  The run's
step control must be fixed: a variable step under rates is refused.
"""
from __future__ import annotations

import math

import numpy as np

from harness.errors import SystemDescriptionError
from harness.master.clock import NS


def rates_of(system_instances, step_ns: int, where: str) -> dict[str, int]:
    """``{instance: rate}`` of the instances that declare a step (``Instance.step`` [s]); each step must be a whole
    multiple (>= 1) of the base step ``step_ns``, else a one-line error naming the instance, its step, the base
    step and the nearest multiples."""
    out: dict[str, int] = {}
    for inst in system_instances:
        step = getattr(inst, "step", None)
        if step is None:
            continue
        if isinstance(step, bool) or not isinstance(step, (int, float)) or not math.isfinite(step) or step <= 0:
            raise SystemDescriptionError(f"{where}: instance {inst.name}: step = {step!r} must be a positive number "
                                         f"of seconds (a whole multiple of the base step {step_ns / NS:g} s)")
        own = int(round(step * NS))
        rate, rest = divmod(own, step_ns)
        if rest or rate < 1:
            lo, hi = max(1, rate) * step_ns / NS, (rate + 1) * step_ns / NS
            raise SystemDescriptionError(f"{where}: instance {inst.name}: step = {step!r} s is not a whole multiple "
                                         f"of the base step {step_ns / NS:g} s (allowed: {lo:g} s, {hi:g} s, ...)")
        if rate > 1:
            out[inst.name] = rate
    return out


class Rates:
    """The rates of a master's instances and where each one's current step ends (integer ns).

    ``r``: rate per instance (master order); ``k``: base steps taken since the start; ``ends``: per instance the
    time its current step ends (== the master's time: it is at a point of its own); ``fresh``: names of the
    instances at a point of their own at the master's time (the recorder reads only those)."""

    def __init__(self, master, rates: dict[str, int], step_ns: int | None = None):
        insts = master.insts
        self.step_ns = step_ns   # the base step (None: not known; each FMU's stop time is then the run's)
        self.r = [int(rates.get(it.name, 1)) for it in insts]
        self.k = 0
        self.ends = [0] * len(insts)
        self.fresh = {it.name for it in insts}
        owner = np.empty(len(master.y), dtype=np.intp)   # instance of every entry of y
        for i, it in enumerate(insts):
            owner[it.output_slice] = i
        target = np.empty(len(master.u), dtype=np.intp)  # instance of every entry of u
        for i, it in enumerate(insts):
            target[it.input_slice] = i
        r = np.array(self.r, dtype=np.int64)
        self.link_lcm = np.lcm(r[owner[master.src]], r[target]) if len(master.u) else np.zeros(0, dtype=np.int64)
        index = {id(it.fmu): i for i, it in enumerate(insts)}
        self.discrete_lcm = [math.lcm(self.r[index[id(link[0])]], self.r[index[id(link[2])]])
                             for link in master._discrete + master._discrete_chain]
        self.names = [it.name for it in insts]
        self._slices = [it.output_slice for it in insts]
        self._ranges: dict[tuple, list] = {}   # the signals of a set of instances, as few slices (cached per set)

    def start(self, start_ns: int) -> None:
        self.k = 0
        self.ends = [start_ns] * len(self.r)

    def starting(self, t_ns: int) -> list[int]:
        """Instances whose step starts at ``t_ns`` (they are at a point of their own)."""
        return [i for i, end in enumerate(self.ends) if end == t_ns]

    def begin(self, t_ns: int, h_ns: int) -> tuple[list[int], dict[int, int]]:
        """The instances starting a step at ``t_ns`` and each one's step [ns]: ``rate * h_ns``."""
        starting = self.starting(t_ns)
        steps = {}
        for i in starting:
            steps[i] = h = self.r[i] * h_ns
            self.ends[i] = t_ns + h
        return starting, steps

    def stop_of(self, i: int, start_ns: int, stop_ns: int) -> int:
        """The end of instance ``i``'s last own step of a run from ``start_ns`` to ``stop_ns`` [ns] (its FMU's stop
        time: that step may reach past the run's)."""
        own = self.r[i] * self.step_ns
        return start_ns + -(-(stop_ns - start_ns) // own) * own

    def finish(self, t_next_ns: int) -> list[int]:
        """Count the base step; the instances whose step ends at ``t_next_ns``."""
        self.k += 1
        done = [i for i, end in enumerate(self.ends) if end == t_next_ns]
        self.fresh = {self.names[i] for i in done}
        return done

    def plan(self, plan: list, which: list[int]) -> list:
        """The steps of an exchange plan (:func:`harness.master.coupling.exchange_plan`) that concern the instances
        ``which`` (cached per set)."""
        key = ("plan", tuple(which))
        found = self._ranges.get(key)
        if found is None:
            chosen = set(which)
            found = self._ranges[key] = [(op, arg) for op, arg in plan if isinstance(arg, int) and arg in chosen]
        return found

    def ranges(self, which: list[int]) -> list[slice]:
        """The entries of ``y`` of the instances ``which`` as the fewest slices (adjacent instances' slices
        joined; cached per set)."""
        key = tuple(which)
        found = self._ranges.get(key)
        if found is None:
            found = []
            for i in sorted(which):
                sl = self._slices[i]
                if sl.stop == sl.start:
                    continue
                if found and found[-1].stop == sl.start:
                    found[-1] = slice(found[-1].start, sl.stop)
                else:
                    found.append(sl)
            self._ranges[key] = found
        return found

    def transfer_mask(self) -> np.ndarray:
        """The entries of ``u`` whose connection passes a value at this base step (libcosim's rule; always at
        the start of the target's step, as the multiple of both rates is one of the target's)."""
        return self.k % self.link_lcm == 0

    def discrete_now(self) -> list[bool]:
        """Per non-Real connection (sampled ones, then chained ones): whether it passes at this base step."""
        return [self.k % m == 0 for m in self.discrete_lcm]

    # -- checkpoints ---------------------------------------------------------------------------------------------
    def state(self) -> dict:
        return {"k": self.k, "ends": list(self.ends), "fresh": sorted(self.fresh)}

    def set_state(self, state: dict) -> None:
        self.k = int(state["k"])
        self.ends = [int(e) for e in state["ends"]]
        self.fresh = set(state["fresh"])
