"""A thin, checked wrapper over fmpy's low-level FMI 2.0 co-simulation interface.

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
"""
from __future__ import annotations

import functools
import sys
import types
from collections import Counter, deque
from ctypes import byref, c_char_p, c_double, c_int, c_uint
from pathlib import Path

import numpy as np
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, fmi2FMUstate)
from fmpy.fmi1 import FMICallException, calloc, free

from fmus.refusal import CATEGORY as REFUSAL_CATEGORY
from fmus.refusal import Refusal
from harness.errors import FMUError, ParameterRefused, StepDiscarded
from harness.fmi.cache import cache_dir, model_description, unzipped  # noqa: F401 (cache_dir: public here too)

OK, WARNING, DISCARD, ERROR, FATAL, PENDING = range(6)
_LABELS = ("ok", "warning", "discard", "error", "fatal", "pending")

# -- extraction (the one archive cache, :mod:`harness.fmi.cache`) -------------------------------------------


def extracted(path: str | Path, model_exchange: bool = False):
    """(model description, unzip directory) of an FMU, extracted once per process and modification time.
    ``model_exchange``: the FMU is to run through its Model Exchange interface (:mod:`harness.fmi.me`), which
    it must have; else through its co-simulation interface."""
    p = Path(path).resolve()
    if not p.is_file():
        raise FMUError(str(path), "extract", None, None, detail=f"no such FMU file {p}")
    md = model_description(p)
    if model_exchange and md.modelExchange is None:
        raise FMUError(p.stem, "read_model_description", None, None,
                       detail=f"{p.name} has no Model Exchange interface (FMI {md.fmiVersion})")
    if md.coSimulation is None and not model_exchange:
        kinds = [k for k, el in (("model exchange", md.modelExchange),
                                 ("scheduled execution", getattr(md, "scheduledExecution", None))) if el is not None]
        raise FMUError(p.stem, "read_model_description", None, None,
                       detail=f"{p.name} is not a co-simulation FMU (FMI {md.fmiVersion}, "
                              f"{' and '.join(kinds) or 'no interface'} only)")
    return md, unzipped(p)


# -- log capture ------------------------------------------------------------------------------------------------
# One logger for every instance (fmpy's native proxy formats the variadic message first); messages are routed
# to the wrapper by instance name.  fmpy's proxy holds ONE Python logger for the whole process, and a drive FMU
# loaded in this process brings its own copy of this module (harness.drive_fmu), which installs its logger: so
# the routing table is one for the process (a fixed entry in sys.modules), and whichever copy's logger the proxy
# holds finds every copy's instances.
_ROUTES = sys.modules.setdefault("_pressdrive_fmi_log_routes",
                                 types.ModuleType("_pressdrive_fmi_log_routes", "FMI log routing (harness.fmi.fmu)"))
if not hasattr(_ROUTES, "by_name"):
    _ROUTES.by_name = {}
_BY_NAME: dict[bytes, "FMU"] = _ROUTES.by_name


def _log(env, instance_name, status, category, message):
    fmu = _BY_NAME.get(instance_name)
    text = message.decode("utf-8", "replace") if message else ""
    if fmu is None:  # fmpy's native proxy keeps ONE Python logger for all FMUs: behave like fmpy's for others
        print(f"[{_LABELS[status].upper() if 0 <= status < 6 else status}] {text}")
        return
    fmu._logged(status, category.decode("utf-8", "replace") if category else "", text)


_CALLBACKS = fmi2CallbackFunctions()
_LOGGER = fmi2CallbackLoggerTYPE(_log)
_CALLBACKS.logger = _LOGGER
_CALLBACKS.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
_CALLBACKS.freeMemory = fmi2CallbackFreeMemoryTYPE(free)


def _install_proxy() -> None:
    """fmpy's native proxy formats variadic messages; it holds a single Python logger for the process, so it
    is (re)installed before each instantiation (unknown instances are printed as fmpy does)."""
    try:
        from fmpy.logging import addLoggerProxy

        _CALLBACKS.logger = _LOGGER   # the proxy takes the logger it finds here (not itself, once installed)
        addLoggerProxy(byref(_CALLBACKS))
    except Exception:  # pragma: no cover - no native proxy: messages arrive unformatted
        pass


