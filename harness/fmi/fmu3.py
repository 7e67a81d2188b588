"""FMI 3.0 co-simulation FMUs behind the same :class:`~harness.fmi.fmu.Instance` interface as FMI 1.0 and 2.0.

The Modelica Reference-FMUs 3.0 and FMUs exported by pythonfmu3 are FMI 3.0; their binaries live in
``binaries/x86_64-linux`` and every call is an ``fmi3*`` function, which fmpy's :class:`fmpy.fmi3.FMU3Slave`
binds.  :func:`harness.fmi.cache.model_description` already gives the description in FMI 2.0's words
(Float64/Float32 are ``Real``, Int8...UInt64 ``Integer``), so everything above this module treats the
versions alike; this wrapper calls each variable by its own FMI 3.0 type (:func:`~harness.fmi.cache.native_types`).

What the master cannot use is refused when the instance is made, in one line naming the variable:

* Clocks (``Clock`` variables; a Scheduled-Execution-only FMU has no co-simulation interface at all and is
  refused by :func:`~harness.fmi.fmu.extracted`): the master has no clocked partitions or event mode;
* arrays of a non-numeric type among the inputs and outputs (String, Boolean, Binary with more than one
  element).  A numeric array is one scalar variable per element (``y[1]``, ``A[1,2]``, 1-based, row-major:
  :func:`harness.fmi.cache.array_elements`): reading an element reads its whole array, setting one sets the
  whole array with the other elements as last set or read (at first their start values).

The co-simulation runs without event mode and without early return (FMI 3.0's basic step mode, as an FMI 2.0
slave runs); an FMU that asks to terminate in ``fmi3DoStep`` raises :class:`~harness.errors.FMUError`
naming the time.  Directional derivatives (fmi3GetDirectionalDerivative, outputs with respect to inputs) where the
``CoSimulation`` element declares ``providesDirectionalDerivatives`` (read here: fmpy 0.3's reader of FMI 3.0
leaves it out).  FMI 3.0 has no input derivatives for co-simulation in the master's sense, so
``can_interpolate_inputs`` is False.
"""
from __future__ import annotations

import math
from ctypes import byref
from pathlib import Path

import numpy as np

from harness.errors import FMUError
from harness.fmi.cache import array_elements, native_types
from harness.fmi.fmu import ERROR, FMUInstance, RealBlock

_INTEGERS = ("Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64")


def _elements(v) -> int:
    """Number of elements of a variable (1 for a scalar; fmpy gives an array's shape, () for a scalar)."""
    shape = getattr(v, "shape", None) or ()
    return math.prod(int(n) for n in shape) if shape else 1


def _declares_directional_derivatives(unzip_dir: Path) -> bool:
    """``CoSimulation/@providesDirectionalDerivatives`` of an extracted FMI 3.0 FMU."""
    import xml.etree.ElementTree as ET

    try:
        cs = ET.parse(Path(unzip_dir) / "modelDescription.xml").getroot().find("CoSimulation")
    except (OSError, ET.ParseError):
        return False
    return cs is not None and cs.get("providesDirectionalDerivatives") in ("true", "1")


