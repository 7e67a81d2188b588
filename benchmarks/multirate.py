"""Each FMU at its own rate on the shipped drives: the cheapest per-FMU rates that meet a drive's declared accuracy,
beside its best single rate (issue 60).

``python -m benchmarks.multirate [--systems bed_drive ...] [--repeats 3] [--out results/multirate.csv]``

For each drive that declares its accuracy (``System.accuracy``), with the master and extrapolation of its
declared experiment, over the accuracy's span, judged by :func:`harness.studies.accuracy.check` against the
monolithic reference:

1. **best single rate**: the largest step of the ladder (:data:`LADDER`, those dividing the span) at which every
   FMU at that step meets the accuracy;
2. **per-FMU rates**: for base steps at and one rung below the best single one, each instance in turn (the
   order the drive declares them) takes the largest rate of :data:`RATES` at which the whole drive still meets
   the accuracy with the rates chosen before it (a greedy search; each trial a full run);
3. the cheapest of each, by FMU steps (``fmi2DoStep`` calls summed over the FMUs: the cost that holds on any
   machine), then run ``--repeats`` times side by side, in turn, for the stepping CPU time
   (``time.process_time`` around the run's loop, ``df.attrs["cpu_time"]``), the median kept.  Run it pinned
   to one CPU (``taskset -c 0 python -m benchmarks.multirate``): the machine is shared.

The table has one row per drive: the best single step and its cost, the rates and their cost, the ratio.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

LADDER = (2e-5, 5e-5, 1e-4, 2e-4, 2.5e-4, 5e-4, 1e-3, 2e-3)
RATES = (2, 3, 4, 5, 8, 10, 16, 20, 25, 40, 50, 100)


def _divides(span: float, h: float) -> bool:
    n = span / h
    return abs(n - round(n)) <= 1e-9 * n


def with_rates(system, step: float, rates: dict):
    """``system`` with each instance of ``rates`` at its own step ``rate * step``."""
    return replace(system, instances=[replace(i, step=rates[i.name] * step if rates.get(i.name, 1) > 1 else None)
                                      for i in system.instances])


class Judge:
    """Runs a drive over its accuracy span and judges it (one reference, computed once)."""

    def __init__(self, name: str):
        from harness import load
        from harness.studies.accuracy import accuracy_spec
        from harness.studies.reference import reference

        self.system = load(name)
        self.spec = accuracy_spec(self.system)
        exp = self.system.experiment
        self.master, self.order = exp.master, exp.extrapolation
        with np.errstate(over="ignore", invalid="ignore"):
            self.reference = reference(self.system, stop_time=self.spec.stop_time, step=self.spec.reference_step)
        self.runs = 0

    def run(self, step: float, rates: dict):
        from harness.studies.trial import trial

        self.runs += 1
        return trial(with_rates(self.system, step, rates), stop_time=self.spec.stop_time, step=step,
                     master=self.master, extrapolation=self.order)

    def meets(self, step: float, rates: dict) -> tuple[bool, int]:
        from harness.studies.accuracy import check

        t = self.run(step, rates)
        if t.result is None or not t.complete:
            return False, 0
        return all(c.ok for c in check(self.system, t.result, self.reference)), int(t.result.attrs["fmu_steps"])


def best_single(judge: Judge) -> tuple[float, int] | None:
    """(step, FMU steps) of the largest ladder step that meets the accuracy, every FMU at it (tried from the
    largest down; the first that meets)."""
    for h in sorted(LADDER, reverse=True):
        if _divides(judge.spec.stop_time, h):
            ok, cost = judge.meets(h, {})
            if ok:
                return h, cost
    return None


def best_rates(judge: Judge, base: float, log=None) -> tuple[dict, int] | None:
    """(rates, FMU steps) of the greedy per-FMU search at base step ``base`` (module docstring)."""
    ok, cost = judge.meets(base, {})
    if not ok:
        return None
    rates: dict[str, int] = {}
    for inst in [i.name for i in judge.system.instances]:
        for r in RATES:
            trial_rates = {**rates, inst: r}
            good, c = judge.meets(base, trial_rates)
            if log:
                log(f"  base {base:g} s {trial_rates}: {'meets' if good else 'misses'} ({c} FMU steps)")
            if not good:
                break
            rates, cost = trial_rates, c
    return rates, cost


def cpu_time(judge: Judge, step: float, rates: dict) -> float:
    t = judge.run(step, rates)
    return float(t.result.attrs["cpu_time"])


def measure(name: str, repeats: int = 3, log=print) -> dict:
    t0 = time.perf_counter()
    judge = Judge(name)
    single = best_single(judge)
    if single is None:
        return dict(system=name, note="no ladder step meets the accuracy")
    h, single_cost = single
    log(f"{name}: best single step {h:g} s, {single_cost} FMU steps")
    candidates = []
    below = [s for s in LADDER if s < h and _divides(judge.spec.stop_time, s)]
    for base in [h] + below[-1:]:
        found = best_rates(judge, base, log)
        if found is not None:
            candidates.append((found[1], base, found[0]))
    cost, base, rates = min(candidates, key=lambda c: c[0]) if candidates else (single_cost, h, {})
    if cost >= single_cost:   # no rates beat the single one: the single one it is
        cost, base, rates = single_cost, h, {}
    cpu_single, cpu_rates = [], []
    for _ in range(repeats):   # side by side, in turn
        cpu_single.append(cpu_time(judge, h, {}))
        cpu_rates.append(cpu_time(judge, base, rates))
    row = dict(system=name, master=judge.master, extrapolation=judge.order, single_step=h,
               single_fmu_steps=single_cost, single_cpu=statistics.median(cpu_single), base_step=base,
               rates=" ".join(f"{k}={v}" for k, v in rates.items()) or "-", rates_fmu_steps=cost,
               rates_cpu=statistics.median(cpu_rates), runs=judge.runs,
               search_wall=time.perf_counter() - t0)
    row["fmu_steps_ratio"] = row["rates_fmu_steps"] / row["single_fmu_steps"]
    row["cpu_ratio"] = row["rates_cpu"] / row["single_cpu"]
    log(f"{name}: {row}")
    return row


def main(argv=None) -> int:
    from harness.run import system_names

    p = argparse.ArgumentParser(prog="python -m benchmarks.multirate", description=__doc__.splitlines()[0])
    p.add_argument("--systems", nargs="*", default=None)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--out", type=Path, default=None)
    args = p.parse_args(argv)
    from benchmarks.host_accuracy import drives

    names = args.systems or list(drives())
    unknown = sorted(set(names) - set(system_names()))
    if unknown:
        print(f"error: unknown systems {', '.join(unknown)}", file=sys.stderr)
        return 1
    rows = [measure(n, args.repeats) for n in names]
    df = pd.DataFrame(rows)
    print(df.to_string(index=False))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        df.to_csv(args.out, index=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
