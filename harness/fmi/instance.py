"""What every running FMU instance offers the master, whatever runs it (:class:`Instance`), the extraction of
an FMU (:func:`extracted`) and the value-reference blocks get/set work on (:class:`RealBlock`).  The FMI
versions' wrappers (:mod:`harness.fmi.fmu`, :mod:`~harness.fmi.fmu1`, :mod:`~harness.fmi.fmu3`, :mod:`~harness.fmi.me`)
and the in-process and isolated paths derive from :class:`Instance`."""
from __future__ import annotations

import sys
from collections import Counter, deque
from ctypes import c_double, c_uint
from pathlib import Path

import numpy as np
from fmpy.fmi1 import FMICallException

from fmus.refusal import CATEGORY as REFUSAL_CATEGORY
from fmus.refusal import Refusal
from harness.errors import FMUError, ParameterRefused, StepDiscarded
from harness.fmi.annotation import advanced_positions
from harness.fmi.cache import model_description, unzipped
from harness.fmi.status import DISCARD, ERROR, WARNING

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


class FMUInstance:
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
        # fmi2SerializeFMUstate & co (FMI 3.0: canSerializeFMUState): a state as bytes, for checkpoints
        self.can_serialize = bool(getattr(cs, "canSerializeFMUstate", False) or
                                  getattr(cs, "canSerializeFMUState", False))
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

    # -- FMU state as bytes (checkpoints: harness.run.checkpoint) ---------------------------------------------------
    def serialize_state(self, state) -> bytes:
        """A state (:meth:`get_state`'s) as bytes; refused in one line for an FMU that cannot serialize it."""
        raise FMUError(self.name, "fmi2SerializeFMUstate", self.time, None,
                       detail=f"{self.path.name} cannot serialize its state (no canSerializeFMUstate)")

    def deserialize_state(self, data: bytes):
        """A state from :meth:`serialize_state`'s bytes, to :meth:`set_state`."""
        raise FMUError(self.name, "fmi2DeSerializeFMUstate", self.time, None,
                       detail=f"{self.path.name} cannot serialize its state (no canSerializeFMUstate)")

    # -- values ----------------------------------------------------------------------------------------------
    def set(self, block: RealBlock, values=None) -> None:
        """Write ``values`` (or the block's own buffer, if None) to the block's variables (:meth:`_write_reals`)."""
        if values is not None:
            block.values[:] = values
        if block.n:
            self._write_reals(block)

    def _write_reals(self, block: RealBlock) -> None:
        """Send the block's buffer to its variables (each way of running an FMU has its own)."""
        raise NotImplementedError

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




# the former name of FMUInstance (deprecated: harness.model.Instance is the declaration of an instance in a system)
Instance = FMUInstance
