"""The FMI layer: one checked wrapper per FMI call (:mod:`harness.fmi.fmu`) and the in-process path for
pythonfmu FMUs, the toolkit's and anybody's (:mod:`harness.fmi.inprocess`).  :func:`open_instance` chooses between them."""
from __future__ import annotations

import warnings
from pathlib import Path

from harness.errors import FMUError
from harness.fmi import inprocess
from harness.fmi.cache import model_description
from harness.fmi.fmu import FMU, FMUInstance, Instance, extracted  # Instance: FMUInstance's deprecated name
from harness.fmi.fmu1 import FMU1
from harness.fmi.fmu3 import FMU3
from harness.fmi.me import ModelExchange2, ModelExchange3, SolverSettings

__all__ = ["FMU", "FMU1", "FMU3", "ModelExchange2", "ModelExchange3", "SolverSettings", "FMUInstance", "Instance",
           "open_instance", "extracted", "IN_PROCESS_CHOICES", "InProcessFallback"]

IN_PROCESS_CHOICES = (None, True, False)


class InProcessFallback(UserWarning):
    """A pythonfmu FMU runs through its FMI library because its script does not import in this process."""


def open_instance(path: str | Path, name: str, logging_on: bool = True, in_process: bool | None = None,
                  isolate=None) -> FMUInstance:
    """An instance of the FMU at ``path``, called in-process or through FMI.

    ``in_process``: None (default) runs every pythonfmu FMU in this process
    (:class:`harness.fmi.inprocess.InProcessFMU`: the same slave object its C wrapper would create, called
    without the C round trip; bit-identical and faster) when its script imports here, else through its
    shared library with one :class:`InProcessFallback` warning saying why; every other FMU runs through its
    shared library.  True: every pythonfmu FMU in-process, an import failure is an error.  False: every FMU
    through FMI (the CLI's ``--fmi-only``).  FMI 1.0 co-simulation FMUs run through
    :class:`harness.fmi.fmu1.FMU1`, FMI 3.0 ones (pythonfmu3's too: their slave is an Fmi3Slave, which the
    in-process path does not call) through :class:`harness.fmi.fmu3.FMU3`.

    An FMU runs through its co-simulation interface if it has one, else through its Model Exchange interface
    (:mod:`harness.fmi.me`: integrated by a solver of its own).  That is the one way to choose ME: an SSP
    component with ``implementation="ModelExchange"`` reaches here as a copy of its FMU without the
    co-simulation interface (:func:`harness.fmi.cache.model_exchange_only`), so every layer above (system
    validation, coupling, results) sees the interface that runs.

    ``isolate``: an :class:`harness.fmi.isolated.Isolation` (or what :meth:`Isolation.of` takes): the FMUs it
    applies to (by default every foreign FMU) run in a child process of their own
    (:class:`harness.fmi.isolated.IsolatedInstance`), so a crash or a hang inside a call is one error line."""
    if isolate is not None:
        from harness.fmi.isolated import IsolatedInstance, Isolation

        iso = Isolation.of(isolate)
        if iso is not None and Path(path).is_file() and iso.applies(extracted(path, model_exchange=_me_only(path))[1]):
            return IsolatedInstance(path, name, logging_on, in_process, iso.timeout)
    if in_process not in IN_PROCESS_CHOICES:
        raise FMUError(name, "instantiate", None, None,
                       detail=f"in_process = {in_process!r} is not admissible: must be None, True or False")
    md = model_description(path) if Path(path).is_file() else None
    if md is not None and md.coSimulation is None and md.modelExchange is not None:
        if str(md.fmiVersion).startswith("3"):
            return ModelExchange3(path, name, logging_on)
        if md.fmiVersion != "2.0":
            raise FMUError(name, "instantiate", None, None,
                           detail=f"{Path(path).name}: Model Exchange of FMI {md.fmiVersion} is not supported "
                                  f"(FMI 2.0 and 3.0 only)")
        return ModelExchange2(path, name, logging_on)
    md, unzip_dir = extracted(path)
    if md.fmiVersion == "1.0":
        return FMU1(path, name, logging_on)
    if str(md.fmiVersion).startswith("3"):
        return FMU3(path, name, logging_on)
    if in_process is not False:
        if inprocess.is_pythonfmu(unzip_dir):
            if in_process or inprocess.is_toolkit_fmu(unzip_dir):
                return inprocess.InProcessFMU(path, name, logging_on)
            try:
                cls = inprocess.slave_class(unzip_dir)
            except Exception as e:  # the script needs what this process lacks: the C wrapper may still run it
                warnings.warn(InProcessFallback(
                    f"{Path(path).name} ({name}): its pythonfmu script does not import in this process "
                    f"({type(e).__name__}: {' '.join(str(e).split())}); called through its FMI library"),
                    stacklevel=2)
            else:
                return inprocess.InProcessFMU(path, name, logging_on, cls)
    return FMU(path, name, logging_on)


def _me_only(path) -> bool:
    md = model_description(path)
    return md.coSimulation is None and md.modelExchange is not None


def release(master, fmus: dict) -> None:
    """End a run's FMUs: the master that took them (any :class:`harness.master.Master`) terminates and frees them;
    where none was made (an FMU or the master's constructor failed), each FMU is freed on its own."""
    if master is not None:
        master.terminate()
        master.free()
    else:
        for f in fmus.values():
            f.free()
