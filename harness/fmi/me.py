"""Model Exchange FMUs as co-simulation instances: the FMU's equations integrated by an ODE solver of its own.

A Model Exchange FMU gives its state derivatives and event indicators, not a step.  FMPy, OMSimulator and PyFMI
integrate such FMUs themselves; here :class:`ModelExchange2` (FMI 2.0) and :class:`ModelExchange3` (FMI 3.0)
do so inside ``do_step`` (one loop, :class:`_Integrated`, over either version's calls) and offer
the master the same :class:`~harness.fmi.fmu.Instance` interface as a co-simulation FMU, so it can be one
component of a co-simulation like any other.  Over a communication step [t, t + h] its inputs are held (the
master sets them before the step, as for a co-simulation FMU that cannot interpolate inputs), and

* the solver is SUNDIALS CVODE (BDF, dense linear solver) as FMPy ships it (:class:`fmpy.sundials.CVodeSolver`),
  with its root finding on the event indicators: a **state event** stops the integration where an indicator
  changes sign (scipy's BDF with its event location where FMPy has no CVODE: :class:`_ScipySolver`);
* a **time event** (``nextEventTime`` from fmi2NewDiscreteStates / fmi3UpdateDiscreteStates) is a point the
  integration stops at;
* a **step event** is what fmi2/3CompletedIntegratorStep asks for after each integration segment;
* at each event the FMU goes through event mode (EnterEventMode, NewDiscreteStates / UpdateDiscreteStates
  until no more are needed, EnterContinuousTimeMode) and the solver restarts from the new state;
* an input set since the last step (a discontinuity of the right-hand side for the solver) restarts it at the
  step's start; a discrete input (Integer, Boolean, String, or a Real of discrete variability) is set in event
  mode, as FMI 2.0 and 3.0 require, and the event is completed at the step's start.

This is the loop of ``fmpy.simulation.simulateME``, restricted to one communication step; with the same
relative tolerance and maximum solver step (:class:`SolverSettings`) a standalone ME FMU gives what
``fmpy.simulate_fmu`` gives on the same output grid (tests/test_fmi_content.py).  An FMU that can get and set
its state (``canGetAndSetFMUstate``) rolls back: the saved state holds the time, and the solver restarts from
the restored state.  Errors inside the solver's callbacks (an FMU call failing while CVODE evaluates the
right-hand side) stop the integration and are raised as the FMU's own :class:`~harness.errors.FMUError`
(the FMU's message), not only as CVODE's "the right-hand side routine failed".
"""
from __future__ import annotations

import math
from ctypes import POINTER, byref, c_double, c_int, c_size_t, cast
from dataclasses import dataclass
from pathlib import Path

from fmpy.fmi1 import FMICallException

from harness.errors import FMUError
from harness.fmi.fmu import FMU, RealBlock
from harness.fmi.fmu3 import FMU3


@dataclass(frozen=True)
class SolverSettings:
    """The ME component's own solver settings.  ``rtol``: CVODE's relative tolerance (absolute tolerance =
    rtol x each state's nominal, as FMPy sets it); None takes the run's ``tolerance`` if one is given, else
    :data:`DEFAULT_RTOL`.
    ``max_step`` [s]: the largest internal step; None is FMPy's choice, (stop - start) / 50, or no limit
    without a stop time.  ``max_steps``: internal steps allowed per integration segment (FMPy: 500).
    ``solver``: "cvode" (FMPy's SUNDIALS CVODE; where FMPy ships no CVODE for the platform, scipy's is taken,
    with one warning) or "scipy" (:class:`_ScipySolver`: scipy's BDF with event location, the fallback)."""

    rtol: float | None = None
    max_step: float | None = None
    max_steps: int = 500
    solver: str = "cvode"

    def __post_init__(self):
        if self.solver not in SOLVERS:
            raise ValueError(f"SolverSettings.solver = {self.solver!r} is not admissible: must be one of "
                             f"{', '.join(SOLVERS)}")
        for name in ("rtol", "max_step"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"SolverSettings.{name} = {v!r} is not admissible: must be a positive number")
        if not (isinstance(self.max_steps, int) and self.max_steps > 0):
            raise ValueError(f"SolverSettings.max_steps = {self.max_steps!r} is not admissible: must be a "
                             f"positive integer")


