"""Mechanism synthesis tools of the seeds, as ``python -m harness synth <tool>``.

Each tool module exposes ``register(subparsers)`` (adds its subcommand, with ``func`` set to its
``run(args) -> int``); the analysis itself lives in the pure equation layer (fmus.physics).
"""
from __future__ import annotations

import importlib
import sys

TOOLS = ("fourbar", "groove", "sectors", "knife", "carrier")


def summary(doc: str) -> str:
    """A tool's description for ``--help``: the first paragraph of its module docstring, whole (its first
    line alone is cut mid-sentence when the sentence wraps)."""
    return " ".join(doc.strip().split("\n\n")[0].split())


def fail(tool: str, message: str) -> int:
    """Bad input of ``synth TOOL``: one line ``error: synth TOOL: message`` on stderr; exit status 2."""
    print(f"error: synth {tool}: {message}", file=sys.stderr)
    return 2


def typed(name: str, value, unit: str = "") -> str:
    """An input as the user typed it on the command line: ``--min-transmission 80 deg``."""
    shown = f"{value:g}" if isinstance(value, float) else str(value)
    return f"--{name.replace('_', '-')} {shown}" + (f" {unit}" if unit else "")


def register(subparsers) -> None:
    synth = subparsers.add_parser("synth", help="mechanism synthesis and analysis tools of the seeds",
                                  description="Mechanism synthesis and analysis tools of the seeds; bad input "
                                              "is one line on stderr and exit status 2.")
    tools = synth.add_subparsers(dest="tool", metavar="TOOL", required=True)
    for name in TOOLS:
        module = importlib.import_module(f"harness.synthesis.{name}")
        module.register(tools)
        if "func" not in tools.choices[name]._defaults:
            tools.choices[name].set_defaults(func=module.run)


def standalone(register_tool, argv=None) -> int:
    """Run one tool module directly (``python -m harness.synthesis.knife ...``)."""
    import argparse

    ap = argparse.ArgumentParser(prog="synth")
    register_tool(ap.add_subparsers(dest="tool", required=True))
    args = ap.parse_args(argv)
    return args.func(args)
