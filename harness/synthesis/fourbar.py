"""``synth fourbar``: four-bar synthesis by two extreme positions and kinematic analysis (seed 004).

    synth fourbar --swing DEG --min-transmission DEG [--branch {1,-1}] [--json]
    synth fourbar --analyse --coupler L --frame L --rocker L [--branch {1,-1}] [--optimum] [--json]  (crank = 1)

The equations live in fmus.physics.fourbar_synthesis (``synthesise``, ``analyse``); this module only parses, prints
and turns a linkage that cannot be built into a one-line error (exit code 2).
"""
from __future__ import annotations

import argparse
import json
import sys

from harness.synthesis import fail, summary, typed

_ROWS = (("crank", "crank O2A", ""), ("coupler", "coupler AD", ""), ("frame", "frame O2O5", ""),
         ("rocker", "rocker DO5", ""), ("time_ratio", "time ratio K_px (working share)", ""),
         ("swing_deg", "rocker swing", "deg"), ("min_transmission_deg", "min transmission angle", "deg"),
         ("working_stroke_deg", "working stroke (crank angle)", "deg"),
         ("idle_stroke_deg", "idle stroke (crank angle)", "deg"),
         ("velocity_peak_working", "B working (peak/mean speed)", ""),
         ("velocity_peak_idle", "B idle", ""),
         ("accel_runup_working", "C1 working (run-up)", ""), ("accel_runout_working", "C3 working (run-out)", ""),
         ("accel_runup_idle", "C1 idle (run-up)", ""), ("accel_runout_idle", "C3 idle (run-out)", ""))


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--swing", type=float, metavar="DEG",
                   help="rocker swing to synthesise [deg] (no default: required unless --analyse)")
    p.add_argument("--min-transmission", type=float, metavar="DEG", dest="min_transmission",
                   help="smallest admissible transmission angle [deg] (no default: required unless --analyse)")
    p.add_argument("--analyse", "--analyze", action="store_true", help="analyse given lengths instead (crank = 1)")
    p.add_argument("--coupler", type=float, metavar="L",
                   help="coupler length / crank length (no default: required with --analyse)")
    p.add_argument("--frame", type=float, metavar="L",
                   help="frame length / crank length (no default: required with --analyse)")
    p.add_argument("--rocker", type=float, metavar="L",
                   help="rocker length / crank length (no default: required with --analyse)")
    p.add_argument("--branch", type=int, choices=(1, -1), default=1,
                   help="assembly branch, crank turning CCW (default 1; seed 004's is -1: the small acceleration "
                        "peak of the working stroke at its run-up)")
    p.add_argument("--optimum", action="store_true",
                   help="with --analyse: also the largest time ratio any crank-rocker reaches at this linkage's own "
                        "swing and minimum transmission angle (the synthesis's criterion, seed 004's)")
    p.add_argument("--json", action="store_true", help="print one JSON object")


def register(subparsers) -> argparse.ArgumentParser:
    """Add the ``fourbar`` subcommand to an argparse subparsers object."""
    p = subparsers.add_parser("fourbar", help="four-bar synthesis by two extreme positions / analysis (seed 004)",
                              description=summary(__doc__))
    _add_arguments(p)
    p.set_defaults(func=run)
    return p


def _fail(message: str) -> int:
    return fail("fourbar", message)


def _in_users_words(e, args) -> str:
    """A ParameterError of the synthesis in the words of the command line: the option and the value typed
    (``--swing 200: must be in (0, 180) deg``); a check on the unit crank names the lengths given instead."""
    option = {"swing": "swing", "min_transmission": "min_transmission", "coupler": "coupler", "frame": "frame",
              "rocker": "rocker"}.get(getattr(e, "name", None))
    if option is not None and getattr(args, option, None) is not None:
        return f"{typed(option, getattr(args, option))}: {e.requirement}"
    if args.analyse and hasattr(e, "requirement"):
        given = " ".join(typed(n, getattr(args, n)) for n in ("coupler", "frame", "rocker"))
        return f"{given} (crank = 1): {e.requirement}"
    return str(e)


def run(args) -> int:
    from fmus.physics.base import ParameterError
    from fmus.physics.fourbar_synthesis import analyse, synthesise

    try:
        if args.analyse:
            missing = [n for n in ("coupler", "frame", "rocker") if getattr(args, n) is None]
            if missing:
                return _fail("--analyse needs " + ", ".join(f"--{n}" for n in missing))
            result = analyse(1.0, args.coupler, args.frame, args.rocker, branch=args.branch)
            if args.optimum:
                best = synthesise(result.swing_deg, result.min_transmission_deg, branch=args.branch)
        else:
            if args.swing is None or args.min_transmission is None:
                return _fail("give --swing and --min-transmission (or --analyse with --coupler/--frame/--rocker)")
            result = synthesise(args.swing, args.min_transmission, branch=args.branch)
    except ParameterError as e:
        return _fail(_in_users_words(e, args))
    except ValueError as e:
        return _fail(str(e))
    data = result.as_dict()
    if args.analyse and args.optimum:
        data["optimum"] = best.as_dict()
    if args.json:
        print(json.dumps(data))
        return 0
    title = "four-bar analysis" if args.analyse else (f"four-bar synthesis: swing {args.swing:g} deg, "
                                                       f"min transmission {args.min_transmission:g} deg")
    print(title + " (crank = 1, crank turning CCW, branch %+d)" % data["branch"])
    for key, label, unit in _ROWS:
        print(f"  {label:<34s} {data[key]:>12.6f} {unit}")
    if "optimum" in data:
        o = data["optimum"]
        print(f"  largest K_px at this swing and min transmission angle {o['time_ratio']:12.6f}  (short by "
              f"{o['time_ratio'] - data['time_ratio']:.2g}; its lengths 1 : {o['coupler']:.5f} : {o['frame']:.5f} : "
              f"{o['rocker']:.5f})")
    print("  invariants of each stroke, normalised by its own duration T and swing psi_S (seed 004, Tir):")
    print("    tau = t/T, b = (dpsi/dtau)/psi_S, c = (d2psi/dtau2)/psi_S; B = max b (peak over mean speed),")
    print("    C1 = max |c| before the velocity peak (run-up), C3 = max |c| after it (run-out)")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="synth")
    register(parser.add_subparsers(dest="tool", required=True))
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