DEFAULT_RTOL = 1e-10
"""CVODE's relative tolerance when neither ``SolverSettings.rtol`` nor the run's ``tolerance`` gives one.  The solver
restarts at every communication step (the held inputs change), so its error adds up over the steps instead of
staying at the tolerance; the component's error must stay below the coupling's (the measurements that chose this
value are in CHANGELOG.md).
"""
SOLVERS = ("cvode", "scipy")


class SolverFallback(UserWarning):
    """A Model Exchange FMU is integrated by scipy because FMPy ships no CVODE for this platform."""


class _NoInput:
    """fmpy's solver re-applies input signals in its root function; the master has set the inputs already."""

    @staticmethod
    def apply(*args, **kwargs) -> None:
        return None


def _solver_class(name: str = "cvode"):
    """The solver class: scipy's (:class:`_ScipySolver`), or fmpy's CVodeSolver with callbacks that stop
    CVODE on an exception (status -1) and keep it, instead of letting ctypes print it to stderr (then CVODE
    says only that "the right-hand side routine failed")."""
    if name == "scipy":
        return _ScipySolver
    try:
        from fmpy.sundials import CVodeSolver
    except Exception as e:  # no CVODE library for this platform in FMPy
        import warnings

        warnings.warn(SolverFallback(f"FMPy's CVODE is not available here ({type(e).__name__}: {e}); Model "
                                     f"Exchange FMUs are integrated by scipy's BDF"), stacklevel=3)
        return _ScipySolver

    class Solver(CVodeSolver):
        failure: BaseException | None = None

        def f(self, t, y, ydot, user_data):
            try:
                return super().f(t, y, ydot, user_data)
            except BaseException as e:  # noqa: BLE001 - handed back to the caller by ModelExchange2._integrate
                self.failure = e
                return -1

        def g(self, t, y, gout, user_data):
            try:
                return super().g(t, y, gout, user_data)
            except BaseException as e:  # noqa: BLE001
                self.failure = e
                return -1

    return Solver


