"""Running a system: :func:`load`, :func:`simulate` and the CLI command ``python -m harness run``.

The package is split by job; every name is importable from ``harness.run``:

* :mod:`harness.run.systems`: finding a system (:func:`load`, :func:`system_names`, :func:`declared`);
* :mod:`harness.run.parameters`: parameter overrides, FMPy's argument names, ``--set`` values;
* :mod:`harness.run.simulation`: :func:`simulate` (argument checks, the run, the result's assembly),
  :class:`RunOptions`, :func:`simulate_scenario`;
* :mod:`harness.run.interrupts`: :class:`RunWarning` and :class:`RunInterrupted`;
* :mod:`harness.run.cli`: the ``run`` command (:func:`register`, :func:`run_cli`).
"""
from __future__ import annotations

from harness.errors import HarnessError, Terminated, interruption
from harness.fmi import open_instance
from harness.run.interrupts import RunInterrupted, RunWarning
from harness.run.parameters import _ALIASES, _DEPRECATED, _FMPY_ONLY, parse_sets, split_parameters
from harness.run.simulation import RunOptions, column_units, partial_path, simulate, simulate_scenario
from harness.run.systems import declared, load, system_names
from harness.run.cli import register, run_cli

__all__ = ["load", "simulate", "simulate_scenario", "RunOptions", "RunWarning", "RunInterrupted", "Terminated",
           "column_units", "partial_path", "register", "run_cli", "parse_sets", "split_parameters", "declared",
           "system_names", "interruption", "open_instance", "HarnessError", "_ALIASES", "_DEPRECATED",
           "_FMPY_ONLY"]
