"""Running a system: :func:`load`, :func:`simulate` and the CLI command ``python -m harness run``.

The package holds one module per job and re-exports every name the former single module had:

* :mod:`harness.run.systems`: :func:`load` (a name in ``systems/``, a .py file, an .ssp/.ssd, a bare .fmu),
  :func:`system_names`, :func:`declared`;
* :mod:`harness.run.parameters`: :func:`split_parameters`, :func:`parse_sets` and the checks of
  :func:`simulate`'s arguments (FMPy's names);
* :mod:`harness.run.interrupts`: :class:`RunWarning`, :class:`RunInterrupted`;
* :mod:`harness.run.simulation`: :class:`RunOptions`, :func:`simulate`, :func:`simulate_scenario`,
  :func:`column_units`, :func:`partial_path`;
* :mod:`harness.run.cli`: the ``run`` command (:func:`register`, :func:`run_cli`).

Code that replaces a name for a test or a benchmark patches it in the module that looks it up (for example
``harness.run.simulation.open_instance``), not here.
"""

from harness.errors import HarnessError, Terminated, interruption  # noqa: F401 (defined with the errors)
from harness.run.cli import _check_targets, _divergence_hint, _halved, _isolation, _plot, register, run_cli  # noqa: F401
from harness.run.interrupts import RunInterrupted, RunWarning
from harness.run.parameters import (_ALIASES, _DEPRECATED, _FMPY_ONLY, _positive, _renamed,  # noqa: F401
                                    _value, parse_sets, split_parameters)
from harness.run.simulation import (RunOptions, _output_interval, _run, column_units,  # noqa: F401
                                    partial_path, simulate, simulate_scenario)
from harness.run.systems import (_close_match, _fmu_system, _known_systems, _load_file, _system_of,  # noqa: F401
                                 declared, load, system_names)

__all__ = ["load", "simulate", "simulate_scenario", "RunOptions", "RunWarning", "RunInterrupted", "Terminated", "column_units", "partial_path", "register", "run_cli", "parse_sets", "HarnessError"]
