"""FMI 1.0 co-simulation FMUs behind the same :class:`~harness.fmi.fmu.Instance` interface as FMI 2.0.

Other tools' systems still ship FMI 1.0 FMUs (OSP's ``dp-ship`` demo case: five of them, run by libcosim), so
the master takes them as they are, through fmpy's :class:`fmpy.fmi1.FMU1Slave`.  FMI 1.0 co-simulation has
no initialization mode: ``fmiInitializeSlave(tStart, stopTimeDefined, tStop)`` both starts the experiment
and ends the initialization, and no output may be read before it.  So :meth:`FMU1.enter_initialization`
calls it (parameters and start values are set before, as in FMI 2.0), the master's consistent exchange at
the start then reads initialized outputs and sets the inputs for the first step, and
:meth:`FMU1.exit_initialization` has nothing left to do.  FMI 1.0 has no FMU state: such an FMU cannot roll
back (``iterative`` takes each step once with it, step doubling refuses it, naming it).

fmpy's model description already maps FMI 1.0 onto FMI 2.0's words (causality ``parameter``, ``local``), so
everything above this module treats both versions alike.
"""
from __future__ import annotations

from pathlib import Path

from harness.errors import FMUError
from harness.fmi.fmu import ERROR, FMUInstance, RealBlock

def _text(value) -> str:
    """An fmiString as fmpy returns it (bytes, or None for a null pointer) as text: FMI 1.0 strings are
    UTF-8 like FMI 2.0's (str() of the bytes would give "b'hello'", and one connection later "b\"b'hello'\"")."""
    if value is None:
        return ""
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)


_TYPES = {"Real": ("Real", float), "Integer": ("Integer", int), "Enumeration": ("Integer", int),
          "Boolean": ("Boolean", bool), "String": ("String", _text)}  # model type -> (FMI 1.0 call suffix, Python type)


class FMU1(FMUInstance):
    """One instance of an FMI 1.0 co-simulation FMU (module docstring)."""

    path_kind = "fmi1"

    def __init__(self, path: str | Path, name: str, logging_on: bool = True):
        from fmpy.fmi1 import FMU1Slave

        super().__init__(path, name)
        self.can_get_set_state = self.can_serialize = False   # FMI 1.0 co-simulation saves no state
        self.can_interpolate_inputs = False  # the master hands no input derivatives to FMI 1.0 FMUs
        self.max_input_derivative_order = 0
        self._start, self._stop = 0.0, None
        self.check_binary(self.md.coSimulation.modelIdentifier, "fmiInstantiateSlave")
        self._slave = FMU1Slave(guid=self.md.guid, unzipDirectory=str(self.unzip_dir),
                                modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self._call("fmiInstantiateSlave", self._slave.instantiate, loggingOn=False)

    # -- life cycle --------------------------------------------------------------------------------------------
    def setup(self, start_time: float = 0.0, stop_time: float | None = None, tolerance: float | None = None):
        self.time = start_time
        self._start, self._stop = float(start_time), stop_time

    def enter_initialization(self) -> None:
        self._call("fmiInitializeSlave", self._slave.initialize, tStart=self._start, stopTime=self._stop)

    def exit_initialization(self) -> None:
        """Nothing: fmiInitializeSlave ended the initialization (module docstring)."""

    def terminate(self) -> None:
        if not self.failed and self._slave is not None:
            self._call("fmiTerminateSlave", self._slave.terminate)

    def free(self) -> None:
        """Free the instance (the shared library stays loaded, as for FMI 2.0 FMUs)."""
        if self._slave is not None and not self.failed:
            self._slave.fmi1FreeSlaveInstance(self._slave.component)
        self._slave = None

    # -- values ------------------------------------------------------------------------------------------------
    def get(self, block: RealBlock):
        if block.n:
            block.values[:] = self._call("fmiGetReal", self._slave.getReal, block.refs)
        return block.values

    def _write_reals(self, block: RealBlock) -> None:
        self._call("fmiSetReal", self._slave.setReal, block.refs, block.values.tolist())

    def get_list(self, block: RealBlock) -> list:
        return list(self._call("fmiGetReal", self._slave.getReal, block.refs)) if block.n else []

    def set_list(self, block: RealBlock, values: list) -> None:
        if block.n:
            self._call("fmiSetReal", self._slave.setReal, block.refs, list(values))

    def set_input_derivatives(self, block: RealBlock, order: int, values) -> None:
        raise FMUError(self.name, "fmiSetRealInputDerivatives", self.time, ERROR,
                       detail="the master hands no input derivatives to FMI 1.0 FMUs")

    def set_value(self, name: str, value) -> None:
        v, value = self._typed(name, value)
        suffix, _ = _TYPES[v.type]
        self._call(f"fmiSet{suffix}", getattr(self._slave, f"set{suffix}"), [v.valueReference], [value])

    def get_value(self, name: str):
        v = self.var(name)
        suffix, kind = _TYPES[v.type]
        return kind(self._call(f"fmiGet{suffix}", getattr(self._slave, f"get{suffix}"), [v.valueReference])[0])

    # -- stepping ----------------------------------------------------------------------------------------------
    def do_step(self, t: float, h: float, no_prior_state: bool = False) -> None:
        self.time = t
        self._call(f"fmiDoStep(h = {h:.6g} s)", self._slave.doStep, t, h, True)
        self.time = t + h

    def _no_state(self, state=None):
        raise FMUError(self.name, "FMU state", self.time, ERROR, detail="FMI 1.0 FMUs have no FMU state")

    get_state = set_state = free_state = _no_state


__all__ = ["FMU1"]
