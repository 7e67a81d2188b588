"""``python -m harness list`` and ``show SYSTEM [INSTANCE]``: what a newcomer can run, read from the systems
themselves (their ``SYSTEM`` and their FMUs' modelDescriptions), so the listing cannot go stale.

``list`` prints one line per shipped system with its description; ``show`` prints a system's default
experiment, instances (FMU, fidelity), power bonds, explicit connections and scenes, then per instance its
inputs, outputs and parameters with units (parameters with the value this system gives them).
"""
from __future__ import annotations

import sys
import textwrap

from harness.model import System, _unit, model_description, resolve_fmu
from harness.run import load, system_names

WIDTH = 100


def list_systems() -> list[str]:
    """One line per system in ``systems/``: its name and description."""
    names = system_names()
    pad = max(len(n) for n in names)
    return [f"{n:<{pad}}  {load(n).description or '(no description)'}" for n in names]


def _fidelity(inst, md) -> str:
    if "fidelity" in inst.parameters:
        return str(inst.parameters["fidelity"])
    declared = {v.name: v for v in md.modelVariables}.get("fidelity")
    return str(declared.start) if declared is not None else "-"


def _wrapped(label: str, items: list[str], indent: int) -> list[str]:
    """``label item, item, ...`` wrapped at WIDTH; an item (``name = value unit``) is never split."""
    if not items:
        return []
    first = " " * indent + f"{label:<12}"
    glued = ", ".join(item.replace(" ", "\0") for item in items)
    return [line.replace("\0", " ") for line in textwrap.wrap(
        glued, WIDTH, initial_indent=first, subsequent_indent=" " * len(first), break_on_hyphens=False)]


def _with_unit(v) -> str:
    unit = _unit(v)
    return f"{v.name} [{unit}]" if unit and unit != "1" else v.name


def describe(system: System, only: str | None = None) -> list[str]:
    """The lines of ``show``: the system, then the variables of every instance (of ``only`` if given)."""
    mds = {inst.name: model_description(resolve_fmu(inst.fmu)) for inst in system.instances}
    if only is not None:
        system.instance(only)  # a one-line error listing the instances
    lines = [f"{system.name}: {system.description or '(no description)'}"]
    e = system.experiment
    if e is not None:
        control = f", step control {e.step_control} (tolerance {e.tolerance:g})" if e.step_control else ""
        lines.append(f"default run: stop time {e.stop_time:g} s, step {e.step:g} s, master {e.master}, "
                     f"extrapolation {e.extrapolation}{control}")
    if only is None:
        pad = max(len(i.name) for i in system.instances)
        lines.append("instances (name, FMU, fidelity):")
        lines += [f"  {i.name:<{pad}}  {mds[i.name].modelName:<20} fidelity {_fidelity(i, mds[i.name])}"
                  for i in system.instances]
        if system.bonds:
            lines.append("power bonds (motion out -> motion in):")
            lines += [f"  {b.label}" for b in system.bonds]
        if system.connections:
            lines.append("connections:")
            lines += [f"  {c.source} -> {c.target}" + (f" (x {c.factor:g})" if c.factor != 1.0 else "")
                      for c in system.connections]
        if system.scenes:
            lines.append("scenes (scene SYSTEM NAME):")
            pad_s = max(len(s.name) for s in system.scenes)
            lines += [f"  {s.name:<{pad_s}}  {s.question}" + ("  [default]" if s.name == system.default_scene else "")
                      for s in system.scenes]
        if system.scenarios:
            lines.append("scenarios, transients (run SYSTEM --scenario NAME):")
            pad_s = max(len(s.name) for s in system.scenarios)
            lines += [f"  {s.name:<{pad_s}}  {s.question}" for s in system.scenarios]
    lines.append("variables (parameters with this system's values; set one with --set Instance.name=VALUE):")
    for inst in system.instances:
        if only is not None and inst.name != only:
            continue
        md = mds[inst.name]
        lines.append(f"  {inst.name} ({md.modelName})")
        by = {c: [v for v in md.modelVariables if v.causality == c] for c in ("input", "output", "parameter")}
        lines += _wrapped("inputs:", [_with_unit(v) for v in by["input"]], 4)
        lines += _wrapped("outputs:", [_with_unit(v) for v in by["output"]], 4)
        params = []
        for v in by["parameter"]:
            value = inst.parameters.get(v.name, v.start)
            value = f"{value:.6g}" if isinstance(value, float) else value
            unit = _unit(v)
            params.append(f"{v.name} = {value}" + (f" {unit}" if unit and unit != "1" else ""))
        lines += _wrapped("parameters:", params, 4)
    return lines


def register(subparsers) -> None:
    p = subparsers.add_parser("list", help="list the shipped systems with their descriptions",
                              description="List the systems in systems/ (each runs as `run NAME`), one line each.")
    p.set_defaults(func=lambda args: _print(list_systems()))
    p = subparsers.add_parser(
        "show", help="show a system: instances, bonds, scenes and every variable with its unit",
        description="Show a system: its default run, instances (FMU, fidelity), power bonds, connections and "
                    "scenes, then each instance's inputs, outputs and parameters with units.")
    p.add_argument("system", help="system name in systems/ (see `list`), a .py file defining SYSTEM, or .ssp/.ssd")
    p.add_argument("instance", nargs="?", default=None,
                   help="show only this instance's variables (default: every instance)")
    p.set_defaults(func=lambda args: _print(describe(load(args.system), args.instance)))


def _print(lines: list[str]) -> int:
    sys.stdout.write("\n".join(lines) + "\n")
    return 0


__all__ = ["list_systems", "describe", "register"]
