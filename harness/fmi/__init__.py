"""The FMI layer: one checked wrapper per FMI call (:mod:`harness.fmi.fmu`) and the in-process path for
pythonfmu FMUs (:mod:`harness.fmi.inprocess`).  :func:`open_instance` chooses between them."""
from __future__ import annotations

from pathlib import Path

from harness.errors import FMUError
from harness.fmi import inprocess
from harness.fmi.fmu import FMU, Instance, extracted

__all__ = ["FMU", "Instance", "open_instance", "extracted", "IN_PROCESS_CHOICES"]

IN_PROCESS_CHOICES = (None, True, False)


def open_instance(path: str | Path, name: str, logging_on: bool = True, in_process: bool | None = None) -> Instance:
    """An instance of the FMU at ``path``, called in-process or through FMI.

    ``in_process``: None (default) runs the pythonfmu FMUs of this toolkit (they carry its vendor annotation)
    in this process (:class:`harness.fmi.inprocess.InProcessFMU`, bit-identical to the FMI path and faster) and
    every other FMU through its shared library; True runs every pythonfmu FMU in-process (any other FMU still
    through FMI); False runs everything through FMI."""
    if in_process not in IN_PROCESS_CHOICES:
        raise FMUError(name, "instantiate", None, None,
                       detail=f"in_process = {in_process!r} is not admissible: must be None, True or False")
    if in_process is not False:
        _, unzip_dir = extracted(path)
        if inprocess.is_pythonfmu(unzip_dir) and (in_process or inprocess.is_toolkit_fmu(unzip_dir)):
            return inprocess.InProcessFMU(path, name, logging_on)
    return FMU(path, name, logging_on)
