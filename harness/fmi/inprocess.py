"""The in-process path for pythonfmu FMUs: the slave object called directly, without the C round trip.

A pythonfmu FMU is a C library that, on ``fmi2Instantiate``, puts the FMU's ``resources/`` folder on
``sys.path``, imports the module named in ``resources/slavemodule.txt``, instantiates its ``Fmi2Slave``
subclass with ``instance_name``, ``resources``, ``logger`` and ``visible``, and then forwards every FMI call
to a method of that object (``do_step``, ``get_real``, ``set_real``, ``_get_fmu_state``...), converting
each double to a Python float and back.  Because the object lives in the master's own interpreter anyway,
:class:`InProcessFMU` does the same thing without the C layer: it imports the same module from the same
extracted folder, instantiates the same class with the same arguments and calls the same methods with the
same float values.  So the results are bit-identical to the FMI path (``tests/test_inprocess.py`` checks
every press drive), and each FMI call saves the ctypes call, ``PyGILState_Ensure``, the conversion of every
value to and from C, and the log-queue flush the C wrapper does after every call.

Status mapping (as the pythonfmu 0.7 C wrapper does it): a Python exception in any call is ``fmi2Fatal``
(:class:`~harness.errors.FMUError` with the FMU's logged error line, or the exception's text); ``do_step``
returning False is ``fmi2Discard`` (:class:`~harness.errors.StepDiscarded`).  Messages the slave logs
(``Fmi2Slave.log``) go to the same ``log``/``errors`` lists as on the FMI path.

Which FMUs run here is decided by :func:`harness.fmi.open_instance`: by default every pythonfmu FMU whose
script imports in this process (the toolkit's own FMUs, whose VendorAnnotations name the slave module and
class, and any other pythonfmu FMU: its script under a unique module name, :func:`_module_name`); an FMU
whose script cannot be imported here runs through FMI, with one warning line saying why.
"""
from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.util
import inspect
import sys
from pathlib import Path
from types import ModuleType

import numpy as np

from fmus.refusal import CATEGORY as REFUSAL_CATEGORY
from harness.errors import FMUError, StepDiscarded
from harness.fmi.fmu import DISCARD, ERROR, FATAL, WARNING, FMUInstance, RealBlock, toolkit_annotation

_SLAVE_BASE = "Fmi2Slave"


def is_pythonfmu(unzip_dir: Path) -> bool:
    """True for an FMU made with pythonfmu (its resources name the slave module) for FMI 2.0.  pythonfmu3's
    FMUs name their module the same way, but their slave is an ``Fmi3Slave`` with FMI 3.0's methods: they
    run through their FMI 3.0 library (:class:`harness.fmi.fmu3.FMU3`)."""
    unzip_dir = Path(unzip_dir)
    if not (unzip_dir / "resources" / "slavemodule.txt").is_file():
        return False
    return _fmi_version(str(unzip_dir)) == "2.0"


@functools.lru_cache(maxsize=None)
def _fmi_version(unzip_dir: str) -> str | None:
    """The fmiVersion attribute of an extracted FMU's modelDescription.xml (None if unreadable)."""
    import xml.etree.ElementTree as ET

    try:
        for _, el in ET.iterparse(Path(unzip_dir) / "modelDescription.xml", events=("start",)):
            return el.get("fmiVersion")
    except (OSError, ET.ParseError):
        return None
    return None


def is_toolkit_fmu(unzip_dir: Path) -> bool:
    """True for the toolkit's own FMUs (fmus.slave.PressSlave names its slave class in an annotation)."""
    return toolkit_annotation(unzip_dir) is not None


def _depth(cls: type) -> int:
    """Position of pythonfmu's ``Fmi2Slave`` in the class's MRO (-1 if it is not a slave)."""
    for i, base in enumerate(cls.__mro__):
        if base.__name__ == _SLAVE_BASE:
            return i
    return -1


def _module_name(unzip_dir: Path, script: str) -> str:
    """The name the in-process path imports an FMU's slave script under: the script's own name for the
    toolkit's FMUs (already unique: ``pd_<name>_<hash>``), else the script's name plus a digest of the FMU's
    extraction folder, so two FMUs built from scripts of the same file name (and two versions of one FMU) are
    two modules in one process.  (pythonfmu's C wrapper imports the script under its own name, so there the
    first one imported in a process wins.)"""
    digest = hashlib.sha1(str(Path(unzip_dir).resolve()).encode()).hexdigest()[:12]
    return f"{script}__fmu_{digest}"


def _import_script(unzip_dir: Path) -> ModuleType:
    """Import the slave module named in ``resources/slavemodule.txt`` as pythonfmu's wrapper does (the
    resources folder on ``sys.path``, so the script finds the modules packed beside it), under the unique
    name of :func:`_module_name` where the script is a plain file in the resources folder (any FMU but the
    toolkit's, whose module and package names are unique already)."""
    written, sys.dont_write_bytecode = sys.dont_write_bytecode, False
    try:
        return _import_script_from(Path(unzip_dir))
    finally:
        sys.dont_write_bytecode = written


