"""Mechanism synthesis tools of the seeds, as ``python -m harness synth <tool>``.

Each tool module exposes ``register(subparsers)`` (adds its subcommand, with ``func`` set to its
``run(args) -> int``); the analysis itself lives in the pure equation layer (fmus.physics).
"""
from __future__ import annotations

import importlib

TOOLS = ("fourbar", "groove", "sectors", "knife", "carrier")


def register(subparsers) -> None:
    synth = subparsers.add_parser("synth", help="mechanism synthesis and analysis tools of the seeds")
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