class _ScipySolver:
    """The fallback solver: scipy's ``solve_ivp`` (BDF) over one segment, its event location on the event
    indicators (every indicator an event function, terminal), with the interface of fmpy's CVodeSolver
    (``step(t, t_next)`` -> (state event, roots, time reached), ``reset(t)``).  Without continuous states a
    dummy state (x' = 0) lets the event location run, as fmpy does for CVODE."""

    failure: BaseException | None = None

    def __init__(self, nx, nz, get_x, set_x, get_dx, get_z, get_nominals, set_time, input, startTime,
                 maxStep=float("inf"), relativeTolerance=1e-5, maxNumSteps=500):
        import numpy as np

        self.np = np
        self.nx, self.nz = nx, nz
        self.get_x, self.set_x, self.get_dx = get_x, set_x, get_dx
        self.get_z, self.get_nominals = get_z, get_nominals
        self.set_time, self.max_step, self.rtol = set_time, maxStep, relativeTolerance
        self.x = np.zeros(max(nx, 1))
        self.dx = np.zeros(max(nx, 1))
        self.z = np.zeros(nz)
        self.atol = np.full(max(nx, 1), relativeTolerance)
        self.reset(startTime)

    def _p(self, array):
        return array.ctypes.data_as(POINTER(c_double))

    def _load(self, t, y) -> None:
        self.set_time(t)
        if self.nx:
            self.x[:] = y
            self.set_x(self._p(self.x), self.nx)

    def _rhs(self, t, y):
        self._load(t, y)
        if not self.nx:
            return self.np.zeros(1)
        self.get_dx(self._p(self.dx), self.nx)
        return self.dx.copy()

    def _indicator(self, i: int, direction: float = 0.0):
        def event(t, y):
            self._load(t, y)
            self.get_z(self._p(self.z), self.nz)
            return self.z[i]
        event.terminal = True
        event.direction = direction
        return event

    def _directions(self, t, t_next, y0) -> list[float]:
        """Per indicator, the crossing direction to look for: any, except for an indicator (about) zero at the
        segment's start (just after an event): only a crossing against the way it is leaving zero, so that
        the event just handled is not found again at the start (CVODE treats such roots as inactive)."""
        np = self.np
        z0 = np.zeros(self.nz)
        self._load(t, y0)
        self.get_z(self._p(z0), self.nz)
        small = np.abs(z0) <= 1e-10 * (1.0 + np.abs(z0).max())
        if not small.any():
            return [0.0] * self.nz
        h = 1e-6 * (t_next - t)
        y1 = y0 + h * self._rhs(t, y0) if self.nx else y0
        z1 = np.zeros(self.nz)
        self._load(t + h, y1)
        self.get_z(self._p(z1), self.nz)
        return [float(-np.sign(z1[i] - z0[i])) if small[i] else 0.0 for i in range(self.nz)]

    def reset(self, time) -> None:
        if self.nx:
            self.get_x(self._p(self.x), self.nx)
            nominals = self.np.zeros(self.nx)
            self.get_nominals(self._p(nominals), self.nx)
            self.atol = self.rtol * nominals

    def step(self, t, t_next):
        from scipy.integrate import solve_ivp

        if self.nx:
            self.get_x(self._p(self.x), self.nx)
        y0 = self.x.copy() if self.nx else self.np.zeros(1)
        directions = self._directions(t, t_next, y0) if self.nz else []
        events = [self._indicator(i, d) for i, d in enumerate(directions)]
        sol = solve_ivp(self._rhs, (t, t_next), y0, method="BDF", rtol=self.rtol, atol=self.atol,
                        max_step=self.max_step, events=events or None, dense_output=bool(events))
        if sol.status < 0:
            raise RuntimeError(f"scipy solve_ivp failed: {sol.message}")
        roots = self.np.zeros(self.nz, dtype=self.np.int32)
        if sol.status == 1:
            hits = [(te[0], i) for i, te in enumerate(sol.t_events) if len(te)]
            t_end = min(h[0] for h in hits)
            first = [i for when, i in hits if when == t_end]
            roots[first] = 1
            t_end, y_end = self._past_root(sol, t, t_end, t_next, first, events)
        else:
            t_end, y_end = t_next, sol.y[:, -1]
        self._load(t_end, y_end)
        return sol.status == 1, roots, float(t_end)

    def _past_root(self, sol, t, t_root, t_next, crossed, events):
        """The first point at or after the located root where the indicator has really changed sign: scipy
        locates a root to rounding, on either side; the FMU decides its event from the sign (CVODE, too,
        returns the point past the root)."""
        before = {i: events[i](t, sol.sol(t)) for i in crossed}
        delta = 1e-15 * max(1.0, abs(t_root))
        when = t_root
        while when < t_next:
            y = sol.sol(when)
            if all(events[i](when, y) * before[i] <= 0.0 for i in crossed):
                return when, y
            when = min(t_root + delta, t_next)
            delta *= 4.0
        return t_next, sol.sol(t_next)


class _MEState:
    """A saved ME instance: the FMU's fmi2FMUstate, the time it was taken at and the FMU's mode then
    (continuous time, or event mode when a discrete input had been set) and its next time event."""

    __slots__ = ("fmu_state", "time", "mode", "next_event")

    def __init__(self, fmu_state, time, mode, next_event):
        self.fmu_state, self.time, self.mode, self.next_event = fmu_state, time, mode, next_event


