"""Coupling stability of the masters, split by concern:

* :mod:`~harness.studies.stability.theory`: the two-inertia benchmark's exact one-step map (amplification
  matrices) and its stability boundary;
* :mod:`~harness.studies.stability.measured`: the blow-up criterion, bisection on co-simulation runs, and
  the two-inertia study table and map (theory beside measurement);
* :mod:`~harness.studies.stability.press`: the measured stability maps of the press drives (each drive's
  coupling parameter is its ``System.stability``, declared in ``systems/<name>.py``);
* :mod:`~harness.studies.stability.cli`: the ``study stability`` command.

The public names of all four are importable from here.
"""
from harness.studies.stability.cli import STUDIES, register, register_stability, stability_cli
from harness.studies.stability.measured import (DEFAULT_VALUES, GROWTH_SUFFIXES, STUDY_BASE, STUDY_ZETA, SWEEPS,
                                                growth_ratio, is_unstable, measured_boundary, plot_stability_map,
                                                stability_table, two_inertia_run)
from harness.studies.stability.press import (PRESS_MASTERS, PRESS_STUDIES, PressRun, check_sweep, deviation_ratio,
                                             plot_press_map, press_boundary, press_stability_table)
from harness.studies.stability.press import _with_fmu_dir  # noqa: F401 (used by the tests)
from harness.studies.stability.theory import (INTEGRATORS, MASTER_NAMES, ORDERS, TwoInertia, amplification_matrix,
                                              deflate_rigid, held_input_map, hold_weights, lagrange_weights,
                                              model_substeps, monolithic_matrix, rigid_shift, spectral_radius,
                                              stability_boundary, subsystem_maps)

__all__ = ["TwoInertia", "amplification_matrix", "monolithic_matrix", "spectral_radius", "stability_boundary",
           "measured_boundary", "is_unstable", "growth_ratio", "two_inertia_run", "hold_weights",
           "lagrange_weights", "held_input_map", "subsystem_maps", "model_substeps", "rigid_shift",
           "deflate_rigid", "stability_table", "plot_stability_map", "register", "register_stability",
           "stability_cli", "STUDIES", "STUDY_BASE", "STUDY_ZETA", "SWEEPS", "DEFAULT_VALUES", "GROWTH_SUFFIXES",
           "MASTER_NAMES", "ORDERS", "INTEGRATORS", "PRESS_MASTERS", "PRESS_STUDIES", "PressRun", "press_boundary",
           "press_stability_table", "plot_press_map", "deviation_ratio", "check_sweep"]
