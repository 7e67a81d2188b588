"""Isolation: an FMU instance run in a child process of its own, every call forwarded with a timeout.

A foreign FMU is native code the toolkit cannot vouch for: a segmentation fault, an ``abort()`` or an endless
loop inside one of its calls would take the master's process (and every row it computed) with it.  As
libcosim's proxy FMUs do, :class:`IsolatedInstance` offers the master the same interface as every other
instance (:class:`harness.fmi.fmu.Instance`) but opens the real one (:func:`harness.fmi.open_instance`, so FMI
1.0, 2.0, 3.0 and model exchange alike) in a child Python process (``python -m harness.fmi.isolated``) and
forwards each call over a socket pair.  The model description is read in the parent, so names, units and
causalities need no round trip.

* A call that returns an FMI error in the child comes back as the same :class:`~harness.errors.FMUError`
  (``StepDiscarded``, ``ParameterRefused``) it would have raised in this process.
* A child that dies inside a call (a signal: SIGSEGV, SIGABRT, SIGBUS...; or an exit) is one
  :class:`FMUCrashed` line naming the instance, the FMI call, the simulated time and how the process ended.
* A call that does not return within ``timeout`` seconds (:class:`Isolation`) kills the child and is one
  :class:`FMUCrashed` line saying so.

Either error stops the run the way any FMU error does (:func:`harness.run.simulate`): the result up to the last
good communication point is kept, marked incomplete.  Values cross the process boundary as Python floats
(pickled doubles), so an isolated run is bit-identical to the same run in one process.  What it costs is the
round trips: the values a master sets travel with its next call, and a step's answer carries the values of
every variable block the master reads, so a plain step (set inputs, step, read outputs) is one round trip
(measured by ``python -m benchmarks.isolation``, written in docs/howto/foreign.md).
"""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
from dataclasses import dataclass
from multiprocessing.connection import Connection
from pathlib import Path

from harness.errors import FMUError, SystemDescriptionError
from harness.fmi.fmu import FMUInstance, RealBlock

DEFAULT_TIMEOUT = 60.0  # [s] per forwarded call: far beyond any sane step, short enough for a night's sweep
STARTUP = 120.0         # [s] allowed beyond the timeout for the child's start (a Python interpreter, imports)


class FMUCrashed(FMUError):
    """The process of an isolated FMU died inside a call (a signal or an exit), or the call did not return
    within the isolation's timeout (``hung`` True; the process was killed)."""

    def __init__(self, instance: str, function: str, time: float | None, detail: str, hung: bool = False):
        super().__init__(instance, function, time, None, detail=detail)
        self.hung = hung


@dataclass(frozen=True)
class Isolation:
    """Which FMUs run in a child process of their own, and how long one call may take.

    ``which``: ``"foreign"`` (every FMU not built by this toolkit), ``"all"``, or ``"none"``; ``timeout``
    [s]: the longest one forwarded call (a step, a get, the instantiation) may take before the child is killed
    and the run stops (positive)."""
    which: str = "foreign"
    timeout: float = DEFAULT_TIMEOUT

    def __post_init__(self):
        if self.which not in ("foreign", "all", "none"):
            raise SystemDescriptionError(f"isolate = {self.which!r} is not admissible: must be 'foreign', 'all' "
                                         f"or 'none'")
        t = self.timeout
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not t > 0 or t != t or t == float("inf"):
            raise SystemDescriptionError(f"isolation timeout = {t!r} s is not admissible: must be a finite number > 0")

    @classmethod
    def of(cls, value) -> "Isolation | None":
        """An :class:`Isolation` from what a user passes as ``isolate``: None/False (none), True ("foreign"),
        a string (``which``), a number (the timeout of "foreign"), or an Isolation; None when nothing is
        isolated."""
        if value is None or value is False:
            return None
        if isinstance(value, Isolation):
            iso = value
        elif value is True:
            iso = cls()
        elif isinstance(value, str):
            iso = cls(value)
        elif isinstance(value, (int, float)):
            iso = cls(timeout=value)
        else:
            raise SystemDescriptionError(f"isolate = {value!r} is not admissible: must be True, False, 'foreign', "
                                         f"'all', 'none', a timeout in s or an Isolation")
        return None if iso.which == "none" else iso

    def applies(self, unzip_dir: Path) -> bool:
        """True when the FMU extracted at ``unzip_dir`` is to run isolated."""
        if self.which == "all":
            return True
        from harness.fmi.inprocess import is_toolkit_fmu

        return not is_toolkit_fmu(unzip_dir)


