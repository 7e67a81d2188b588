"""The command ``python -m harness run`` (:mod:`harness.run`): its parser (:func:`register`) and
:func:`run_cli`, which checks the targets, runs, writes the result, charts and report, and prints one line."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

from harness.errors import HarnessError, SystemDescriptionError
from harness.master import MASTERS
from harness.reporting.quantities import json_path
from harness.run.interrupts import RunInterrupted, RunWarning
from harness.run.systems import load
from harness.run.parameters import parse_sets
from harness.run.simulation import RunOptions, partial_path, simulate, simulate_scenario


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "run", help="run a system (name in systems/, a .py file defining SYSTEM, .ssp/.ssd or an OspSystemStructure.xml) "
                    "and write its result",
        description="Co-simulate a system and write the result as CSV or Parquet (time in s, one column per "
                    "Instance.variable). --out and --plot are checked before the run. A run that stops early "
                    "(divergence, FMU failure, Ctrl-C, SIGTERM) writes what it computed to OUT.partial.csv and "
                    "its chart to DIR/<system>.partial.png instead, never over a complete result, says so on "
                    "stderr in one line and exits 1 (130 after Ctrl-C, 143 after SIGTERM). The options are "
                    "those of harness.simulate(): --start-time is start_time, --set fills start_values, "
                    "--output is output, --input is input.")
    p.add_argument("system", help="system name in systems/ (e.g. bed_drive; `list` shows them), a .py file "
                                  "defining SYSTEM, an .ssp/.ssd file or an OspSystemStructure.xml (or its folder)")
    p.add_argument("--start-time", type=float, default=None, metavar="SECONDS",
                   help="start time [s] (default: the system's default experiment, else 0)")
    p.add_argument("--stop-time", type=float, default=None, metavar="SECONDS",
                   help="stop time [s] (default: the system's default experiment)")
    p.add_argument("--step", "--step-size", type=float, default=None, metavar="SECONDS",
                   help="communication step [s] (default: the system's default experiment, else "
                        "--output-interval)")
    p.add_argument("--output-interval", type=float, default=None, metavar="SECONDS",
                   help="record the result every this often, a whole multiple of the step (default: every "
                        "communication step)")
    p.add_argument("--master", default=None, metavar="NAME",
                   help=f"{', '.join(MASTERS)} (default: the system's, else jacobi)")
    p.add_argument("--extrapolation", type=int, default=None, choices=(0, 1, 2),
                   help="input extrapolation order (default: the system's, else 0 = hold)")
    p.add_argument("--step-control", default=None, choices=("none", "richardson", "ecco"),
                   help="step control (default: the system's, else none = fixed step)")
    p.add_argument("--tolerance", type=float, default=None, metavar="TOL",
                   help="relative tolerance [-] of step control and iteration (default: the system's, else none)")
    p.add_argument("--set", action="append", default=[], metavar="Instance.param=VALUE",
                   help="start value of a parameter, in its declared unit (repeatable; `show SYSTEM` lists "
                        "them; default: the system's values)")
    p.add_argument("--output", action="append", default=None, metavar="Instance.variable",
                   help="record only these variables (repeatable; default: every output)")
    p.add_argument("--input", "--input-file", type=Path, default=None, metavar="FILE.csv",
                   help="input signals: a CSV file with a 'time' column [s] and one column per free input "
                        "Instance.variable, interpolated as FMPy does (continuous Real inputs linearly, others "
                        "held; two rows at one time are a step); checked before the run (default: none, free "
                        "inputs keep their start values)")
    p.add_argument("--scenario", default=None, metavar="NAME|FILE",
                   help="run a transient: one of the drive's scenarios (`show SYSTEM` lists them: startup, "
                        "speed_change, estop, jam) or a .yaml/.json scenario file; its parameters, input changes "
                        "and stop time apply (--set and --stop-time override them) and its transient quantities "
                        "are printed and written beside the result as FILE.transient.json (default: none)")
    p.add_argument("--out", type=Path, default=None, metavar="FILE",
                   help="write the result to this file: .csv, or .parquet when pyarrow or fastparquet is "
                        "installed, and the drive's engineering quantities beside it (FILE.quantities.json, "
                        "x.csv -> x.quantities.json); its folder is made if missing, and checked before the run "
                        "(default: not written)")
    p.add_argument("--units", action="store_true",
                   help="CSV: write a second header row with each column's unit (read it with "
                        "pandas.read_csv(FILE, header=[0, 1], index_col=0); Parquet keeps the units in its "
                        "metadata); default: names only")
    p.add_argument("--plot", type=Path, default=None, metavar="DIR",
                   help="write charts of the run, named after --out (x.csv -> DIR/x.png; without --out after "
                        "the system, <system>[_<scenario>].png): the signals over time and, where the system "
                        "declares its crank angle, DIR/x_cycle.png (over the last complete crank revolution) and "
                        "DIR/x_polar.png (joint forces against the crank angle); a stop's DIR/x_stop.png; "
                        "<name>.partial.png for a run that stopped early (default: no chart)")
    p.add_argument("--svg", action="store_true",
                   help="with --plot: also write each chart as SVG (vector, for a document) beside its PNG "
                        "(default: PNG only; the SVG is a second drawing of each chart)")
    p.add_argument("--report", type=Path, default=None, metavar="FILE.html",
                   help="write one self-contained HTML page of the run to hand on: its engineering quantities, "
                        "charts (inline), the drive (instances, fidelities, parameters changed from their "
                        "defaults), the method with the drive's declared accuracy, versions and run time; checked "
                        "before the run (default: none)")
    p.add_argument("--limits", type=Path, default=None, metavar="FILE.yaml",
                   help="judge the run's quantities against limits: a YAML mapping 'quantity: \"<= VALUE\"' (the "
                        "--target syntax of size); each is marked pass or FAIL in the printed table, the JSON "
                        "(FILE.limits.json beside --out) and the report; exit status 3 after writing everything "
                        "when any limit fails (default: no limits)")
    p.add_argument("--quiet-quantities", action="store_true",
                   help="do not print the table of the drive's engineering quantities after the run (default: "
                        "printed; with --out they are written beside the result as FILE.quantities.json "
                        "either way)")
    p.add_argument("--fmi-only", action="store_true",
                   help="call every FMU through its FMI library (default: pythonfmu FMUs, the toolkit's and "
                        "others', are called in this process: the same results bit for bit, faster)")
    p.add_argument("--isolate", nargs="?", const="foreign", default=None, choices=("foreign", "all"),
                   help="run every foreign FMU (not built by this toolkit; 'all': every FMU) in a child process "
                        "of its own: a crash or a hang inside one of its calls stops the run in one line naming "
                        "the instance, the FMI call and the time, and the rows computed so far are kept "
                        "(default: every FMU in this process)")
    checkpoints = {   # option: (type, metavar, help)
        "--checkpoint": (Path, "FILE", "write the whole run's state to FILE (every FMU's serialized state, the "
                                       "master's, the rows so far) at --checkpoint-at, and run on; `run SYSTEM "
                                       "--from-checkpoint FILE` continues from it, bit for bit (default: none)"),
        "--checkpoint-at": (float, "SECONDS", "with --checkpoint: the time [s] (the first communication point at "
                                              "or after it; default: the stop time)"),
        "--from-checkpoint": (Path, "FILE", "continue the run from a checkpoint FILE of the same system, toolkit "
                                            "and FMUs, with the same options (--set values that differ are set at "
                                            "its time); the result holds its rows and the new ones (default: start "
                                            "from the beginning)")}
    for option, (kind, metavar, text) in checkpoints.items():
        p.add_argument(option, type=kind, default=None, metavar=metavar, help=text)
    p.add_argument("--isolate-timeout", type=float, default=None, metavar="SECONDS",
                   help="with --isolate: the longest one FMU call may take before its process is killed and "
                        "the run stops (default: 60 s)")
    p.set_defaults(func=run_cli)


def _check_targets(args) -> None:
    """Every file the run will write, checked before it starts (format, folder made, writable): a run is
    never computed for a result that could not be kept."""
    from harness.results import check_writable, result_format

    if args.out is not None:
        result_format(args.out)
        check_writable(args.out, "--out")
    if getattr(args, "checkpoint", None) is not None:
        check_writable(args.checkpoint, "--checkpoint")
    elif getattr(args, "checkpoint_at", None) is not None:
        raise HarnessError(f"--checkpoint-at {args.checkpoint_at:g} needs --checkpoint FILE to write to")
    if args.plot is not None:
        check_writable(args.plot, "--plot", folder=True)
    elif getattr(args, "svg", False):
        raise HarnessError("--svg needs --plot DIR: the SVG is written beside each chart's PNG")
    if getattr(args, "report", None) is not None:
        from harness.reporting.htmlreport import check_report_path

        check_report_path(args.report)


def _plot(system, df, folder: Path, svg: bool = False, stem: str | None = None) -> list[Path]:
    """The run's charts in ``folder`` (the PNGs are returned; ``svg``: also as SVG); an incomplete run's under
    ``<name>.partial.png`` (``.svg``), so they never replace the charts of a complete run (drawn beside,
    renamed)."""
    import os
    import tempfile

    from harness.reporting.charts import plot_result

    if df.attrs.get("complete", True):
        return [p for p in plot_result(system, df, folder, svg, stem) if p.suffix == ".png"]
    with tempfile.TemporaryDirectory(dir=folder, prefix=".partial-chart-") as tmp:
        paths = []
        for drawn in plot_result(system, df, tmp, svg, stem):
            paths.append(Path(folder) / f"{drawn.stem}.partial{drawn.suffix}")
            os.replace(drawn, paths[-1])
    return [p for p in paths if p.suffix == ".png"]


def _divergence_hint(a: dict) -> str:
    """What to change after a diverged run, from the run itself: a smaller step (or tolerance, under step
    control) and the interface-Jacobian master, whose implicit coupling is stable where a stiff mode spans FMUs
    (it needs FMUs that can roll back; it says so in one line if one cannot)."""
    if a.get("step_control") not in (None, "none") and a.get("tolerance") is not None:
        first = f"lower the tolerance (now {a['tolerance']:g})"
    else:
        first = f"reduce the step (now {a['step']:g} s)"
    better = {m: "jacobian" for m in ("jacobi", "jacobi-sampled", "gauss-seidel", "iterative")}  # implicit
    nxt = better.get(a.get("master"))
    return first + (f" or use --master {nxt}" if nxt else "")


def run_cli(args) -> int:
    system = load(args.system)  # a wrong name first: no folder is made for it
    _check_targets(args)
    args.limit_list = _read_limits(system, args)
    return _run(system, args)


def _read_limits(system, args) -> list:
    """The ``--limits`` file read and, in a plain run (whose quantity names are known before it), its names
    checked: refused in one line before the run."""
    if getattr(args, "limits", None) is None:
        return []
    from harness.reporting import limits

    found = limits.read(args.limits)
    if not getattr(args, "scenario", None):
        limits.check_names(found, expected_names(system), f"limits file {args.limits}", f"drive {system.name}")
    return found


def expected_names(system) -> list[str]:
    """The names of the quantities a plain run of ``system`` gives (from an empty result)."""
    import pandas as pd

    from harness.reporting.quantities import quantities

    return quantities(system, pd.DataFrame(index=pd.Index([], name="time", dtype=float))).names


def _judge(args, df, out) -> tuple[str, bool]:
    """The ``--limits`` verdicts on the run's quantities: marked in its tables, written beside ``out``; (the
    printed table, whether any failed)."""
    from harness.reporting import limits

    a = df.attrs
    tables = ([(a["scenario"], a["transient"])] if a.get("transient") is not None else []) + [("steady",
                                                                                                a["quantities"])]
    verdicts = limits.judge(args.limit_list, tables)
    for where, q in tables:
        limits.mark(q, verdicts, where)
    a["limits"] = verdicts
    if out is not None:
        limits.write_json(verdicts, str(args.limits), limits.json_path(out))
    return limits.table(verdicts, f"limits of {args.limits}"), any(not v.passed for v in verdicts)


def _run(system, args) -> int:
    status = 0
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RunWarning)  # the CLI reports a stop itself, in one line
            settings = dict(start_time=args.start_time, stop_time=args.stop_time, step=args.step,
                            output_interval=getattr(args, "output_interval", None),
                            input=getattr(args, "input", None), master=args.master,
                            extrapolation=args.extrapolation, step_control=args.step_control,
                            tolerance=args.tolerance, start_values=parse_sets(args.set), output=args.output,
                            options=RunOptions(progress=None, in_process=False if args.fmi_only else None,
                                               isolate=_isolation(args)),
                            on_error="return", from_checkpoint=getattr(args, "from_checkpoint", None))
            if getattr(args, "checkpoint", None) is not None:
                settings["checkpoint"] = (args.checkpoint, args.checkpoint_at)
            if getattr(args, "scenario", None):
                df = simulate_scenario(system, args.scenario, **settings)
            else:
                df = simulate(system, **settings)
    except RunInterrupted as e:
        df, status = e.partial, e.status
    a = df.attrs
    if a.get("bad_input"):  # a refused parameter: nothing was computed, nothing is written
        print(f"error: {a['error']}", file=sys.stderr)
        return 1
    out = args.out
    if out is not None and not a["complete"]:
        out = partial_path(out)
    judged, failed = _judge(args, df, out) if getattr(args, "limit_list", None) else ("", False)
    if out is not None:
        from harness.results import write_result

        write_result(df, out, units=getattr(args, "units", False))
        if a["quantities"].rows:
            a["quantities"].write_json(json_path(out))
        if a.get("transient") is not None and a["transient"].rows:
            a["transient"].write_json(out.with_name(f"{out.stem}.transient.json"))
    where = f"wrote {out}" if out is not None else "no --out given, result not written"
    if (a.get("checkpoint") or {}).get("time") is not None:
        where += f"; checkpoint {a['checkpoint']['path']} at t = {a['checkpoint']['time']:.9g} s"
    charts = None
    if args.plot is not None and len(df):
        if a.get("scenario"):  # a transient's charts beside the plain run's, not over them
            import dataclasses

            system = dataclasses.replace(system, name=f"{system.name}_{a['scenario']}")
        charts = _plot(system, df, args.plot, getattr(args, "svg", False),
                       stem=Path(args.out).stem if args.out is not None else None)
        where += "; chart " + ", ".join(str(p) for p in charts)
        from harness.reporting.charts import cycle_chart_missing

        missing = cycle_chart_missing(system, df) if system.chart is not None else ""
        if missing:  # a drive that has a cycle chart says why this run has none
            where += f"; no cycle chart: {missing}"
    if getattr(args, "report", None) is not None:
        from harness.reporting.htmlreport import write_run_report

        page = args.report if a["complete"] else partial_path(args.report)   # never over a complete run's page
        where += f"; report {write_run_report(system, df, page, charts)}"
    if not a["complete"]:
        hint = f"; {_divergence_hint(a)}" if a.get("diverged") or a.get("blew_up") else ""
        print(f"error: {a['error']}; {len(df)} points to t = {df.index[-1] if len(df) else 0:.6g} s kept, "
              f"{'INCOMPLETE result ' + where if out is not None else where}{hint}", file=sys.stderr)
        return status or 1
    if a.get("suspect"):
        print(f"warning: {a['suspect']}", file=sys.stderr)
    print(f"{a['system']}: {len(df)} points to t = {df.index[-1] if len(df) else 0:.6g} s, master {a['master']}, "
          f"{a['steps']} steps{_halved(a)} in {a['wall_time']:.3g} s; {where}")
    if not getattr(args, "quiet_quantities", False) and a["quantities"].rows:
        print(a["quantities"].table())
    if a.get("transient") is not None:
        print(a["transient"].table())
    if judged:
        print(judged)
    if failed:
        from harness.reporting.limits import FAILED

        return FAILED
    return 0


def _isolation(args):
    """The run's isolation from ``--isolate [foreign|all]`` and ``--isolate-timeout`` (None: none)."""
    which = getattr(args, "isolate", None)
    timeout = getattr(args, "isolate_timeout", None)
    if which is None:
        if timeout is not None:
            raise SystemDescriptionError(f"--isolate-timeout {timeout:g} needs --isolate")
        return None
    from harness.fmi.isolated import DEFAULT_TIMEOUT, Isolation

    return Isolation(which, DEFAULT_TIMEOUT if timeout is None else timeout)


def _halved(a: dict) -> str:
    """' (N taken in halves, ...)' where the jacobian master halved steps (harness.master.jacobian.needs_halving)."""
    n = a.get("halved_steps") or 0
    return f" ({n} taken again in halves where the coupling's correction did not converge)" if n else ""
