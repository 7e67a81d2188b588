"""``python -m harness <command>``: list, show, run, export (SSP), synth, study, scene, sweep.

A failure exits non-zero with a one-line error on stderr and no traceback (``--debug``, anywhere on the line,
shows it).  SIGTERM (``kill``, ``timeout``) interrupts a command as Ctrl-C does, so what it finished is kept
and marked; the exit status is then 143 (130 after Ctrl-C)."""
from __future__ import annotations

import signal
import sys


def _on_sigterm(signum, frame):
    """SIGTERM as an interrupt (:func:`_sigterm_as_interrupt`); a second one while the first's work is saved is
    ignored.  Imports nothing heavy: it may fire inside any import of the start-up."""
    from harness.errors import Terminated

    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    raise Terminated("terminated (SIGTERM)")


if __name__ == "__main__":   # from the first line on: a SIGTERM while the command starts gets the usual message
    from harness.errors import Terminated as _Terminated  # noqa: F401 (imported before the handler can fire)

    signal.signal(signal.SIGTERM, _on_sigterm)

import argparse  # noqa: E402


class _Version(argparse._VersionAction):
    """``--version``: the installed package's version, looked up only when asked for (reading the package
    metadata costs a noticeable part of a short command's start-up)."""

    def __call__(self, parser, namespace, values, option_string=None):
        self.version = f"%(prog)s {_version()}"
        super().__call__(parser, namespace, values, option_string)


# The commands and their one-line help, in the order ``--help`` lists them: the top-level help (and
# ``--version``, a bare ``python -m harness``) is built from this table alone, without importing the commands'
# modules (pandas, scipy, matplotlib: over a second); tests/test_messages.py checks it against the full parser.
COMMANDS = (
    ("list", "list the shipped systems with their descriptions"),
    ("show", "show a system: instances, bonds, scenes and every variable with its unit"),
    ("run", "run a system (name in systems/, a .py file defining SYSTEM, .ssp/.ssd or an OspSystemStructure.xml) and "
            "write its result"),
    ("compare", "two or more designs of a drive side by side: their engineering quantities and charts"),
    ("size", "size one parameter of a drive to an engineering-quantity target"),
    ("modes", "the drive's torsional natural frequencies, mode shapes and exciting orders"),
    ("duty", "the motor's thermal check over a duty cycle: starts and stops per hour"),
    ("export", "write a system as an SSP 1.0 archive (FMUs included), as one co-simulation FMU (.fmu) or as OSP's "
               "OspSystemStructure.xml (--format osp)"),
    ("synth", "mechanism synthesis and analysis tools of the seeds"),
    ("study", "numerical studies (stability, precision)"),
    ("scene", "answer a scene's question with the coarsest adequate model"),
    ("sweep", "parameter sweep on dask.distributed"),
)
TOP_ONLY = ([], ["-h"], ["--help"], ["--version"])   # argument lists the top-level parser alone answers


def build_parser(command: str | None = None, top_only: bool = False) -> argparse.ArgumentParser:
    """The command line's parser; ``command="run"``: with the ``run`` command alone (the same ``run``, its help
    and its errors; the other commands' modules, the studies and the synthesis tools with scipy, are then not
    imported: a run's start-up is shorter by their import time).  ``top_only``: the commands as names with
    their help (:data:`COMMANDS`) and no options, for ``--help``, ``--version`` and a bare command line."""
    import os

    prog = "pressdrive" if os.path.basename(sys.argv[0] or "").startswith("pressdrive") else "python -m harness"
    ap = argparse.ArgumentParser(prog=prog, description="Co-simulation of printing-press drives with FMI 2.0: "
                                 "list, show, run, export (SSP), synth, study, scene, sweep. `pressdrive` and "
                                 "`python -m harness` are the same command.")
    ap.add_argument("--debug", action="store_true",
                    help="show the traceback of a failure (accepted anywhere on the command line)")
    ap.add_argument("--version", action=_Version, version="")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND", required=True)
    if top_only:
        for name, text in COMMANDS:
            sub.add_parser(name, help=text)
        _show_defaults(ap)
        return ap
    if command == "run":
        from harness import run

        run.register(sub)
        _show_defaults(ap)
        _accept_negative_numbers(ap)
        return ap
    from harness import describe, run, ssp, synthesis
    from harness.studies import accuracy, compare, duty, modes, precision, scenes, size, stability, sweep, takeup

    describe.register(sub)        # list, show SYSTEM
    run.register(sub)             # run a system
    compare.register(sub)         # compare X --variant ... --variant ...
    size.register(sub)            # size X --vary I.p --target 'Q <= V'
    modes.register(sub)           # modes X: torsional natural frequencies
    duty.register(sub)            # duty X --starts N --stops N: the motor's thermal check
    ssp.register(sub)             # export a system as SSP
    synthesis.register(sub)       # synth fourbar|groove|sectors|knife
    study = sub.add_parser("study", help="numerical studies (stability, precision)",
                           description="Numerical studies of the co-simulation masters.")
    group = study.add_subparsers(dest="study", metavar="STUDY", required=True)
    stability.register_stability(group)    # study stability two_inertia
    precision.register_precision(group)    # study precision SYSTEM
    accuracy.register(group)               # study accuracy SYSTEM (the cheapest method meeting its accuracy)
    takeup.register(group)                 # study takeup (seed 000's take-up map)
    scenes.register(sub)          # scene X NAME
    sweep.register(sub)           # sweep X --grid spec
    _show_defaults(ap)
    _accept_negative_numbers(ap)
    return ap


