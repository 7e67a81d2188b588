"""``python -m harness <command>``: run, export (SSP), synth, study, scene, sweep.

A failure exits non-zero with a one-line error on stderr and no traceback (``--debug`` shows it)."""
from __future__ import annotations

import argparse
import sys


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m harness", description=__doc__.splitlines()[0])
    ap.add_argument("--debug", action="store_true", help="show the traceback of a failure")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND", required=True)
    from harness import run, ssp, synthesis
    from harness.studies import precision, scenes, stability, sweep, takeup

    run.register(sub)             # run a system
    ssp.register(sub)             # export a system as SSP
    synthesis.register(sub)       # synth fourbar|groove|sectors|knife
    study = sub.add_parser("study", help="numerical studies (stability, precision)",
                           description="Numerical studies of the co-simulation masters.")
    group = study.add_subparsers(dest="study", metavar="STUDY", required=True)
    stability.register_stability(group)    # study stability two_inertia
    precision.register_precision(group)    # study precision SYSTEM
    takeup.register(group)                 # study takeup (seed 000's take-up map)
    scenes.register(sub)          # scene X NAME
    sweep.register(sub)           # sweep X --grid spec
    return ap


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    debug = "--debug" in argv
    try:
        ap = build_parser()
        args = ap.parse_args(argv)
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # one line, no traceback
        if debug:
            raise
        text = str(e).strip().splitlines()[0] if str(e).strip() else ""
        print(f"error: {type(e).__name__}: {text}" if text else f"error: {type(e).__name__}", file=sys.stderr)
        return 1


def _exit(status: int) -> None:
    """Leave without interpreter finalisation: pythonfmu 0.7 FMUs run their Python inside this interpreter and
    tearing it down with their instances alive has, rarely, aborted the process after the work was done
    ("corrupted double-linked list"), turning a finished run into exit status 134.  Output is flushed first."""
    import os

    sys.stdout.flush()
    sys.stderr.flush()
    if "PRESSDRIVE_NORMAL_EXIT" in os.environ:
        sys.exit(status)
    os._exit(status)


if __name__ == "__main__":
    _exit(main())