class _Integrated:
    """The integration of a Model Exchange FMU over communication steps (module docstring), on top of an FMI
    wrapper (:class:`~harness.fmi.fmu.FMU` or :class:`~harness.fmi.fmu3.FMU3`) that supplies the FMI calls
    of its version through the ``_fmi_*`` methods."""

    path_kind = "me"

    def _init_integration(self, settings: SolverSettings | None, nx: int, nz: int, needs_completed_step: bool):
        self.settings = settings or SolverSettings()
        self.nx, self.nz = int(nx), int(nz)
        self.needs_completed_step = bool(needs_completed_step)
        self._start, self._stop, self._rtol = 0.0, None, DEFAULT_RTOL
        self._mode = "instantiated"          # -> "initialization" -> "event" / "continuous"
        self._solver = None
        self._restart = True                 # the solver restarts at the next step's start
        self._next_event: float | None = None
        self._t = 0.0                        # the FMU's time (fmi2SetTime / fmi3SetTime)
        self._discrete = {v.name for v in self.md.modelVariables if v.causality == "input"
                          and (v.type != "Real" or v.variability == "discrete")}
        self._discrete_blocks: dict[int, bool] = {}   # id(RealBlock) -> holds a discrete input

    # -- life cycle --------------------------------------------------------------------------------------------
    def setup(self, start_time: float = 0.0, stop_time: float | None = None, tolerance: float | None = None):
        super().setup(start_time, stop_time, tolerance)
        self._start, self._stop, self._t = float(start_time), stop_time, float(start_time)
        self._rtol = self.settings.rtol or tolerance or DEFAULT_RTOL

    def enter_initialization(self) -> None:
        super().enter_initialization()
        self._mode = "initialization"

    def exit_initialization(self) -> None:
        super().exit_initialization()
        self._mode = "event"
        self._event_iteration("the initial event iteration")

    def _event_iteration(self, when: str) -> None:
        """Update the discrete states until the FMU needs no more, then continuous-time mode (from event mode)."""
        more = True
        while more:
            more, terminate, self._next_event = self._fmi_update_discrete()
            if terminate:
                raise FMUError(self.name, "event iteration", self._t, None,
                               detail=f"the FMU asked to terminate the simulation in {when} at t = {self._t:.6g} s")
        self._fmi_enter_continuous()
        self._mode = "continuous"
        self._restart = True

    def terminate(self) -> None:
        self._solver = None
        super().terminate()

    def free(self) -> None:
        self._solver = None
        super().free()

    # -- inputs: a set input restarts the solver; a discrete one is set in event mode ---------------------------
    def _before_setting(self, block: RealBlock) -> None:
        """Event mode first if the block holds a Real input of discrete variability (FMI: set in event mode)."""
        discrete = self._discrete_blocks.get(id(block))
        if discrete is None:
            discrete = self._discrete_blocks[id(block)] = any(n in self._discrete for n in block.names)
        if discrete:
            self._to_event_mode()

    def _to_event_mode(self) -> None:
        """Enter event mode unless already in it (a discrete input set, an event found while integrating)."""
        if self._mode == "continuous":
            self._fmi_enter_event_mode()
            self._mode = "event"

    def set(self, block: RealBlock, values=None) -> None:
        self._before_setting(block)
        super().set(block, values)
        self._restart = True

    def set_list(self, block: RealBlock, values: list) -> None:
        self._before_setting(block)
        super().set_list(block, values)
        self._restart = True

    def set_value(self, name: str, value) -> None:
        if name in self._discrete:
            self._to_event_mode()
        super().set_value(name, value)
        self._restart = True

    # -- stepping ----------------------------------------------------------------------------------------------
    def _set_time(self, t: float) -> None:
        self._t = t
        self._fmi_set_time(t)

    def _new_solver(self, t: float):
        """CVODE from the FMU's current state at ``t`` (module docstring)."""
        max_step = self.settings.max_step
        if max_step is None:
            max_step = (self._stop - self._start) / 50.0 if self._stop is not None else float("inf")
        get_x, set_x, get_dx, get_z, get_nominals = self._fmi_vectors()
        cls = _solver_class(self.settings.solver)
        return cls(nx=self.nx, nz=self.nz, get_x=get_x, set_x=set_x, get_dx=get_dx, get_z=get_z,
                   get_nominals=get_nominals, set_time=self._set_time, input=_NoInput(), startTime=t,
                   maxStep=max_step, relativeTolerance=self._rtol, maxNumSteps=self.settings.max_steps)

    def _integrate(self, t: float, t_next: float) -> tuple[bool, float]:
        """One solver segment from ``t`` towards ``t_next``: (state event, time reached)."""
        solver = self._solver
        solver.failure = None
        try:
            state_event, _, reached = solver.step(t, t_next)
        except RuntimeError as e:
            if solver.failure is not None:
                raise solver.failure from None
            raise FMUError(self.name, "CVode", t, None, detail=" ".join(str(e).split())) from None
        if solver.failure is not None:  # pragma: no cover - CVODE reports a failed callback as an error
            raise solver.failure
        return state_event, reached

    def do_step(self, t: float, h: float, no_prior_state: bool = False) -> None:
        """Integrate from ``t`` to ``t + h`` with the inputs held, handling every event on the way."""
        self.time = t
        if self._mode == "event":  # a discrete input was set: complete its event first
            self._event_iteration(f"the event of a discrete input at t = {t:.6g} s")
        end = t + h
        now = self._t = t
        eps = 1e-12 * max(1.0, abs(end))
        while end - now > eps:
            if self._restart or self._solver is None:
                self._set_time(now)
                self._solver = self._new_solver(now) if self._solver is None else self._solver
                self._solver.reset(now)
                self._restart = False
            target = end
            if self._next_event is not None and now - eps < self._next_event < end - eps:
                target = self._next_event
            state_event, now = self._integrate(now, target)
            self._set_time(now)
            step_event = False
            if self.needs_completed_step:
                step_event, terminate = self._fmi_completed_step()
                if terminate:
                    raise FMUError(self.name, "completed integrator step", now, None,
                                   detail=f"the FMU asked to terminate the simulation at t = {now:.6g} s")
            time_event = self._next_event is not None and abs(now - self._next_event) <= eps
            if state_event or time_event or step_event:
                self._to_event_mode()
                self._event_iteration(f"the event at t = {now:.6g} s")
        if now != end:  # within eps: the communication point itself, exactly
            self._set_time(end)
        self.time = end

    # -- FMU state (rollback) ----------------------------------------------------------------------------------
    def get_state(self, state=None):
        """The FMU's state, its time, mode and next time event; the solver restarts from it when it is set."""
        if state is None:
            return _MEState(super().get_state(), self._t, self._mode, self._next_event)
        super().get_state(state.fmu_state)
        state.time, state.mode, state.next_event = self._t, self._mode, self._next_event
        return state

    def set_state(self, state) -> None:
        super().set_state(state.fmu_state)
        self._t, self._mode, self._next_event = state.time, state.mode, state.next_event
        self._restart = True

    def free_state(self, state) -> None:
        super().free_state(state.fmu_state)

    def serialize_state(self, state) -> bytes:
        """The FMU's own bytes behind a JSON line of the solver's time, mode and next time event."""
        import json

        head = json.dumps([state.time, state.mode, state.next_event]).encode()
        return head + b"\n" + super().serialize_state(state.fmu_state)

    def deserialize_state(self, data: bytes):
        import json

        head, _, rest = bytes(data).partition(b"\n")
        t, mode, next_event = json.loads(head)
        return _MEState(super().deserialize_state(rest), t, mode, next_event)