def _import_script_from(unzip_dir: Path) -> ModuleType:
    """:func:`_import_script`'s import.  It runs with Python's bytecode cache on even where the process
    turns it off (``PYTHONDONTWRITEBYTECODE``): the extracted folder is the toolkit's own cache
    (:func:`harness.fmi.cache.unzipped`), so each FMU's code is compiled once, not on every run (the FMUs of a
    build share their runtime package, imported from the first one's folder; docs/performance.md measures what
    this saves)."""
    resources = unzip_dir / "resources"
    script = (resources / "slavemodule.txt").read_text().strip().splitlines()[0].strip()
    file = resources / f"{script}.py"
    if toolkit_annotation(unzip_dir) is not None or not file.is_file():
        if str(resources) not in sys.path:
            sys.path.insert(0, str(resources))
        return importlib.import_module(script)
    # A plain pythonfmu FMU packs a copy of pythonfmu (without its binaries) beside its script: its folder goes
    # LAST on sys.path, so this process keeps importing the installed pythonfmu (a later FMU build in the same
    # process still finds the binaries) while the script still finds its own modules.
    if str(resources) not in sys.path:
        sys.path.append(str(resources))
    name = _module_name(unzip_dir, script)
    module = sys.modules.get(name)
    if module is None:
        spec = importlib.util.spec_from_file_location(name, file)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except BaseException:
            del sys.modules[name]
            raise
    return module


def slave_class(unzip_dir: Path) -> type:
    """Import the FMU's slave module from its resources folder and return the slave class.

    The class is the one the FMU's annotation names, else (any pythonfmu FMU) the class pythonfmu's C
    wrapper takes: among the module's classes, the first whose MRO has ``Fmi2Slave`` deepest."""
    module = _import_script(unzip_dir)
    ann = toolkit_annotation(unzip_dir)
    if ann is not None and ann.get("class"):
        return getattr(module, ann.get("class"))
    best, depth = None, 0
    for value in vars(module).values():
        d = _depth(value) if inspect.isclass(value) else -1
        if d > depth:
            best, depth = value, d
    if best is None:
        raise ImportError(f"module {module.__name__} of {unzip_dir} defines no Fmi2Slave subclass")
    return best


class _State:
    """A saved slave state (the object returned by ``_get_fmu_state``), overwritable like an fmi2FMUstate."""
    __slots__ = ("value",)

    def __init__(self):
        self.value = None


