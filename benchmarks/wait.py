"""The wait a person sees: ``python -m benchmarks.wait [--repeat N] [--pin] [--system NAME]``.

Times whole commands as a person types them, each in a process of its own (start to exit, from outside):

* ``python -m harness --help``;
* ``python -m harness run SYSTEM --quiet-quantities`` (the summary line only);
* the same with the charts drawn in the command's own process, one after the other (no chart workers,
  :mod:`harness.chartworkers`), for comparison;
* ``python -m harness run SYSTEM --plot DIR`` (summary, quantities table and both charts): the goal line,
  its wall time at most ``GOAL`` times the run's own stepping time (``attrs["wall_time"]``: the FMUs'
  initialisation and the steps, as the command prints it).

Each line gives the wall time, the process's CPU time (user + system, of the child: less disturbed by other
processes on a loaded machine than the wall time), the stepping time the command printed, and the ratios
whole / stepping by wall time and by CPU time.  ``--pin`` runs every command on CPU 0 (``taskset -c 0``), so
the command's own threads do not spread over cores.  The median over ``--repeat`` runs is shown.

``--stages``: the CPU and wall time of each stage of ``run SYSTEM --plot`` (imports, loading the drive, opening
the FMUs, the stepping, the quantities, the charts, drawn by the chart workers as the command does) in one
process, and the total against the stepping's own CPU and wall time (``attrs["cpu_time"]``,
``attrs["wall_time"]``): on a loaded machine the wall times stretch with the load, CPU times much less.
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GOAL = 3.0      # run with summary and charts at most this many times its stepping time
STEPPING = re.compile(r" steps(?: \([^)]*\))? in ([0-9.eE+-]+) s;")


def timed(argv: list[str], pin: bool) -> tuple[float, float, str]:
    """(wall [s], CPU of the child [s], stdout) of one command run to its end."""
    if pin and shutil.which("taskset"):
        argv = ["taskset", "-c", "0", *argv]
    before = os.times()
    t0 = time.perf_counter()
    p = subprocess.run(argv, cwd=ROOT, capture_output=True, text=True, env={**os.environ, "MPLBACKEND": "Agg"})
    wall = time.perf_counter() - t0
    after = os.times()
    if p.returncode:
        raise SystemExit(f"{' '.join(argv)}: exit {p.returncode}: {p.stderr.strip().splitlines()[-1:]}")
    cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
    return wall, cpu, p.stdout


def stepping(stdout: str) -> float:
    found = STEPPING.search(stdout)
    if not found:
        raise SystemExit(f"no stepping time in the run's summary line: {stdout.splitlines()[:1]}")
    return float(found.group(1))


# the run command with its charts drawn in its own process, one after the other (no chart workers): the
# comparison for the workers' gain, side by side in one session
IN_PROCESS = [sys.executable, "-c", "import sys; from harness import chartworkers; chartworkers.available_cpus = "
              "lambda: 1; from harness.__main__ import main; sys.exit(main(sys.argv[1:]))"]


def measure(system: str, repeat: int, pin: bool) -> list[dict]:
    py = [sys.executable, "-m", "harness"]
    rows = []
    with tempfile.TemporaryDirectory(prefix="wait-") as tmp:
        cases = [("--help", py + ["--help"], False),
                 (f"run {system} (summary only)", py + ["run", system, "--quiet-quantities"], True),
                 (f"run {system} --plot, charts in process", IN_PROCESS + ["run", system, "--plot", tmp], True),
                 (f"run {system} --plot (summary, quantities, charts)", py + ["run", system, "--plot", tmp], True)]
        for label, argv, is_run in cases:
            walls, cpus, steps = [], [], []
            for _ in range(repeat):
                wall, cpu, out = timed(argv, pin)
                walls.append(wall)
                cpus.append(cpu)
                if is_run:
                    steps.append(stepping(out))
            row = dict(case=label, wall=statistics.median(walls), cpu=statistics.median(cpus))
            if steps:
                row["stepping"] = statistics.median(steps)
                row["ratio_wall"] = row["wall"] / row["stepping"]
                row["ratio_cpu"] = row["cpu"] / row["stepping"]
            rows.append(row)
    return rows


def lines(rows: list[dict], pin: bool, repeat: int) -> list[str]:
    out = [f"the wait a person sees (median of {repeat}{', pinned to CPU 0' if pin else ''}; "
           f"CPU = the command's user + system time)"]
    for r in rows:
        text = f"  {r['case']:<48} wall {r['wall']:6.2f} s  CPU {r['cpu']:6.2f} s"
        if "stepping" in r:
            text += (f"  stepping {r['stepping']:5.2f} s  whole/stepping {r['ratio_wall']:4.1f}x wall, "
                     f"{r['ratio_cpu']:4.1f}x CPU")
        out.append(text)
    last = rows[-1]
    verdict = "met" if last["ratio_wall"] <= GOAL else "missed"
    out.append(f"  goal: run with summary and charts <= {GOAL:g}x its stepping time: {last['ratio_wall']:.1f}x by "
               f"wall time, {verdict} ({last['ratio_cpu']:.1f}x by CPU time)")
    return out


STAGES_CHILD = r"""
import json, os, sys, tempfile, time
marks = [("interpreter start-up", time.process_time(), time.perf_counter())]
def mark(name):
    marks.append((name, time.process_time(), time.perf_counter()))