class FMU3(FMUInstance):
    """One instance of an FMI 3.0 co-simulation FMU (module docstring)."""

    path_kind = "fmi3"

    def __init__(self, path: str | Path, name: str, logging_on: bool = True, model_exchange: bool = False):
        """``model_exchange``: instantiate through the Model Exchange interface (fmpy's FMU3Model), for
        :class:`harness.fmi.me.ModelExchange3`."""
        from fmpy.fmi3 import FMU3Model, FMU3Slave

        super().__init__(path, name, model_exchange)
        self.native = native_types(self.md)
        clocks = [n for n, t in self.native.items() if t == "Clock"]
        if clocks:
            raise FMUError(name, "instantiate", None, None,
                           detail=f"{self.path.name} declares Clock variables ({', '.join(clocks[:4])}): FMI 3.0 "
                                  f"clocks are not supported")
        arrays = [f"{v.name} {tuple(v.shape)}" for v in self.md.modelVariables
                  if v.causality in ("input", "output") and _elements(v) > 1]
        if arrays:
            raise FMUError(name, "instantiate", None, None,
                           detail=f"{self.path.name}: array {'inputs/outputs' if len(arrays) > 1 else 'input/output'} "
                                  f"{', '.join(arrays[:4])}: FMI 3.0 arrays of this type are not supported "
                                  f"(numeric arrays run as one variable per element)")
        self._elements = array_elements(self.md)
        self._arrays: dict[int, list] = {}   # array value reference -> its values as last set or read
        self.can_interpolate_inputs = False
        self.max_input_derivative_order = 0
        self.provides_directional_derivative = not model_exchange and _declares_directional_derivatives(self.unzip_dir)
        self._start, self._stop, self._tolerance = 0.0, None, None
        self._states: list = []
        self._float32 = any(t == "Float32" for t in self.native.values())
        cs = self.md.modelExchange if model_exchange else self.md.coSimulation
        self.check_binary(cs.modelIdentifier, "fmi3InstantiateModelExchange" if model_exchange
                          else "fmi3InstantiateCoSimulation")
        if model_exchange:
            self._slave = FMU3Model(guid=self.md.guid, unzipDirectory=str(self.unzip_dir),
                                    modelIdentifier=self.md.modelExchange.modelIdentifier, instanceName=name)
            self._call("fmi3InstantiateModelExchange", self._slave.instantiate, loggingOn=logging_on,
                       logMessage=self._log_message)
        else:
            self._slave = FMU3Slave(guid=self.md.guid, unzipDirectory=str(self.unzip_dir),
                                    modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
            self._call("fmi3InstantiateCoSimulation", self._slave.instantiate, loggingOn=logging_on,
                       logMessage=self._log_message)
        self._c = self._slave.component

    def _log_message(self, environment, status, category, message) -> None:
        text = message.decode("utf-8", "replace") if message else ""
        self._logged(status, category.decode("utf-8", "replace") if category else "", text)

    # -- life cycle --------------------------------------------------------------------------------------------
    def setup(self, start_time: float = 0.0, stop_time: float | None = None, tolerance: float | None = None):
        """FMI 3.0 has no fmi3SetupExperiment: the values go to fmi3EnterInitializationMode."""
        self.time = start_time
        self._start, self._stop, self._tolerance = float(start_time), stop_time, tolerance

    def enter_initialization(self) -> None:
        self._call("fmi3EnterInitializationMode", self._slave.enterInitializationMode,
                   tolerance=self._tolerance, startTime=self._start, stopTime=self._stop)

    def exit_initialization(self) -> None:
        self._call("fmi3ExitInitializationMode", self._slave.exitInitializationMode)

    def terminate(self) -> None:
        if not self.failed and self._c:
            self._call("fmi3Terminate", self._slave.terminate)

    def free(self) -> None:
        """Free the instance and its saved states (the shared library stays loaded, as for FMI 2.0)."""
        if self._c and not self.failed:
            for s in self._states:
                self._slave.fmi3FreeFMUState(self._c, byref(s))
            self._states.clear()
            self._slave.fmi3FreeInstance(self._c)
        self._c = None

    # -- values ------------------------------------------------------------------------------------------------
    def _reals(self, function: str, block: RealBlock) -> None:
        """fmi3GetFloat64 / fmi3SetFloat64 on the block's buffer; Float32 variables one by one."""
        if self._elements and any(r in self._elements for r in block.refs):
            for i, (n, r) in enumerate(zip(block.names, block.refs)):
                if function.startswith("fmi3Get"):
                    block.buf[i] = self._read(n, r)
                else:
                    self._write(n, r, block.buf[i])
            return
        if not self._float32 or all(self.native[n] == "Float64" for n in block.names):
            self._call(function, getattr(self._slave, function), self._c, block.vr, block.n, block.buf, block.n)
            return
        for i, (n, r) in enumerate(zip(block.names, block.refs)):
            kind = self.native[n]
            if function.startswith("fmi3Get"):
                block.buf[i] = self._call(f"fmi3Get{kind}", getattr(self._slave, f"get{kind}"), [r])[0]
            else:
                self._call(f"fmi3Set{kind}", getattr(self._slave, f"set{kind}"), [r], [block.buf[i]])

    def _read(self, name: str, ref: int):
        """One scalar or array element (:func:`harness.fmi.cache.array_elements`) by its FMI 3.0 type."""
        kind = self.native[name]
        kind = "Int64" if kind == "Enumeration" else kind
        e = self._elements.get(ref)
        if e is None:
            return self._call(f"fmi3Get{kind}", getattr(self._slave, f"get{kind}"), [ref])[0]
        values = self._call(f"fmi3Get{kind}", getattr(self._slave, f"get{kind}"), [e.array], e.size)
        self._arrays[e.array] = list(values)
        return values[e.index]

    def _write(self, name: str, ref: int, value) -> None:
        """Set one scalar or array element: an element sets its whole array (the other elements as last set or
        read, else their start values)."""
        kind = self.native[name]
        kind = "Int64" if kind == "Enumeration" else kind
        e = self._elements.get(ref)
        if e is None:
            self._call(f"fmi3Set{kind}", getattr(self._slave, f"set{kind}"), [ref], [value])
            return
        values = self._arrays.get(e.array)
        if values is None:
            values = self._array_starts(e.array, kind)
        values[e.index] = value
        self._arrays[e.array] = values
        self._call(f"fmi3Set{kind}", getattr(self._slave, f"set{kind}"), [e.array], values)

    def _array_starts(self, array: int, kind: str) -> list:
        conv = float if kind.startswith("Float") else int
        starts = [None] * next(e.size for e in self._elements.values() if e.array == array)
        for v in self.md.modelVariables:
            e = self._elements.get(v.valueReference)
            if e is not None and e.array == array:
                starts[e.index] = conv(v.start) if v.start is not None else conv(0)
        return starts

    def get(self, block: RealBlock):
        if block.n:
            self._reals("fmi3GetFloat64", block)
        return block.values

    def _write_reals(self, block: RealBlock) -> None:
        self._reals("fmi3SetFloat64", block)

    def get_list(self, block: RealBlock) -> list:
        if not block.n:
            return []
        self._reals("fmi3GetFloat64", block)
        return block.buf[:block.n]

    def set_list(self, block: RealBlock, values: list) -> None:
        if block.n:
            block.buf[:block.n] = values
            self._reals("fmi3SetFloat64", block)

    def set_input_derivatives(self, block: RealBlock, order: int, values) -> None:
        raise FMUError(self.name, "set input derivatives", self.time, ERROR,
                       detail="the master hands no input derivatives to FMI 3.0 FMUs")

    def _native(self, name: str):
        v = self.var(name)
        if _elements(v) > 1:
            raise FMUError(self.name, "set", self.time, None,
                           detail=f"{name} is an array {tuple(v.shape)}: FMI 3.0 arrays are not supported "
                                  f"(only scalars)")
        kind = self.native[name]
        return v, ("Int64" if kind == "Enumeration" else kind)

    def set_value(self, name: str, value) -> None:
        """Set one variable of any type; ``value`` is converted to its type (bytes for Binary)."""
        v, kind = self._native(name)
        if kind == "Binary":
            value = value if isinstance(value, bytes) else str(value).encode()
        else:
            v, value = self._typed(name, value)
        self._write(name, v.valueReference, value)

    def get_value(self, name: str):
        """Read one variable: float (Float64/32), int (Int*/UInt*, Enumeration), bool, str, bytes (Binary)."""
        v, kind = self._native(name)
        value = self._read(name, v.valueReference)
        if kind in ("Float64", "Float32"):
            return float(value)
        if kind in _INTEGERS:
            return int(value)
        if kind == "Boolean":
            return bool(value)
        return value

    def directional_derivative(self, unknowns: RealBlock, knowns: RealBlock, seed):
        """fmi3GetDirectionalDerivative: sum_j d unknowns_i / d knowns_j * seed_j at the current time (scalar
        outputs, inputs); refused in one line for an FMU that does not declare it."""
        self._directional_refused("fmi3GetDirectionalDerivative")
        return np.array(self._call("fmi3GetDirectionalDerivative", self._slave.getDirectionalDerivative,
                                   unknowns.refs, knowns.refs, [float(s) for s in seed]), dtype=float)

    # -- stepping ----------------------------------------------------------------------------------------------
    def do_step(self, t: float, h: float, no_prior_state: bool = False) -> None:
        self.time = t
        _, terminate, _, _ = self._call(f"fmi3DoStep(h = {h:.6g} s)", self._slave.doStep, t, h, no_prior_state)
        if terminate:
            raise FMUError(self.name, f"fmi3DoStep(h = {h:.6g} s)", t, None,
                           detail=f"the FMU asked to terminate the simulation at t = {t + h:.6g} s")
        self.time = t + h

    # -- FMU state (rollback) ----------------------------------------------------------------------------------
    def get_state(self, state=None):
        """fmi3GetFMUState; pass a state returned before to overwrite it (no new allocation)."""
        from fmpy.fmi3 import fmi3FMUState

        if state is None:
            state = fmi3FMUState()
            self._states.append(state)
        self._call("fmi3GetFMUState", self._slave.fmi3GetFMUState, self._c, byref(state))
        return state

    def set_state(self, state) -> None:
        self._call("fmi3SetFMUState", self._slave.fmi3SetFMUState, self._c, state)

    def free_state(self, state) -> None:
        self._call("fmi3FreeFMUState", self._slave.fmi3FreeFMUState, self._c, byref(state))
        self._states = [s for s in self._states if s is not state]

    def serialize_state(self, state) -> bytes:
        from ctypes import c_size_t, create_string_buffer

        if not self.can_serialize:
            return super().serialize_state(state)
        size = c_size_t()
        self._call("fmi3SerializedFMUStateSize", self._slave.fmi3SerializedFMUStateSize, self._c, state, byref(size))
        buf = create_string_buffer(size.value)
        self._call("fmi3SerializeFMUState", self._slave.fmi3SerializeFMUState, self._c, state, buf, size)
        return buf.raw

    def deserialize_state(self, data: bytes):
        from ctypes import create_string_buffer

        from fmpy.fmi3 import fmi3FMUState

        if not self.can_serialize:
            return super().deserialize_state(data)
        state = fmi3FMUState()
        self._call("fmi3DeserializeFMUState", self._slave.fmi3DeserializeFMUState, self._c,
                   create_string_buffer(data, len(data)), len(data), byref(state))
        self._states.append(state)
        return state


__all__ = ["FMU3"]
