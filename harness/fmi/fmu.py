"""A thin, checked wrapper over fmpy's low-level FMI 2.0 co-simulation interface (:class:`FMU`).

* The FMU archive is extracted once per process (cached by path and modification time) and its shared
  library stays loaded for the life of the process: pythonfmu FMUs run Python inside the process, and
  unloading and reloading their library is neither cheap nor safe.  ``free()`` frees the instance only.
* Value references are resolved once (:meth:`FMU.reals` returns a :class:`RealBlock`: the references and a
  preallocated value buffer as ctypes arrays with a numpy view); get/set of reals are one C call on those
  buffers, without per-call allocation.
* Every FMI status is checked; anything but fmi2OK/fmi2Warning raises :class:`~harness.errors.FMUError`
  naming the instance, the FMI call and the time, with the last error message the FMU logged (pythonfmu
  reports a Python exception as fmi2Fatal with the text only in the log).  fmi2Discard from fmi2DoStep raises
  :class:`~harness.errors.StepDiscarded`.
* Directional derivatives (:meth:`Instance.directional_derivative`): d outputs / d inputs at the current time,
  what FMI co-simulation defines fmi2GetDirectionalDerivative for, where the FMU declares
  ``providesDirectionalDerivative``; an FMU that does not is refused in one line (the master then perturbs).

The version-neutral base (:class:`~harness.fmi.instance.Instance`, :func:`~harness.fmi.instance.extracted`,
:class:`~harness.fmi.instance.RealBlock`), the status codes (:mod:`harness.fmi.status`), the process-wide
logger proxy (:mod:`harness.fmi.log_routing`) and the toolkit annotation (:mod:`harness.fmi.annotation`) live
in modules of their own; every name is importable from here as before.
"""
from __future__ import annotations

from ctypes import byref, c_char_p, c_double, c_int, c_size_t, c_uint, create_string_buffer
from pathlib import Path

import numpy as np
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2FMUstate

from harness.errors import FMUError
from harness.fmi.annotation import advanced_positions, toolkit_annotation  # noqa: F401 (public here too)
from harness.fmi.cache import cache_dir, model_description, unzipped  # noqa: F401 (public here too)
from harness.fmi.instance import FMUInstance, Instance, RealBlock, extracted  # noqa: F401 (public here too)
from harness.fmi.log_routing import _BY_NAME, _CALLBACKS, _install_proxy
from harness.fmi.status import DISCARD, ERROR, FATAL, OK, PENDING, WARNING  # noqa: F401 (public here too)

_LEAKED: list = []  # instances that failed and are deliberately never freed (see FMU.free)