# attributes of the child's instance the master reads (set by each FMI version's class on its own)
_FLAGS = ("can_get_set_state", "can_serialize", "can_vary_step", "can_interpolate_inputs",
          "provides_directional_derivative", "max_input_derivative_order", "advanced_positions", "path_kind")


def _signal_name(code: int) -> str:
    try:
        sig = signal.Signals(-code)
    except ValueError:
        return f"signal {-code}"
    what = {"SIGSEGV": "segmentation fault", "SIGABRT": "abort", "SIGBUS": "bus error",
            "SIGFPE": "floating-point exception", "SIGILL": "illegal instruction",
            "SIGKILL": "killed"}.get(sig.name)
    return f"{sig.name}, {what}" if what else sig.name


class IsolatedInstance(FMUInstance):
    """An FMU instance in a child process (module docstring); the master calls it like any other."""

    def __init__(self, path: str | Path, name: str, logging_on: bool = True, in_process: bool | None = None,
                 timeout: float = DEFAULT_TIMEOUT):
        from harness.fmi.cache import model_description

        md = model_description(path) if Path(path).is_file() else None
        super().__init__(path, name, model_exchange=md is not None and md.coSimulation is None)
        self.timeout = float(timeout)
        v = str(self.md.fmiVersion)
        self._prefix = "fmi3" if v.startswith("3") else "fmi" if v == "1.0" else "fmi2"
        self._proc = None
        self._conn = None
        self._blocks: dict[int, tuple] = {}
        self._pending: list = []     # sets not sent yet: they travel with the next call (one round trip less)
        self._fresh_values: dict | None = None   # every block's values after the last step, until anything else is sent
        parent, child = socket.socketpair()
        env = dict(os.environ)
        root = str(Path(__file__).resolve().parents[2])   # this checkout of the toolkit wins in the child too
        env["PYTHONPATH"] = os.pathsep.join([root] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
        try:
            self._proc = subprocess.Popen([sys.executable, "-m", "harness.fmi.isolated", str(child.fileno())],
                                          pass_fds=(child.fileno(),), env=env, stdin=subprocess.DEVNULL)
        finally:
            child.close()
        self._conn = Connection(parent.detach())
        instantiate = f"{self._prefix}Instantiate" if self._prefix != "fmi3" else "fmi3InstantiateCoSimulation"
        flags = self._ask(instantiate, "open", str(self.path), name, logging_on, in_process,
                          wait=STARTUP + self.timeout)
        for k, val in flags.items():
            setattr(self, k, val)
        self.path_kind = f"isolated {flags.get('path_kind', 'fmi')}"

    # -- the forwarding ----------------------------------------------------------------------------------------
    def _ask(self, function: str, op: str, *args, wait: float | None = None):
        """Send one call to the child and return its answer; an FMU error raised there is raised here; a dead
        child or a call over the timeout is :class:`FMUCrashed`."""
        if self.failed or self._conn is None:
            raise FMUError(self.name, function, self.time, None, detail="the instance failed before")
        pending, self._pending = self._pending, []
        self._fresh_values = None
        try:
            self._conn.send((pending, op, args))
            ready = self._conn.poll(self.timeout if wait is None else wait)
        except (OSError, EOFError):
            ready = True   # the child is gone: its exit status says how
        except BaseException:   # Ctrl-C, SIGTERM while waiting: the answer would come out of turn; end the child
            self._kill()
            raise
        if not ready:
            self._kill()
            raise FMUCrashed(self.name, function, self.time, hung=True,
                             detail=f"the FMU did not answer within {self.timeout if wait is None else wait:g} s (it hangs: "
                                    f"its isolated process was killed; if it is only slow, raise the isolation "
                                    f"timeout)")
        try:
            kind, value, failed = self._conn.recv()
        except (OSError, EOFError):
            code = self._reap()
            how = _signal_name(code) if code is not None and code < 0 else f"exit status {code}"
            raise FMUCrashed(self.name, function, self.time,
                             detail=f"the FMU's isolated process died ({how})") from None
        self.failed = bool(failed)
        if kind == "ok":
            return value
        cls, message, attrs = value
        err = cls.__new__(cls)
        Exception.__init__(err, message)
        err.__dict__.update(attrs)
        raise err

    def _reap(self) -> int | None:
        self.failed = True
        if self._conn is not None:
            self._conn.close()
            self._conn = None
        try:
            return self._proc.wait(timeout=5)
        except subprocess.TimeoutExpired:  # pragma: no cover - closed its socket yet still running
            self._proc.kill()
            return self._proc.wait()

    def _kill(self) -> None:
        if self._proc is not None and self._proc.poll() is None:
            self._proc.kill()
        self._reap()

    def _block(self, block: RealBlock) -> int:
        """The child's key of a block (its value references, registered once)."""
        key = id(block)
        known = self._blocks.get(key)
        if known is None or known[0] is not block:
            self._ask(f"{self._prefix}GetReal", "block", key, block.names)
            self._blocks[key] = (block,)
        return key

    # -- life cycle --------------------------------------------------------------------------------------------
    def setup(self, start_time: float = 0.0, stop_time: float | None = None, tolerance: float | None = None):
        self.time = start_time
        self._ask(f"{self._prefix}SetupExperiment", "setup", start_time, stop_time, tolerance)

    def enter_initialization(self) -> None:
        self._ask(f"{self._prefix}EnterInitializationMode", "enter_initialization")

    def exit_initialization(self) -> None:
        self._ask(f"{self._prefix}ExitInitializationMode", "exit_initialization")

    def terminate(self) -> None:
        if self.failed or self._conn is None:
            return
        self._ask(f"{self._prefix}Terminate", "terminate")

    def free(self) -> None:
        """Free the instance and end its process (a failed one is only reaped)."""
        if self._conn is not None and not self.failed:
            try:
                self._ask(f"{self._prefix}FreeInstance", "free")
                self._conn.send(([], "exit", ()))
            except (FMUError, OSError):
                pass
        if self._proc is not None:
            if self._conn is not None:
                self._conn.close()
                self._conn = None
            try:
                self._proc.wait(timeout=min(self.timeout, 10.0))
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
            self._proc = None

    def __del__(self):  # a run that never freed it: no child outlives its parent's instance
        proc = getattr(self, "_proc", None)
        if proc is not None and proc.poll() is None:
            proc.kill()

    # -- values ------------------------------------------------------------------------------------------------
    def get(self, block: RealBlock):
        if block.n:
            key = self._block(block)
            fresh = self._fresh_values
            block.values[:] = fresh[key] if fresh is not None and key in fresh else \
                self._ask(f"{self._prefix}GetReal", "get", key)
        return block.values

    def _write_reals(self, block: RealBlock) -> None:
        """Kept and sent with the next call (an FMU's error in it is raised by that call, with its own words)."""
        self._pending.append((self._block(block), block.values.tolist()))
        self._fresh_values = None

    def get_list(self, block: RealBlock) -> list:
        return self.get(block).tolist() if block.n else []

    def set_list(self, block: RealBlock, values: list) -> None:
        self.set(block, values)

    def set_input_derivatives(self, block: RealBlock, order: int, values) -> None:
        if block.n:
            self._ask(f"{self._prefix}SetRealInputDerivatives", "set_input_derivatives", self._block(block),
                      int(order), [float(v) for v in values])

    def set_value(self, name: str, value) -> None:
        self.var(name)
        self._ask(f"{self._prefix}Set", "set_value", name, value)

    def get_value(self, name: str):
        self.var(name)
        return self._ask(f"{self._prefix}Get", "get_value", name)

    def directional_derivative(self, unknowns: RealBlock, knowns: RealBlock, seed):
        import numpy as np

        return np.array(self._ask(f"{self._prefix}GetDirectionalDerivative", "directional_derivative",
                                  self._block(unknowns), self._block(knowns), [float(s) for s in seed]), dtype=float)

    # -- stepping ----------------------------------------------------------------------------------------------
    def do_step(self, t: float, h: float, no_prior_state: bool = False) -> None:
        self.time = t
        fresh = self._ask(f"{self._prefix}DoStep(h = {h:.6g} s)", "do_step", t, h, no_prior_state)
        self._fresh_values = fresh
        self.time = t + h

    # -- FMU state (rollback): the state stays in the child, the parent holds its number --------------------------
    def get_state(self, state=None):
        return self._ask(f"{self._prefix}GetFMUstate", "get_state", state)

    def set_state(self, state) -> None:
        self._ask(f"{self._prefix}SetFMUstate", "set_state", state)

    def free_state(self, state) -> None:
        self._ask(f"{self._prefix}FreeFMUstate", "free_state", state)

    def serialize_state(self, state) -> bytes:
        return self._ask(f"{self._prefix}SerializeFMUstate", "serialize_state", state)

    def deserialize_state(self, data: bytes):
        return self._ask(f"{self._prefix}DeSerializeFMUstate", "deserialize_state", data)


# -- the child ----------------------------------------------------------------------------------------------------
def _serve(conn: Connection) -> None:
    """Answer the parent's calls on one instance until it says exit or goes away."""
    from harness.fmi import open_instance

    inst = None
    blocks: dict[int, RealBlock] = {}
    states: dict[int, object] = {}
    counter = [0]

    def handle(op, args):
        nonlocal inst
        if op == "open":
            path, name, logging_on, in_process = args
            inst = open_instance(path, name, logging_on, in_process)
            return {k: getattr(inst, k) for k in _FLAGS if hasattr(inst, k)}
        if op == "block":
            key, names = args
            blocks[key] = inst.reals(names)
            return None
        if op == "get":
            return inst.get_list(blocks[args[0]])
        if op == "set":
            inst.set_list(blocks[args[0]], args[1])
            return None
        if op == "do_step":   # the answer carries every block's values after the step (the master reads them next)
            t, h, no_prior_state = args
            inst.do_step(t, h, no_prior_state=no_prior_state)
            return {key: inst.get_list(b) for key, b in blocks.items()}
        if op == "set_input_derivatives":
            return inst.set_input_derivatives(blocks[args[0]], args[1], args[2])
        if op == "directional_derivative":
            return [float(x) for x in inst.directional_derivative(blocks[args[0]], blocks[args[1]], args[2])]
        if op == "get_state":   # a new state gets the next number; a number given is overwritten
            key = args[0]
            if key is None:
                key = counter[0] = counter[0] + 1
            states[key] = inst.get_state(states.get(key))
            return key
        if op == "set_state":
            return inst.set_state(states[args[0]])
        if op == "free_state":
            return inst.free_state(states.pop(args[0]))
        if op == "serialize_state":
            return inst.serialize_state(states[args[0]])
        if op == "deserialize_state":
            key = counter[0] = counter[0] + 1
            states[key] = inst.deserialize_state(args[0])
            return key
        if op in ("setup", "enter_initialization", "exit_initialization", "terminate", "free", "set_value",
                  "get_value"):
            return getattr(inst, op)(*args)
        raise ValueError(f"unknown isolated call {op!r}")

    while True:
        try:
            pending, op, args = conn.recv()
        except (EOFError, OSError):
            return
        if op == "exit":
            return
        try:
            for key, values in pending:
                inst.set_list(blocks[key], values)
            value = handle(op, args)
        except FMUError as e:
            reply = ("error", (type(e), str(e), dict(e.__dict__)), True if inst is None else inst.failed)
        except Exception as e:  # noqa: BLE001 - anything else the FMU's wrapper raised, as one FMU error
            name = getattr(inst, "name", "?")
            err = FMUError(name, op, getattr(inst, "time", None), None, detail=f"{type(e).__name__}: {e}")
            reply = ("error", (FMUError, str(err), dict(err.__dict__)), True)
        else:
            reply = ("ok", value, False if inst is None else inst.failed)
        conn.send(reply)


def main(argv: list[str]) -> None:
    """``python -m harness.fmi.isolated FD``: serve one instance over the socket FD; the FMU's own prints go
    to stderr (stdout is not the parent's)."""
    os.dup2(2, 1)
    signal.signal(signal.SIGINT, signal.SIG_IGN)   # Ctrl-C is the parent's to handle (it keeps the rows)
    conn = Connection(int(argv[0]))
    try:
        _serve(conn)
    finally:
        conn.close()


if __name__ == "__main__":
    main(sys.argv[1:])