def _version() -> str:
    """The installed package's version, from its metadata (one source: pyproject.toml at install time)."""
    from importlib import metadata

    try:
        return metadata.version("pressdrive")
    except metadata.PackageNotFoundError:  # pragma: no cover - run from a tree that was never installed
        return "(not installed)"


class _DefaultsFormatter(argparse.HelpFormatter):
    """Appends "(default: X)" to an option's help unless the help already states its default; a required
    option says so instead (it has none)."""

    def _get_help_string(self, action):
        h = action.help or ""
        if (action.option_strings and "default" not in h.lower() and action.default is not argparse.SUPPRESS
                and not isinstance(action, (argparse._HelpAction, argparse._StoreTrueAction,
                                            argparse._StoreFalseAction, argparse._VersionAction))):
            if action.required:
                h += " (required, no default)"
            else:
                shown = "none" if action.default is None else str(action.default).replace("%", "%%")
                h += f" (default: {shown})"
        return h


def _show_defaults(parser: argparse.ArgumentParser) -> None:
    """Every command's --help shows every option's default (walks the sub-commands)."""
    parser.formatter_class = _DefaultsFormatter
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction):
            for sp in a.choices.values():
                _show_defaults(sp)


def _accept_negative_numbers(parser: argparse.ArgumentParser) -> None:
    """Every command takes a negative number in any notation as a value (``--step -1e-4``, ``--values -1e-3
    0.5``), so it reaches the command's own check and its one-line message: argparse knows ``-1`` and ``-.5``
    only, and takes ``-1e-4`` for an unknown option (walks the sub-commands)."""
    import re

    parser._negative_number_matcher = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|nan)$", re.IGNORECASE)
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction):
            for sp in a.choices.values():
                _accept_negative_numbers(sp)


def _sigterm_as_interrupt():
    """SIGTERM raises :class:`harness.errors.Terminated` (a KeyboardInterrupt) in the main thread, so every
    command keeps its finished work on it as on Ctrl-C; a second SIGTERM while that work is being saved is
    ignored (SIGKILL still ends the process).  Returns the handler it replaced (None off the main thread)."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGTERM, _on_sigterm)


def _debug_anywhere(argv: list[str]) -> tuple[list[str], bool]:
    """``--debug`` taken from any place before ``--`` (argparse accepts it only before the command)."""
    end = argv.index("--") if "--" in argv else len(argv)
    debug = "--debug" in argv[:end]
    return [a for a in argv[:end] if a != "--debug"] + argv[end:], debug


def _command(argv: list[str]) -> str | None:
    """The command word of ``argv`` when every argument before it is ``--debug`` (the only option before a
    command that takes no value); None otherwise (``--help``, ``--version``, no command: the full parser)."""
    for a in argv:
        if a != "--debug":
            return a if not a.startswith("-") else None
    return None


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    argv, debug = _debug_anywhere(argv)
    argv = (["--debug"] if debug else []) + argv
    before = _sigterm_as_interrupt()
    try:
        return _main(argv, debug)
    finally:
        if before is not None:  # main() called in a process that goes on (a test): its handler back
            import signal

            signal.signal(signal.SIGTERM, before)


def _main(argv: list[str], debug: bool) -> int:
    if not debug:
        import warnings

        # warnings (e.g. an unconnected input of a shipped drive) as one line each, without source lines
        warnings.showwarning = lambda message, category, *a, **k: print(
            f"warning: {str(message).splitlines()[0] if str(message) else category.__name__}", file=sys.stderr)
    return _parse_and_run(argv, debug)


def _parse_and_run(argv: list[str], debug: bool) -> int:
    try:
        ap = build_parser(_command(argv), top_only=[a for a in argv if a != "--debug"] in TOP_ONLY)
        args = ap.parse_args(argv)
        _check_out_folder(args)
        return int(args.func(args) or 0)
    except KeyboardInterrupt as e:
        from harness.errors import interruption   # not harness.run: its import may be the one interrupted

        status, how = interruption(e)  # also a run's or study's interrupt re-raised with its status
        print(how, file=sys.stderr)
        return status
    except Exception as e:  # one line, no traceback
        if debug:
            raise
        from harness.errors import HarnessError

        text = str(e).strip().splitlines()[0] if str(e).strip() else ""
        # the toolkit's own errors speak for themselves; anything else is named by its type
        own = isinstance(e, (HarnessError, ValueError, OSError)) and text
        print(f"error: {text}" if own else f"error: {type(e).__name__}: {text}".rstrip(": "), file=sys.stderr)
        return 1


def _check_out_folder(args) -> None:
    """``study ... --out DIR`` and ``scene ... --out DIR``: the folder is made and written to before the work
    (so a study of minutes does not fail on it only when it writes its table)."""
    if args.command in ("study", "scene") and getattr(args, "out", None) is not None:
        from harness.results import check_writable

        check_writable(args.out, "--out", folder=True)


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
    try:
        _status = main()
    except KeyboardInterrupt as _e:   # between the handler and main's own guard
        from harness.errors import interruption

        _status, _how = interruption(_e)
        print(_how, file=sys.stderr)
    _exit(_status)