class FMU(FMUInstance):
    """One instance of an FMI 2.0 co-simulation FMU, called through its shared library (fmi2* functions)."""

    def __init__(self, path: str | Path, name: str, logging_on: bool = True, model_exchange: bool = False):
        """``model_exchange``: instantiate through the Model Exchange interface (fmpy's FMU2Model, which binds
        the ME functions too), for :class:`harness.fmi.me.ModelExchange2`."""
        super().__init__(path, name, model_exchange)
        self._states: list = []
        cs = self.md.modelExchange if model_exchange else self.md.coSimulation
        self.check_binary(cs.modelIdentifier, "fmi2Instantiate")
        if model_exchange:
            from fmpy.fmi2 import FMU2Model

            self._slave = FMU2Model(guid=self.md.guid, unzipDirectory=str(self.unzip_dir),
                                    modelIdentifier=self.md.modelExchange.modelIdentifier, instanceName=name)
        else:
            self._slave = FMU2Slave(guid=self.md.guid, unzipDirectory=str(self.unzip_dir),
                                    modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        # FMPy's public FMI 2.0 functions of the loaded library (each logs through FMPy's call logger and raises
        # FMICallException on a status worse than warning: :meth:`_fmi`); the hot ones bound once
        self._get_real = self._slave.fmi2GetReal
        self._set_real = self._slave.fmi2SetReal
        self._do_step = None if model_exchange else self._slave.fmi2DoStep
        self._key = name.encode("utf-8")
        _BY_NAME[self._key] = self
        _install_proxy()
        resource = (self.unzip_dir / "resources").as_uri().encode("utf-8")
        self.c = self._slave.fmi2Instantiate(self._key, 0 if model_exchange else 1, self.md.guid.encode("utf-8"),
                                             resource, byref(_CALLBACKS), 0, 1 if logging_on else 0)
        if not self.c:
            raise FMUError(name, "fmi2Instantiate", None, None, self.last_error)

    def _fmi(self, function: str, *args):
        """The one checked FMI 2.0 call: FMPy's public function ``function`` of the instance's library (which logs
        the call through FMPy's call logger when one is set and raises ``FMICallException`` on a status worse than
        fmi2Warning), its status turned into this package's errors by :meth:`_check`.  The hot calls (get, set,
        do_step) do the same inline on functions bound once."""
        try:
            return getattr(self._slave, function)(*args)
        except FMICallException as e:
            self._check(e.status, function)

    # -- life cycle --------------------------------------------------------------------------------------------
    def setup(self, start_time: float = 0.0, stop_time: float | None = None, tolerance: float | None = None):
        self.time = start_time
        self._fmi("fmi2SetupExperiment", self.c, tolerance is not None, tolerance or 0.0, start_time,
                  stop_time is not None, stop_time or 0.0)

    def enter_initialization(self) -> None:
        self._fmi("fmi2EnterInitializationMode", self.c)

    def exit_initialization(self) -> None:
        self._fmi("fmi2ExitInitializationMode", self.c)

    def terminate(self) -> None:
        if self.failed or not self.c:  # no further calls into an instance that failed
            return
        self._fmi("fmi2Terminate", self.c)

    def free(self) -> None:
        """Free the instance and its saved states (the shared library stays loaded).

        An instance that reported fmi2Error or fmi2Fatal is left allocated (a small leak): freeing a pythonfmu
        0.7 instance after a Python exception corrupts the heap and crashes the process later."""
        if self.c and self.failed:
            _LEAKED.append(self.c)
            self.c = None
            return
        if self.c:
            for s in self._states:
                try:   # the instance goes anyway: a state it cannot free is not an error of the run
                    self._slave.fmi2FreeFMUstate(self.c, byref(s))
                except FMICallException:
                    pass
            self._states.clear()
            self._slave.fmi2FreeInstance(self.c)
            self.c = None
            if _BY_NAME.get(self._key) is self:
                del _BY_NAME[self._key]

    # -- values ------------------------------------------------------------------------------------------------
    def get(self, block: RealBlock) -> np.ndarray:
        """Read the block's variables into its buffer and return the numpy view."""
        if block.n:
            try:
                self._get_real(self.c, block.vr, block.n, block.buf)
            except FMICallException as e:
                self._check(e.status, "fmi2GetReal")
        return block.values

    def _write_reals(self, block: RealBlock) -> None:
        try:
            self._set_real(self.c, block.vr, block.n, block.buf)
        except FMICallException as e:
            self._check(e.status, "fmi2SetReal")

    def get_list(self, block: RealBlock) -> list:
        """The block's variables as a list of floats (same values as :meth:`get`)."""
        if not block.n:
            return []
        try:
            self._get_real(self.c, block.vr, block.n, block.buf)
        except FMICallException as e:
            self._check(e.status, "fmi2GetReal")
        return block.buf[:block.n]

    def set_list(self, block: RealBlock, values: list) -> None:
        """Write a list of floats to the block's variables (same effect as :meth:`set`)."""
        n = block.n
        if n:
            block.buf[:n] = values
            try:
                self._set_real(self.c, block.vr, n, block.buf)
            except FMICallException as e:
                self._check(e.status, "fmi2SetReal")

    def set_input_derivatives(self, block: RealBlock, order: int, values) -> None:
        """fmi2SetRealInputDerivatives of one derivative order for the block's variables."""
        n = block.n
        if not n:
            return
        orders = (c_int * n)(*([order] * n))
        vals = (c_double * n)(*values)
        self._fmi("fmi2SetRealInputDerivatives", self.c, block.vr, n, orders, vals)

    def set_value(self, name: str, value) -> None:
        """Set one variable of any type (parameters, start values); ``value`` is converted to its type."""
        v, value = self._typed(name, value)
        vr = (c_uint * 1)(v.valueReference)
        if v.type == "Real":
            self._fmi("fmi2SetReal", self.c, vr, 1, (c_double * 1)(value))
        elif v.type in ("Integer", "Enumeration"):
            self._fmi("fmi2SetInteger", self.c, vr, 1, (c_int * 1)(value))
        elif v.type == "Boolean":
            self._fmi("fmi2SetBoolean", self.c, vr, 1, (c_int * 1)(1 if value else 0))
        else:
            self._fmi("fmi2SetString", self.c, vr, 1, (c_char_p * 1)(value.encode()))

    def get_value(self, name: str):
        """Read one variable of any type: float (Real), int (Integer, Enumeration), bool, str."""
        v = self.var(name)
        vr = (c_uint * 1)(v.valueReference)
        if v.type == "Real":
            buf = (c_double * 1)()
            self._fmi("fmi2GetReal", self.c, vr, 1, buf)
            return float(buf[0])
        if v.type in ("Integer", "Enumeration", "Boolean"):
            function = "fmi2GetBoolean" if v.type == "Boolean" else "fmi2GetInteger"
            buf = (c_int * 1)()
            self._fmi(function, self.c, vr, 1, buf)
            return bool(buf[0]) if v.type == "Boolean" else int(buf[0])
        buf = (c_char_p * 1)()
        self._fmi("fmi2GetString", self.c, vr, 1, buf)
        return (buf[0] or b"").decode("utf-8")

    def directional_derivative(self, unknowns: RealBlock, knowns: RealBlock, seed) -> np.ndarray:
        """fmi2GetDirectionalDerivative: sum_j d unknowns_i / d knowns_j * seed_j at the current time (outputs,
        inputs); refused in one line for an FMU that does not declare it."""
        self._directional_refused("fmi2GetDirectionalDerivative")
        seed_buf = (c_double * max(1, knowns.n))(*[float(s) for s in seed])
        out = (c_double * max(1, unknowns.n))()
        self._fmi("fmi2GetDirectionalDerivative", self.c, unknowns.vr, unknowns.n, knowns.vr, knowns.n, seed_buf, out)
        return np.array(out[:unknowns.n], dtype=float)

    # -- stepping ----------------------------------------------------------------------------------------------
    def do_step(self, t: float, h: float, no_prior_state: bool = False) -> None:
        self.time = t
        try:
            self._do_step(self.c, t, h, 1 if no_prior_state else 0)
        except FMICallException as e:
            self._check(e.status, f"fmi2DoStep(h = {h:.6g} s)")
        self.time = t + h

    # -- FMU state (rollback) ----------------------------------------------------------------------------------
    def get_state(self, state=None):
        """fmi2GetFMUstate; pass a state returned before to overwrite it (no new allocation)."""
        if state is None:
            state = fmi2FMUstate()
            self._states.append(state)
        self._fmi("fmi2GetFMUstate", self.c, byref(state))
        return state

    def set_state(self, state) -> None:
        self._fmi("fmi2SetFMUstate", self.c, state)

    def free_state(self, state) -> None:
        self._fmi("fmi2FreeFMUstate", self.c, byref(state))
        self._states = [s for s in self._states if s is not state]

    def serialize_state(self, state) -> bytes:
        if not self.can_serialize:
            return super().serialize_state(state)
        size = c_size_t()
        self._fmi("fmi2SerializedFMUstateSize", self.c, state, byref(size))
        buf = create_string_buffer(size.value)
        self._fmi("fmi2SerializeFMUstate", self.c, state, buf, size)
        return buf.raw

    def deserialize_state(self, data: bytes):
        if not self.can_serialize:
            return super().deserialize_state(data)
        state = fmi2FMUstate()
        self._fmi("fmi2DeSerializeFMUstate", self.c, create_string_buffer(data, len(data)), len(data), byref(state))
        self._states.append(state)
        return state