_install_proxy()


def toolkit_annotation(unzip_dir: Path):
    """The toolkit's own annotation of an FMU built by fmus.slave.PressSlave (FMI 2.0: VendorAnnotations, tool
    "org.pressdrive"; FMI 3.0: Annotations/Annotation of type "org.pressdrive"; element ``Slave`` with the
    attributes ``module``, ``class`` and ``advancedPositions``), or None for any other FMU.  Read once per extraction folder (its content never changes: a changed FMU is
    extracted into another folder, see :func:`extracted`)."""
    return _annotation(str(unzip_dir))


@functools.lru_cache(maxsize=None)
def _annotation(unzip_dir: str):
    import xml.etree.ElementTree as ET

    try:
        root = ET.parse(Path(unzip_dir) / "modelDescription.xml").getroot()
    except (OSError, ET.ParseError):
        return None
    found = root.find("VendorAnnotations/Tool[@name='org.pressdrive']/Slave")   # FMI 2.0
    if found is None:
        found = root.find("Annotations/Annotation[@type='org.pressdrive']/Slave")  # FMI 3.0
    return found


def advanced_positions(unzip_dir: Path) -> frozenset:
    """Motion-input positions the FMU advances itself over a step with the held speed (from the toolkit's
    annotation; empty for any other FMU)."""
    el = toolkit_annotation(unzip_dir)
    return frozenset((el.get("advancedPositions") or "").split()) if el is not None else frozenset()


_LEAKED: list = []  # instances that failed and are deliberately never freed (see FMU.free)


class RealBlock:
    """Value references of some Real variables and a preallocated value buffer (``values`` is a numpy view
    of the ctypes buffer).  ``names`` are the variable names, in order; ``refs`` the references as a list
    (for the in-process path, which calls Python instead of C)."""

    __slots__ = ("names", "n", "vr", "refs", "buf", "values")

    def __init__(self, names: list[str], refs: list[int]):
        self.names = list(names)
        self.n = len(refs)
        self.refs = [int(r) for r in refs]
        self.vr = (c_uint * max(1, self.n))(*refs)
        self.buf = (c_double * max(1, self.n))()
        self.values = np.ctypeslib.as_array(self.buf)[: self.n]


def _keep_installed_pythonfmu() -> None:
    """Import the installed pythonfmu before any FMU's resources folder goes on ``sys.path``.

    A pythonfmu FMU carries a copy of the pythonfmu package in its resources, without pythonfmu's binaries,
    and its C wrapper (like :mod:`harness.fmi.inprocess`) puts that folder FIRST on ``sys.path``.  Were the
    package first imported after that, the process would hold the FMU's copy, and an FMU built later in the
    same process (build_fmus, or :func:`harness.model.resolve_fmu` rebuilding a stale FMU) would come out
    without binaries."""
    if "pythonfmu" not in sys.modules:
        try:
            import pythonfmu  # noqa: F401
        except ImportError:  # pragma: no cover - not a pythonfmu installation: nothing to protect
            pass