class ModelExchange2(_Integrated, FMU):
    """One instance of an FMI 2.0 Model Exchange FMU, stepped as a co-simulation instance (module docstring)."""

    path_kind = "me2"

    def __init__(self, path: str | Path, name: str, logging_on: bool = True,
                 settings: SolverSettings | None = None):
        FMU.__init__(self, path, name, logging_on, model_exchange=True)
        self._init_integration(settings, self.md.numberOfContinuousStates or 0,
                               self.md.numberOfEventIndicators or 0,
                               self.md.modelExchange.needsCompletedIntegratorStep)

    def _fmi_set_time(self, t: float) -> None:
        self._fmi("fmi2SetTime", self.c, t)

    def _fmi_enter_event_mode(self) -> None:
        self._fmi("fmi2EnterEventMode", self.c)

    def _fmi_enter_continuous(self) -> None:
        self._fmi("fmi2EnterContinuousTimeMode", self.c)

    def _fmi_update_discrete(self):
        from fmpy.fmi2 import fmi2EventInfo

        info = fmi2EventInfo()
        self._fmi("fmi2NewDiscreteStates", self.c, byref(info))
        return (bool(info.newDiscreteStatesNeeded), bool(info.terminateSimulation),
                float(info.nextEventTime) if info.nextEventTimeDefined else None)

    def _fmi_completed_step(self):
        enter, terminate = c_int(0), c_int(0)
        self._fmi("fmi2CompletedIntegratorStep", self.c, 1, byref(enter), byref(terminate))
        return bool(enter.value), bool(terminate.value)

    def _fmi_vectors(self):
        def vector(function: str):
            fn = getattr(self._slave, function)   # FMPy's public function (FMU._fmi), bound once

            def call(pointer, n):
                try:
                    fn(self.c, cast(pointer, POINTER(c_double)), n)
                except FMICallException as e:
                    self._check(e.status, function)
            return call
        return tuple(vector(f) for f in ("fmi2GetContinuousStates", "fmi2SetContinuousStates", "fmi2GetDerivatives",
                                         "fmi2GetEventIndicators", "fmi2GetNominalsOfContinuousStates"))