from harness import chartworkers
chartworkers.start_early()                       # as the run command does with --plot
import harness.run as run
mark("imports of the run command")
system = run.load(sys.argv[1])
workers = chartworkers.for_run()
mark("loading the drive")
df = run.simulate(system, options=run.RunOptions(progress=None))
mark("simulate")
df.attrs["quantities"].table()
mark("quantities table")
from harness.charts import plot_result
with tempfile.TemporaryDirectory() as d:
    plot_result(system, df, d, workers=workers)
    drawn = workers.drawn if workers is not None else 0
    if workers is not None:
        workers.close()
mark("charts (two figures, PNG)")
t0 = marks[0][2] - marks[0][1]                    # wall clock at process start (its CPU so far as wall)
out, cpu0, wall0 = [], 0.0, t0
for name, cpu, wall in marks:
    out.append((name, cpu - cpu0, wall - wall0))
    cpu0, wall0 = cpu, wall
step = df.attrs.get("cpu_time", df.attrs["wall_time"])   # a tree before cpu_time: the wall time
i = [n for n, *_ in out].index("simulate")
out[i:i + 1] = [("simulate: opening the FMUs, results", out[i][1] - step, out[i][2] - df.attrs["wall_time"]),
                ("simulate: initialisation and steps", step, df.attrs["wall_time"])]
kids = os.times()
print(json.dumps({"stages": out, "stepping_cpu": step, "stepping_wall": df.attrs["wall_time"],
                  "total": marks[-1][1], "total_wall": marks[-1][2] - t0, "drawn_by_workers": drawn,
                  "workers_cpu": kids.children_user + kids.children_system}))
"""


def stages(system: str, pin: bool) -> dict:
    """CPU and wall time [s] of each stage of ``run SYSTEM --plot`` in a process of its own (the run command's
    steps called one by one, its chart workers too): the CPU times are robust to other processes, which stretch
    wall times but hardly CPU times."""
    import json

    argv = [sys.executable, "-c", STAGES_CHILD, system]
    _wall, _cpu, out = timed(argv, pin)
    return json.loads(out.strip().splitlines()[-1])


def stage_lines(found: dict) -> list[str]:
    out = ["by stage of run --plot (one process; the stepping's own times from attrs['cpu_time'], ['wall_time'])",
           f"  {'':<44} {'CPU':>8} {'wall':>8}"]
    out += [f"  {name:<44} {cpu:6.2f} s {wall:6.2f} s" for name, cpu, wall in found["stages"]]
    out.append(f"  {'total':<44} {found['total']:6.2f} s {found['total_wall']:6.2f} s = "
               f"{found['total'] / found['stepping_cpu']:.1f}x the stepping's CPU time, "
               f"{found['total_wall'] / found['stepping_wall']:.1f}x its wall time (goal <= {GOAL:g}x)")
    if found["drawn_by_workers"]:
        out.append(f"  the charts: {found['drawn_by_workers']} figures drawn by chart workers while this process "
                   f"waited (charts' wall time above); the workers' CPU time {found['workers_cpu']:.2f} s "
                   f"(their imports overlap the stepping)")
    else:
        out.append("  the charts: drawn in this process (one CPU available: no chart workers)")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.wait", description=__doc__.splitlines()[0])
    ap.add_argument("--system", default="bed_drive")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--pin", action="store_true", help="run every command on CPU 0 (taskset -c 0)")
    ap.add_argument("--stages", action="store_true", help="also the CPU time of each stage of run --plot")
    args = ap.parse_args(argv)
    print("\n".join(lines(measure(args.system, args.repeat, args.pin), args.pin, args.repeat)))
    if args.stages:
        print("\n".join(stage_lines(stages(args.system, args.pin))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