class InProcessFMU(FMUInstance):
    """A pythonfmu FMU whose slave object is called directly in this process (module docstring)."""

    path_kind = "in-process"

    def __init__(self, path: str | Path, name: str, logging_on: bool = True, cls: type | None = None):
        """``cls``: the slave class if the caller already imported it (else :func:`slave_class`)."""
        super().__init__(path, name)
        self.logging_on = logging_on  # False: keep only warnings and errors (FMI debug logging off)
        try:
            cls = cls or slave_class(self.unzip_dir)
            self._slave = cls(instance_name=name, resources=str(self.unzip_dir / "resources"), logger=0,
                              visible=0)
        except Exception as e:
            self.failed = True
            raise FMUError(name, "fmi2Instantiate", None, FATAL, detail=f"{type(e).__name__}: {e}") from None
        self._queue = self._slave.log_queue
        s = self._slave
        self._get_real = s.get_real
        self._set_real = s.set_real
        self._step = s.do_step

    # -- failures and the log ------------------------------------------------------------------------------------
    def _drain(self) -> None:
        """Move the slave's queued log messages to ``log``/``errors`` (the C wrapper does this after each call)."""
        for msg in self._queue:
            status = int(msg.status)
            category = str(msg.category or "")
            if status < WARNING and not self.logging_on and category != REFUSAL_CATEGORY:
                continue
            self._logged(status, category, str(msg.msg))
        del self._queue[:]

    def _fail(self, function: str, exc: BaseException):
        """Raise the FMUError of a call that raised ``exc`` (fmi2Fatal, as pythonfmu reports it)."""
        self._drain()
        if not self.errors[self._reported:]:
            self.errors.append(" ".join(f"{type(exc).__name__}: {exc}".split()))
        self.failed = True
        raise self._error(function, FATAL) from None

    def _call(self, function: str, method, *args):
        if self.failed:
            raise FMUError(self.name, function, self.time, FATAL, detail="the instance failed before")
        try:
            out = method(*args)
        except Exception as e:
            self._fail(function, e)
        if self._queue:
            self._drain()
        return out

    # -- life cycle --------------------------------------------------------------------------------------------
    def setup(self, start_time: float = 0.0, stop_time: float | None = None, tolerance: float | None = None):
        self.time = start_time
        self._call("fmi2SetupExperiment", self._slave.setup_experiment, float(start_time),
                   None if stop_time is None else float(stop_time), None if tolerance is None else float(tolerance))

    def enter_initialization(self) -> None:
        self._call("fmi2EnterInitializationMode", self._slave.enter_initialization_mode)

    def exit_initialization(self) -> None:
        self._call("fmi2ExitInitializationMode", self._slave.exit_initialization_mode)

    def terminate(self) -> None:
        if self.failed or self._slave is None:
            return
        self._call("fmi2Terminate", self._slave.terminate)

    def free(self) -> None:
        self._slave = None
        self._get_real = self._set_real = self._step = None

    # -- values ------------------------------------------------------------------------------------------------
    def get(self, block: RealBlock):
        """Read the block's variables into its buffer and return the numpy view."""
        if block.n:
            try:
                block.values[:] = self._get_real(block.refs)
            except Exception as e:
                self._fail("fmi2GetReal", e)
        return block.values

    def _write_reals(self, block: RealBlock) -> None:
        try:
            self._set_real(block.refs, block.values.tolist())
        except Exception as e:
            self._fail("fmi2SetReal", e)

    def get_list(self, block: RealBlock) -> list:
        """The block's variables as a list of floats (same values as :meth:`get`)."""
        try:
            return self._get_real(block.refs)
        except Exception as e:
            self._fail("fmi2GetReal", e)

    def set_list(self, block: RealBlock, values: list) -> None:
        """Write a list of floats to the block's variables (same effect as :meth:`set`)."""
        try:
            self._set_real(block.refs, values)
        except Exception as e:
            self._fail("fmi2SetReal", e)

    def set_input_derivatives(self, block: RealBlock, order: int, values) -> None:
        raise FMUError(self.name, "fmi2SetRealInputDerivatives", self.time, ERROR,
                       detail="pythonfmu FMUs cannot interpolate inputs")

    _SETTERS = {"Real": ("set_real", "fmi2SetReal"), "Integer": ("set_integer", "fmi2SetInteger"),
                "Enumeration": ("set_integer", "fmi2SetInteger"), "Boolean": ("set_boolean", "fmi2SetBoolean"),
                "String": ("set_string", "fmi2SetString")}

    def set_value(self, name: str, value) -> None:
        """Set one variable of any type (parameters, start values); ``value`` is converted to its type."""
        v, value = self._typed(name, value)
        method, function = self._SETTERS[v.type]
        self._call(function, getattr(self._slave, method), [v.valueReference], [value])

    _GETTERS = {"Real": ("get_real", "fmi2GetReal", float), "Integer": ("get_integer", "fmi2GetInteger", int),
                "Enumeration": ("get_integer", "fmi2GetInteger", int),
                "Boolean": ("get_boolean", "fmi2GetBoolean", bool), "String": ("get_string", "fmi2GetString", str)}

    def get_value(self, name: str):
        """Read one variable of any type: float (Real), int (Integer, Enumeration), bool, str."""
        v = self.var(name)
        method, function, kind = self._GETTERS[v.type]
        return kind(self._call(function, getattr(self._slave, method), [v.valueReference])[0])

    def directional_derivative(self, unknowns: RealBlock, knowns: RealBlock, seed):
        """The slave's directional_derivative (what the host loader answers fmi2GetDirectionalDerivative with):
        sum_j d unknowns_i / d knowns_j * seed_j at the current time; refused in one line for an FMU that does not
        declare it."""
        self._directional_refused("fmi2GetDirectionalDerivative")
        return np.array(self._call("fmi2GetDirectionalDerivative", self._slave.directional_derivative,
                                   unknowns.refs, knowns.refs, [float(s) for s in seed]), dtype=float)

    # -- stepping ----------------------------------------------------------------------------------------------
    def do_step(self, t: float, h: float, no_prior_state: bool = False) -> None:
        self.time = t
        try:
            ok = self._step(t, h)
        except Exception as e:
            self._fail(f"fmi2DoStep(h = {h:.6g} s)", e)
        if self._queue:
            self._drain()
        if not ok:
            log = self.last_error
            self._reported = len(self.errors)
            raise StepDiscarded(self.name, f"fmi2DoStep(h = {h:.6g} s)", t, DISCARD, log)
        self.time = t + h

    # -- FMU state (rollback) ----------------------------------------------------------------------------------
    def get_state(self, state=None):
        if state is None:
            state = _State()
        state.value = self._call("fmi2GetFMUstate", self._slave._get_fmu_state)
        return state

    def set_state(self, state) -> None:
        self._call("fmi2SetFMUstate", self._slave._set_fmu_state, state.value)

    def free_state(self, state) -> None:
        state.value = None

    def serialize_state(self, state) -> bytes:
        if not self.can_serialize:
            return super().serialize_state(state)
        return bytes(self._call("fmi2SerializeFMUstate", self._slave._fmu_state_to_bytes, state.value))

    def deserialize_state(self, data: bytes):
        if not self.can_serialize:
            return super().deserialize_state(data)
        state = _State()
        state.value = self._call("fmi2DeSerializeFMUstate", self._slave._fmu_state_from_bytes, bytes(data))
        return state


__all__ = ["InProcessFMU", "is_pythonfmu", "is_toolkit_fmu", "slave_class"]