class Instance:
    """What every FMU instance offers the master, whatever runs it (the C library through FMI, or a
    pythonfmu slave object called in this process: :mod:`harness.fmi.inprocess`).

    ``path`` is the .fmu file; ``name`` the instance name (used in every error message).  Attributes:
    ``md`` (fmpy model description), ``variables`` (name -> fmpy ModelVariable), ``time`` (the current
    communication point, for messages), ``log`` (the last 200 log messages as (status, text)), ``last_error``,
    ``refusal`` (a parameter value the FMU refused, :mod:`fmus.refusal`, until the failing call raises it),
    ``failed`` (True once the instance returned fmi2Error or fmi2Fatal)."""

    path_kind = "fmi"  # how the instance is called: "fmi" (the FMU's shared library) or "in-process"

    def __init__(self, path: str | Path, name: str, model_exchange: bool = False):
        _keep_installed_pythonfmu()
        self.path = Path(path)
        self.name = name
        self.md, self.unzip_dir = extracted(self.path, model_exchange)
        cs = self.md.modelExchange if model_exchange else self.md.coSimulation
        self.variables = {v.name: v for v in self.md.modelVariables}
        # names declared more than once (an invalid modelDescription loaded anyway): unusable by name
        counts = Counter(v.name for v in self.md.modelVariables)
        self._ambiguous = {n for n, c in counts.items() if c > 1}
        self.can_get_set_state = bool(cs.canGetAndSetFMUstate)
        # a Model Exchange FMU is stepped by its own solver (harness.fmi.me): any step, inputs held
        self.can_vary_step = model_exchange or bool(cs.canHandleVariableCommunicationStepSize)
        self.can_interpolate_inputs = not model_exchange and bool(cs.canInterpolateInputs)
        self.advanced_positions = advanced_positions(self.unzip_dir)
        # fmi2GetDirectionalDerivative answers d outputs / d inputs (co-simulation; FMI 3.0: harness.fmi.fmu3)
        self.provides_directional_derivative = (not model_exchange
                                                and bool(getattr(cs, "providesDirectionalDerivative", False)))
        self.max_input_derivative_order = 2 if self.can_interpolate_inputs else 0
        self.log: deque = deque(maxlen=200)
        self.errors: list[str] = []   # error messages logged by the FMU
        self._reported = 0
        self.refusal: Refusal | None = None   # a parameter value the FMU refused, not yet raised (fmus.refusal)
        self.failed = False
        self.time: float | None = None

    # -- checking ----------------------------------------------------------------------------------------------
    @property
    def last_error(self) -> str:
        """The error messages logged since the last reported failure (the FMU's own lines first; the generic
        'Fatal py exception' line of pythonfmu only when there is nothing else)."""
        msgs = self.errors[self._reported:]
        specific = [m for m in msgs if not m.startswith("Fatal py exception")]
        return "; ".join(specific or msgs[-1:])

    def _logged(self, status: int, category: str, text: str) -> None:
        """One message the FMU logged (every version's logger and the in-process queue end here): a refusal
        (category :data:`fmus.refusal.CATEGORY`) is kept as data for the error of the failing call; any other
        message goes to ``log``, and to ``errors`` from status error on."""
        if category == REFUSAL_CATEGORY:
            refusal = Refusal.from_message(text)
            if refusal is not None:
                self.refusal = refusal
                return
        self.log.append((status, text))
        if status >= ERROR:
            self.errors.append(" ".join(text.split()))

    def _error(self, function: str, status: int, detail: str = "") -> FMUError:
        """The error of a failed call (the messages logged since the last one): :class:`StepDiscarded` for
        discard, :class:`ParameterRefused` when the FMU refused a parameter value, else :class:`FMUError`."""
        log = self.last_error
        self._reported = len(self.errors)
        if status == DISCARD:
            return StepDiscarded(self.name, function, self.time, status, log, detail)
        refusal, self.refusal = self.refusal, None
        if refusal is not None:
            return ParameterRefused(self.name, function, self.time, status, log, detail, refusal=refusal)
        return FMUError(self.name, function, self.time, status, log, detail)

    def _check(self, status: int, function: str) -> None:
        if status > WARNING:
            if status >= ERROR:
                self.failed = True
            raise self._error(function, status)

    def _call(self, function: str, method, *args, **kwargs):
        """``method(*args, **kwargs)`` of an FMPy slave that raises on a bad status (FMI 1.0 and 3.0): the
        status becomes :class:`StepDiscarded` (discard) or :class:`FMUError` with the FMU's logged error; a
        library that cannot be called at all, an FMUError naming the Python error; an instance that failed
        before is not called again."""
        if self.failed:
            raise FMUError(self.name, function, self.time, ERROR, detail="the instance failed before")
        try:
            return method(*args, **kwargs)
        except FMICallException as e:
            status = int(getattr(e, "status", ERROR))
            if status != DISCARD:
                self.failed = True
            raise self._error(function, status) from None
        except Exception as e:  # the library could not be called at all
            self.failed = True
            raise FMUError(self.name, function, self.time, ERROR, detail=f"{type(e).__name__}: {e}") from None

    def _directional_refused(self, function: str):
        """The one-line refusal of a directional derivative the FMU does not declare (None if it does)."""
        if not self.provides_directional_derivative:
            raise FMUError(self.name, function, self.time, None,
                           detail=f"FMU {self.md.modelName} does not provide directional derivatives (its "
                                  f"modelDescription does not declare them)")

    def directional_derivative(self, unknowns: RealBlock, knowns: RealBlock, seed) -> np.ndarray:
        """d unknowns / d knowns * seed (FMI 2.0 and 3.0 co-simulation, where declared; the versions' classes);
        here, an interface without directional derivatives (FMI 1.0, model exchange), the one-line refusal."""
        self._directional_refused("GetDirectionalDerivative")
        raise FMUError(self.name, "GetDirectionalDerivative", self.time, None,
                       detail=f"{type(self).__name__} instances do not call directional derivatives")

    def var(self, name: str):
        v = self.variables.get(name)
        if name in self._ambiguous:
            raise FMUError(self.name, "lookup", None, None,
                           detail=f"FMU {self.md.modelName} declares variable {name!r} more than once")
        if v is None:
            raise FMUError(self.name, "lookup", None, None,
                           detail=f"FMU {self.md.modelName} has no variable {name!r}")
        return v

    def reals(self, names) -> RealBlock:
        """A :class:`RealBlock` for these Real variables (references resolved once)."""
        refs = []
        for n in names:
            v = self.var(n)
            if v.type != "Real":
                raise FMUError(self.name, "lookup", None, None, detail=f"variable {n} is {v.type}, not Real")
            refs.append(v.valueReference)
        return RealBlock(list(names), refs)

    def _typed(self, name: str, value):
        """(variable, value converted to the variable's FMI type) for :meth:`set_value`."""
        v = self.var(name)
        if v.type == "Real":
            return v, float(value)
        if v.type in ("Integer", "Enumeration"):
            iv = int(value)
            if iv != value:
                raise FMUError(self.name, "fmi2SetInteger", self.time, None,
                               detail=f"{name} = {value!r} is not an integer")
            return v, iv
        if v.type == "Boolean":
            return v, bool(value)
        if v.type == "String":
            return v, str(value)
        raise FMUError(self.name, "set", self.time, None, detail=f"{name}: unsupported type {v.type}")  # pragma: no cover

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, {self.path.name})"

    def check_binary(self, model_identifier: str, function: str) -> None:
        """One line (:class:`FMUError` for ``function``, the instantiate call) when the FMU has no shared library
        for this platform where fmpy looks for it (``binaries/<platform>/<modelIdentifier><ext>``), naming the
        FMU file and the platforms it has binaries for; fmpy's own message names the extraction cache only."""
        import fmpy

        folder = fmpy.platform_tuple if str(self.md.fmiVersion).startswith("3") else fmpy.platform
        if (self.unzip_dir / "binaries" / folder / f"{model_identifier}{fmpy.sharedLibraryExtension}").is_file():
            return
        binaries = self.unzip_dir / "binaries"
        have = sorted(d.name for d in binaries.iterdir() if d.is_dir() and any(d.iterdir())) \
            if binaries.is_dir() else []
        sources = (self.unzip_dir / "sources").is_dir()
        has = (f"it has binaries for {', '.join(have)} only" if have else "it has no binaries at all") + \
            (" (and sources: build it for this platform, e.g. with fmpy's 'Compile platform binary')"
             if sources else "")
        raise FMUError(self.name, function, None, None,
                       detail=f"{self.path} has no binary for this platform ({folder}/{model_identifier}"
                              f"{fmpy.sharedLibraryExtension}): {has}")


class FMU(Instance):
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

    def set(self, block: RealBlock, values=None) -> None:
        """Write ``values`` (or the block's own buffer, if None) to the block's variables."""
        if values is not None:
            block.values[:] = values
        if block.n:
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
