"""SSP 1.0 (System Structure and Parameterization): export, import and the start values the export binds.

Split by job; every name below is importable from ``harness.ssp`` itself:

``harness.ssp.export``        :func:`export_ssp` (an .ssp archive of a system, FMUs included), :func:`build_ssd`,
                              :func:`host_step` (the step declared to other hosts) and the ``export`` command;
``harness.ssp.read``          :func:`load_ssp` (an .ssp, .ssd or unpacked folder written by any tool -> System);
``harness.ssp.start_values``  :func:`consistent_inputs` (the connected inputs at the start, from a master's
                              initialization);
``harness.ssp.format``        the namespaces and type names both directions share.

Units and parameter mappings live in :mod:`harness.ssp.values`, the per-instance FMU copies with start values
in :mod:`harness.ssp.start_values`.
"""
from harness.ssp.export import build_ssd, export_ssp, host_step, register
from harness.ssp.format import (FMU_TYPE, OSP_ANNOTATION, OWN_ANNOTATION, PARAMETER_MAPPING_TYPE, PARAMETER_SET,
                                PARAMETER_SET_TYPE)
from harness.ssp.read import NESTED, _Reader, load_ssp
from harness.ssp.start_values import consistent_inputs
from harness.ssp.values import NS, _q

__all__ = ["export_ssp", "build_ssd", "host_step", "load_ssp", "consistent_inputs", "register", "NS", "NESTED",
           "FMU_TYPE", "OSP_ANNOTATION", "OWN_ANNOTATION", "PARAMETER_SET", "PARAMETER_SET_TYPE",
           "PARAMETER_MAPPING_TYPE"]