class ModelExchange3(_Integrated, FMU3):
    """One instance of an FMI 3.0 Model Exchange FMU, stepped as a co-simulation instance (module docstring;
    the FMI 3.0 calls of the same loop: fmi3UpdateDiscreteStates, fmi3GetContinuousStateDerivatives...)."""

    path_kind = "me3"

    def __init__(self, path: str | Path, name: str, logging_on: bool = True,
                 settings: SolverSettings | None = None):
        FMU3.__init__(self, path, name, logging_on, model_exchange=True)
        nx, nz = c_size_t(), c_size_t()
        self._call("fmi3GetNumberOfContinuousStates", self._slave.fmi3GetNumberOfContinuousStates, self._c, byref(nx))
        self._call("fmi3GetNumberOfEventIndicators", self._slave.fmi3GetNumberOfEventIndicators, self._c, byref(nz))
        self._init_integration(settings, nx.value, nz.value, self.md.modelExchange.needsCompletedIntegratorStep)

    def _fmi_set_time(self, t: float) -> None:
        self._call("fmi3SetTime", self._slave.fmi3SetTime, self._c, t)

    def _fmi_enter_event_mode(self) -> None:
        self._call("fmi3EnterEventMode", self._slave.fmi3EnterEventMode, self._c)

    def _fmi_enter_continuous(self) -> None:
        self._call("fmi3EnterContinuousTimeMode", self._slave.fmi3EnterContinuousTimeMode, self._c)

    def _fmi_update_discrete(self):
        from fmpy.fmi3 import fmi3Boolean, fmi3Float64

        more, terminate, nominals, values, defined = (fmi3Boolean() for _ in range(5))
        next_time = fmi3Float64()
        self._call("fmi3UpdateDiscreteStates", self._slave.fmi3UpdateDiscreteStates, self._c, byref(more),
                   byref(terminate), byref(nominals), byref(values), byref(defined), byref(next_time))
        return bool(more.value), bool(terminate.value), float(next_time.value) if defined.value else None

    def _fmi_completed_step(self):
        from fmpy.fmi3 import fmi3Boolean

        enter, terminate = fmi3Boolean(), fmi3Boolean()
        self._call("fmi3CompletedIntegratorStep", self._slave.fmi3CompletedIntegratorStep, self._c, True,
                   byref(enter), byref(terminate))
        return bool(enter.value), bool(terminate.value)

    def _fmi_vectors(self):
        def vector(function: str):
            method = getattr(self._slave, function)

            def call(pointer, n):
                self._call(function, method, self._c, cast(pointer, POINTER(c_double)), n)
            return call
        return tuple(vector(f) for f in ("fmi3GetContinuousStates", "fmi3SetContinuousStates",
                                         "fmi3GetContinuousStateDerivatives", "fmi3GetEventIndicators",
                                         "fmi3GetNominalsOfContinuousStates"))


__all__ = ["ModelExchange2", "ModelExchange3", "SolverSettings", "SolverFallback", "SOLVERS"]
