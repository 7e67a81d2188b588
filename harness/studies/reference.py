"""Monolithic reference of a system, assembled from the same equations the FMUs use.

Every instance of a toolkit FMU is replaced by its pure model (``fmus.physics``), the system's connections
become algebraic assignments evaluated at every right-hand-side call, and the whole state vector is
integrated by scipy (``Radau`` by default: stiff-capable; tight tolerances), so the result has no coupling
error at all.  Output evaluation follows the direct-feedthrough graph of the components: instances are taken
in topological order of the strongly connected components of the instance graph, and an SCC (e.g. a four-bar
and a differential that feed each other's reactions) is swept as often as it has members, which is exact
whenever the variable-level graph has no algebraic loop (the masters detect and report those).

Five kinds of state are not plain ODE states and get explicit treatment here (the table ``_KINDS`` below,
keyed by model class and fidelity, is the only place that knows about them):

* *algebraic* states of rigid (fidelity-0) levels that ``advance`` sets from the held inputs (FourBar,
  JamesDifferential and GearSectors kinematics, the FlywheelShaft's rigid-shaft torque): their derivative is
  taken as 0 and the state is projected with a zero-length ``advance(t, 0, x, u)`` before every output
  evaluation, which is the FMU's own equation at h -> 0;
* *contact memory* of clearance joints (CamRocker and FourBar at fidelity 2: approach speed at the onset,
  onset counter, contact flag, separation speed): contact onset and separation are ``solve_ivp`` events on
  ``|q| - clearance/2`` (direction chosen by the joint's current mode, so a root is never counted twice); at
  each the memory is updated exactly as the FMU's ``advance`` does and the integration restarts, so impacts
  are resolved to the integrator's tolerance instead of to a sub-step.  A restart sits ON the contact's
  kink (the Kelvin-Voigt damping force jumps at the onset, the no-pull clip bends it), where Radau's Newton
  iteration may fail to take any step ("required step size is less than spacing between numbers"): that
  segment is then integrated with ``BDF``, the other stiff method, at the same tolerances (counted in
  ``attrs["fallbacks"]``);
* *a brake* (MotorBelt with a holding torque): its taking hold (the timer reaching the delay), a sliding
  rotor's stop and a held rotor's breaking loose are events too; while it slides, the friction keeps the
  slide's sense (also where a stage of the integrator overshoots zero), while it holds, the rotor's angle and
  speed are frozen;
* *an end stop* (a jam: RackBed, ParallelShafts with a stop): the tool reaching the stop and leaving it are
  events (its force's kink), and where it reaches a catch the memory ``stop_caught`` is set as the FMU's step
  sets it;
* *step memory*: RackBed at fidelity 0 estimates the bed acceleration from the inputs of successive
  communication steps; a monolithic model has no steps, so that level is refused with a one-line error
  (use fidelity 1).

Input signals (:class:`harness.signals.Signals`, a scenario's steps and ramps) are the free inputs' values
over time; every row of their table ends an integration stretch (inside one the inputs are continuous; at a
step the stretch's end sees the value before it), and at its end the models whose inputs set memory at once
(``Model.input_memory``: a released brake restarts its timer) are updated as their FMUs are.

The result has the co-simulation's shape: a DataFrame on the given time grid with ``Instance.variable``
columns for every input and output.
"""
from __future__ import annotations

import importlib
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from harness.master import graph
from harness.master.clock import NS
from harness.model import model_name

ROOT = Path(__file__).resolve().parents[2]


class ReferenceError_(ValueError):
    pass


def component_classes() -> dict[str, type]:
    """Model name -> its declaration class (fmus.declaration.Component), for every FMU in fmus/components."""
    from fmus.build import catalog

    return {name: getattr(importlib.import_module(f"fmus.components.{script.stem}"), name)
            for name, script in catalog().items()}


@dataclass
class _Wire:
    src: int        # source instance index
    out: int        # index into the source model's outputs
    factor: float
    offset: float



class _Switch:
    """A switch of instance ``i`` seen by the reference: armed in its current mode (:meth:`arm`), its event
    function's ``value`` crosses zero in ``direction`` when the mode ends, and :meth:`switch` updates the
    instance's state there; the integration then restarts with every switch armed again."""

    def __init__(self, i: int, model):
        self.i, self.model = i, model

    @classmethod
    def applies(cls, model) -> bool:
        return True

    def arm(self, t, x, u) -> None:
        pass

    direction = 0.0

    def value(self, t, x, u) -> float:
        raise NotImplementedError

    def switch(self, t, x, u) -> np.ndarray:
        raise NotImplementedError

    def derivatives(self, t, x, u):
        """The instance's state derivatives in this mode, or None: the model's own (a mode that fixes a law the
        state alone would switch, e.g. the sense of a sliding friction, keeps it fixed until its event)."""
        return None


class _Contact(_Switch):
    """A clearance joint: its gap against half the clearance, and its memory update."""

    def __init__(self, i: int, model):
        super().__init__(i, model)
        self.half = 0.5 * model.p.clearance
        self.in_contact = None

    @classmethod
    def applies(cls, model) -> bool:
        return model.p.clearance > 0.0

    def arm(self, t, x, u) -> None:
        if self.in_contact is None:  # the start; afterwards the mode changes only at its own events
            self.in_contact = abs(self.gap(t, x, u)[0]) > self.half
        self.direction = -1.0 if self.in_contact else 1.0

    def value(self, t, x, u) -> float:
        return abs(self.gap(t, x, u)[0]) - self.half

    def gap(self, t, x, u) -> tuple[float, float]:
        raise NotImplementedError

    def switch(self, t, x, u) -> np.ndarray:
        """The joint's memory after the onset (mode separated) or the separation (mode in contact)."""
        raise NotImplementedError


class _FourBarContact(_Contact):
    def gap(self, t, x, u):
        return self.model._gap(t, x, u, t)

    def switch(self, t, x, u):
        from fmus.physics.fourbar import COUNT, LAST_V, REBOUND, V_IMPACT

        x = np.array(x, dtype=float)
        v = abs(self.gap(t, x, u)[1])
        if self.in_contact:          # separation: the FMU stores the separation speed
            x[REBOUND] = v
        else:                        # onset: approach speed, last onset speed, onset counter
            x[V_IMPACT], x[LAST_V], x[COUNT] = v, v, x[COUNT] + 1.0
        self.in_contact = not self.in_contact
        return x


class _CamRockerContact(_Contact):
    def gap(self, t, x, u):
        m = self.model
        q, qd, *_ = m._pin(*m._kin(u[0]), u[1], x)
        return q, qd

    def switch(self, t, x, u):
        x = np.array(x, dtype=float)
        if self.in_contact:          # separation: contact flag down (CamRockerModel._update_contact)
            x[4] = 0.0
        else:                        # onset: flag up, counter + 1, approach speed
            x[4], x[3], x[2] = 1.0, x[3] + 1.0, abs(self.gap(t, x, u)[1])
        self.in_contact = not self.in_contact
        return x


class _Brake(_Switch):
    """MotorBelt's rotor brake: commanded, it takes hold when its timer reaches the delay; sliding, the rotor's
    speed reaching zero stops it; held, the rotor's other torques reaching the holding torque set it sliding.
    While it slides, its friction keeps the slide's sense (also where a stage of the integrator overshoots zero),
    while it holds, the rotor's angle and speed are frozen (the rest of the drive moves on).  A brake of another
    model names its speed, timer and command (``SPEED``, ``TIMER``, ``COMMAND``) and overrides the accessors."""

    SPEED, TIMER, COMMAND = 1, 3, 3     # indices in x, x and u
    mode = "released"                   # until armed: the model's own derivatives

    @classmethod
    def applies(cls, model) -> bool:
        return model.p.holding_torque > 0.0

    def holding(self) -> float:
        return self.model.p.holding_torque

    def delay(self) -> float:
        return self.model.p.brake_delay

    def at_rest(self, t, x, u) -> float:
        """The braked part's other torques at rest [N.m]."""
        return self.model.rotor_torque_at_rest(t, x, u, t)

    def sliding(self, t, x, u, friction: float) -> np.ndarray:
        """dx/dt with the brake's torque ``friction``."""
        return self.model.derivatives_with(t, x, u, t, friction)

    loose = False  # the held rotor has just broken loose: arm it sliding (its torques sit at the holding torque)

    def arm(self, t, x, u) -> None:
        loose, self.loose = self.loose, False
        speed = x[self.SPEED]
        if u[self.COMMAND] < 0.5:
            self.mode = "released"
        elif x[self.TIMER] < self.delay():
            self.mode, self.direction = "engaging", 1.0
        elif speed != 0.0:
            self.mode, self.direction, self.sense = "sliding", -1.0, math.copysign(1.0, speed)
        elif not loose and abs(self.at_rest(t, x, u)) <= self.holding():
            self.mode, self.direction = "held", -1.0
        else:
            self.mode, self.direction = "sliding", -1.0
            self.sense = math.copysign(1.0, self.at_rest(t, x, u))

    def value(self, t, x, u) -> float:
        if self.mode == "engaging":
            return x[self.TIMER] - self.delay()
        if self.mode == "sliding":
            return self.sense * x[self.SPEED]
        if self.mode == "held":
            return self.holding() - abs(self.at_rest(t, x, u))
        return 1.0

    def switch(self, t, x, u) -> np.ndarray:
        x = np.array(x, dtype=float)
        if self.mode == "engaging":
            x[self.TIMER] = max(x[self.TIMER], self.delay())
        elif self.mode == "sliding":
            x[self.SPEED] = 0.0
        elif self.mode == "held":
            self.loose = True
        return x

    def derivatives(self, t, x, u):
        if self.mode == "sliding":   # the friction's sense is the slide's, also where a stage overshoots zero
            return self.sliding(t, x, u, -self.holding() * self.sense)
        if self.mode == "held":      # the braked part frozen; the brake's reaction holds it
            dx = self.sliding(t, x, u, -self.at_rest(t, x, u))
            dx[self.SPEED - 1] = dx[self.SPEED] = 0.0
            return dx
        return None


class _ClutchBrake(_Brake):
    """The clutch-brake of a ClutchBrakeShaft: the same switches on the crank side (its speed, timer, command)."""

    SPEED, TIMER, COMMAND = 3, 5, 3

    @classmethod
    def applies(cls, model) -> bool:
        return model.p.cb_torque > 0.0

    def holding(self) -> float:
        return self.model.p.cb_torque

    def delay(self) -> float:
        return self.model.p.cb_delay

    def at_rest(self, t, x, u) -> float:
        return u[1] + u[2]

    def sliding(self, t, x, u, friction: float) -> np.ndarray:
        if x[self.TIMER] < self.delay() or u[self.COMMAND] < 0.5:
            return self.model.derivatives(t, x, u, t)
        return self.model.derivatives_open(t, x, u, friction)


class _EndStop(_Switch):
    """An end stop (a jam) of a model with :class:`fmus.physics.contact.EndStop`: the tool's coordinate against
    the stop's position.  Where it reaches the stop a catch keeps it (the memory ``stop_caught`` set, as the FMU's
    step does), and an end stop's force has its kink (an event restarts the integration there, and where the tool
    leaves it); a caught tool has no switch left."""

    @classmethod
    def applies(cls, model) -> bool:
        return model.has_stop

    def __init__(self, i: int, model):
        super().__init__(i, model)
        self.q = model.outputs.index(model.stop_signals[0])
        self.memory = [s.name for s in model.states].index("stop_caught")
        self.mode = "clear"

    def arm(self, t, x, u) -> None:
        if x[self.memory] >= 0.5:
            self.mode, self.direction = "caught", 0.0
        elif self.value(t, x, u) > 0.0:
            self.mode, self.direction = "contact", -1.0
        else:
            self.mode, self.direction = "clear", 1.0

    def value(self, t, x, u) -> float:
        if self.mode == "caught":
            return 1.0
        return self.model.stop_penetration(self.model.output(t, x, u)[self.q])

    def switch(self, t, x, u) -> np.ndarray:
        x = np.array(x, dtype=float)
        if self.mode == "clear" and self.model.p.stop_catch:
            x[self.memory] = 1.0
        return x


# (model class name, fidelity) -> kind of the non-ODE state (see the module docstring)
_KINDS: dict[tuple[str, int], object] = {
    ("FourBarModel", 0): "algebraic",
    ("JamesDifferentialModel", 0): "algebraic",
    ("GearSectorsModel", 0): "algebraic",
    ("FlywheelShaftModel", 0): "algebraic",
    ("FourBarModel", 2): _FourBarContact,
    ("CamRockerModel", 2): _CamRockerContact,
    ("MotorBeltModel", 1): _Brake,
    ("MotorBeltModel", 2): _Brake,
    ("ClutchBrakeShaftModel", 1): _ClutchBrake,
    ("ParallelShaftsModel", 0): _EndStop,
    ("ParallelShaftsModel", 1): _EndStop,
    ("RackBedModel", 1): _EndStop,
    ("RackBedModel", 0): "RackBed fidelity 0 estimates the bed acceleration from the inputs of successive "
                         "communication steps, which a monolithic model does not have; use fidelity 1",
}


class Monolithic:
    """The assembled ODE of a system: ``rhs(t, X)``, ``signals(t, X)`` and ``simulate(...)``."""

    def __init__(self, system, parameters: dict | None = None, inputs=None):
        """``inputs``: the run's input signals (:class:`harness.signals.Signals`), or None: every free input at
        its start value."""
        classes = component_classes()
        parameters = dict(parameters or {})
        self.names, self.models, self.slices, self.classes = [], [], [], []
        self.values: list[dict] = []   # per instance: the parameters its model was built from
        n = 0
        for inst in system.instances:
            mname = model_name(inst.fmu)
            if mname not in classes:
                raise ReferenceError_(f"instance {inst.name}: FMU {mname} is not a toolkit component, "
                                      f"so no monolithic reference can be assembled")
            cls = classes[mname]
            values = {s.name: s.default for s in cls.model.Params.specs()}
            values.update(inst.parameters)
            prefix = inst.name + "."
            values.update({k[len(prefix):]: v for k, v in parameters.items() if k.startswith(prefix)})
            model = cls.model(cls.model.Params.from_mapping(values))
            self.values.append(values)
            self.names.append(inst.name)
            self.models.append(model)
            self.classes.append(cls)
            self.slices.append(slice(n, n + len(cls.model.states)))
            n += len(cls.model.states)
        self.n_states = n
        self.project = [False] * len(self.models)
        self.switches: list[_Switch] = []
        for i, m in enumerate(self.models):
            kind = _KINDS.get((type(m).__name__, getattr(m.p, "fidelity", None)))
            if kind == "algebraic":
                self.project[i] = True
            elif isinstance(kind, str):
                raise ReferenceError_(f"instance {self.names[i]}: no monolithic reference: {kind}")
        self._set_switches(range(len(self.models)))
        index = {name: i for i, name in enumerate(self.names)}
        self.wires: list[list[_Wire | None]] = [[None] * len(m.inputs) for m in self.models]
        for c in system.all_connections():
            si, sv = c.source.split(".", 1)
            ti, tv = c.target.split(".", 1)
            src_model, dst_model = self.models[index[si]], self.models[index[ti]]
            if sv not in src_model.outputs or tv not in dst_model.inputs:
                raise ReferenceError_(f"connection {c.source} -> {c.target}: not an output -> input pair of the models")
            self.wires[index[ti]][dst_model.inputs.index(tv)] = _Wire(index[si], src_model.outputs.index(sv),
                                                                      float(c.factor), float(c.offset))
        self.start_inputs = []
        for cls in self.classes:
            starts = {v.name: v.start for v in cls.interface() if v.causality == "input"}
            self.start_inputs.append([starts[name] for name in cls.model.inputs])
        self.sweeps = self._evaluation_order()
        self.inputs = inputs
        # (column of inputs.values(), instance, input index) of each signal on an input, and (column, instance,
        # parameter) of each on a tunable parameter: held between the table's rows, the model rebuilt at a change
        self.driven, self.tuned = [], []
        for k, (inst, var, *_) in enumerate(inputs.columns if inputs is not None else ()):
            i = index[inst]
            if var in self.models[i].inputs:
                self.driven.append((k, i, self.models[i].inputs.index(var)))
            elif var in self.values[i] and var in self.classes[i].tunable:
                self.tuned.append((k, i, var))
            else:
                raise ReferenceError_(f"input signal {inst}.{var}: neither an input nor a tunable parameter of "
                                      f"{self.classes[i].__name__}")
        self._tuned_to = None     # the tuned parameters' values the models are built from
        self._segment_end = None  # ns: the end of the stretch being integrated (its inputs before any step there)

    def _set_switches(self, instances) -> None:
        """The switches of ``instances`` (indices) for their present models (a brake appears with its torque)."""
        instances = set(instances)
        self.switches = [c for c in self.switches if c.i not in instances]
        for i in sorted(instances):
            m = self.models[i]
            kind = _KINDS.get((type(m).__name__, getattr(m.p, "fidelity", None)))
            if kind is not None and not isinstance(kind, str) and kind.applies(m):
                self.switches.append(kind(i, m))

    def _tune(self, t: float) -> None:
        """The models of the tuned parameters' values at ``t`` (after a step there), rebuilt where they changed,
        as the FMU rebuilds its model when a tunable parameter is set between communication steps."""
        if not self.tuned:
            return
        values = self.inputs.values(round(t * NS), after_event=True)
        now = tuple(float(values[k]) for k, _, _ in self.tuned)
        if now == self._tuned_to:
            return
        changed = {i for (k, i, var), v in zip(self.tuned, now) if self.values[i][var] != v}
        for (k, i, var), v in zip(self.tuned, now):
            self.values[i][var] = v
        for i in changed:
            cls = self.classes[i].model
            self.models[i] = cls(cls.Params.from_mapping(self.values[i]))
        self._set_switches(changed)
        self._tuned_to = now

    def _evaluation_order(self) -> list[int]:
        """Instance indices in the order their outputs must be evaluated (SCCs repeated len(SCC) times)."""
        g = graph.Digraph(range(len(self.models)))
        for dst, wires in enumerate(self.wires):
            ft = self.classes[dst].feedthrough
            for j, w in enumerate(wires):
                name = self.models[dst].inputs[j]
                if w is not None and any(name in deps for deps in ft.values()):
                    g.add_edge(w.src, dst)
        order = []
        for members in graph.condensation_order(g):
            order.extend(members * len(members))
        return order

    # -- evaluation ----------------------------------------------------------------------------------------
    def initial_state(self) -> np.ndarray:
        """Consistent initial states: each model's initial_state from the inputs its neighbours produce."""
        x = np.zeros(self.n_states)
        u = [list(s) for s in self.start_inputs]
        for i in self.sweeps:
            x[self.slices[i]] = self.models[i].initial_state(u[i])
        # initial states may depend on inputs that depend on other initial states (a chain of n instances
        # needs up to n passes): repeat until nothing changes
        for _ in range(len(self.models) + 2):
            u, _y = self.signals(0.0, x)
            x_new = x.copy()
            for i in self.sweeps:
                x_new[self.slices[i]] = self.models[i].initial_state(u[i])
            if np.array_equal(x_new, x):
                break
            x = x_new
        return x

    def signals(self, t: float, x: np.ndarray):
        """(inputs, outputs) of every instance at time t for the global state x."""
        u = [list(s) for s in self.start_inputs]
        if self.driven:
            t_ns = round(t * NS)
            after = self._segment_end is None or t_ns < self._segment_end
            values = self.inputs.values(t_ns, after_event=after)
            for k, i, j in self.driven:
                u[i][j] = float(values[k])
        y: list = [None] * len(self.models)
        for i in self.sweeps:
            for j, w in enumerate(self.wires[i]):
                if w is not None and y[w.src] is not None:
                    u[i][j] = w.factor * y[w.src][w.out] + w.offset
            xi = x[self.slices[i]]
            if self.project[i]:
                xi = self.models[i].advance(t, 0.0, xi, u[i])
            y[i] = self.models[i].output(t, xi, u[i])
        for i, wires in enumerate(self.wires):  # final assignment with every output known
            for j, w in enumerate(wires):
                if w is not None:
                    u[i][j] = w.factor * y[w.src][w.out] + w.offset
        return u, y

    def rhs(self, t: float, x: np.ndarray) -> np.ndarray:
        u, _ = self.signals(t, x)
        dx = np.empty_like(x)
        for i, m in enumerate(self.models):
            dx[self.slices[i]] = 0.0 if self.project[i] else m.derivatives(t, x[self.slices[i]], u[i], t)
        for c in self.switches:
            d = c.derivatives(t, x[self.slices[c.i]], u[c.i])
            if d is not None:
                dx[self.slices[c.i]] = d
        return dx

    def _event_functions(self, t: float, x: np.ndarray):
        """(switch, event function) for every switch, armed at (t, x) in its current mode."""
        u, _ = self.signals(t, x)
        funcs = []
        for c in self.switches:
            c.arm(t, x[self.slices[c.i]], u[c.i])

            def f(t, x, c=c):
                u, _ = self.signals(t, x)
                return c.value(t, x[self.slices[c.i]], u[c.i])
            f.terminal = True
            f.direction = c.direction
            funcs.append((c, f))
        return funcs

    def simulate(self, stop_time: float, step: float, method: str = "Radau", rtol: float = 1e-9,
                 atol: float = 1e-10, max_step: float | None = None) -> pd.DataFrame:
        n_steps = int(round(stop_time / step))
        grid = np.arange(n_steps + 1) * step
        self._tune(0.0)
        x = self.initial_state()
        events = self._event_functions(0.0, x)
        self.n_events = 0
        t = 0.0
        states = np.empty((len(grid), self.n_states))
        states[0] = x
        k_next = 1
        limit = max_step if max_step is not None else min(m.max_substep for m in self.models) * 10
        limit = limit if np.isfinite(limit) else step
        t_wall = time.perf_counter()
        self.fallbacks = 0
        # the input signals' rows inside the run: each ends a stretch (a step or a ramp's kink), where the
        # integration restarts with the inputs after it
        rows = [] if self.inputs is None else sorted({int(r) for r in self.inputs.t_ns if 0 < r < round(grid[-1] * NS)})
        # each state's error is judged against its largest magnitude so far (rtol of it, atol at least): a speed
        # that comes to rest after running (a held brake) is not asked to 1e-10 absolute, below the roundoff of
        # the stiff springs' forces on large angles, where Radau's Newton iteration stalls at steps of microseconds
        scale = np.zeros_like(x)
        self.rhs_evaluations = 0
        while k_next <= n_steps:
            while rows and rows[0] <= round(t * NS):
                rows.pop(0)
            t_stop = rows[0] / NS if rows else grid[-1]
            self._tune(t)
            self._segment_end = rows[0] if rows else None
            scale = np.maximum(scale, np.abs(x))
            tol = np.maximum(atol, rtol * scale)
            sol = solve_ivp(self.rhs, (t, t_stop), x, method=method, rtol=rtol, atol=tol, max_step=limit,
                            dense_output=True, events=[f for _, f in events] or None, t_eval=None)
            self.rhs_evaluations += sol.nfev
            if sol.status < 0 and sol.t[-1] == t and method != "BDF":  # stuck on a kink at the restart
                self.fallbacks += 1
                sol = solve_ivp(self.rhs, (t, t_stop), x, method="BDF", rtol=rtol, atol=tol, max_step=limit,
                                dense_output=True, events=[f for _, f in events] or None, t_eval=None)
                self.rhs_evaluations += sol.nfev
            if sol.status < 0:
                raise ReferenceError_(f"reference integration failed at t = {sol.t[-1]:.6g} s: {sol.message}")
            t_end = sol.t[-1]
            while k_next <= n_steps and grid[k_next] <= t_end:
                states[k_next] = sol.sol(grid[k_next])
                k_next += 1
            x = sol.y[:, -1].copy()
            t = t_end
            if sol.status == 1:  # a switch (contact onset or separation, a brake): update the state, restart
                u, _ = self.signals(t, x)
                for (c, _f), te in zip(events, sol.t_events):
                    if len(te):
                        x[self.slices[c.i]] = c.switch(t, x[self.slices[c.i]], u[c.i])
                        self.n_events += 1
                events = self._event_functions(t, x)
            elif rows and t == t_stop:  # an input row: the memory the new inputs set (a brake's timer), re-arm
                self._segment_end = None
                self._tune(t)
                u, _ = self.signals(t, x)
                for i, m in enumerate(self.models):
                    if m.input_memory:
                        x[self.slices[i]] = m.advance(t, 0.0, x[self.slices[i]], u[i])
                events = self._event_functions(t, x)
        self._segment_end = None
        self.wall_time = time.perf_counter() - t_wall
        df = self.frame(grid, states)
        df.attrs["fallbacks"] = self.fallbacks
        df.attrs["rhs_evaluations"] = self.rhs_evaluations
        return df

    def frame(self, grid: np.ndarray, states: np.ndarray) -> pd.DataFrame:
        cols: dict[str, list] = {}
        for k, t in enumerate(grid):
            self._tune(float(t))
            u, y = self.signals(float(t), states[k])
            for i, m in enumerate(self.models):
                for name, value in zip(m.inputs, u[i]):
                    cols.setdefault(f"{self.names[i]}.{name}", []).append(float(value))
                for name, value in zip(m.outputs, y[i]):
                    cols.setdefault(f"{self.names[i]}.{name}", []).append(float(value))
        df = pd.DataFrame(cols, index=pd.Index(grid, name="time"))
        df.attrs["complete"] = True
        return df


def reference(system, stop_time: float | None = None, step: float | None = None, parameters: dict | None = None,
              inputs=None, **options) -> pd.DataFrame:
    """The monolithic reference of ``system`` sampled on the co-simulation grid ``k*step``; ``inputs``: its input
    signals (:class:`harness.signals.Signals`)."""
    exp = system.experiment
    stop_time = stop_time if stop_time is not None else exp.stop_time
    step = step if step is not None else exp.step
    return Monolithic(system, parameters, inputs).simulate(stop_time, step, **options)


def scenario_reference(system, scenario, step: float | None = None, stop_time: float | None = None,
                       **options) -> pd.DataFrame:
    """The monolithic reference of ``system`` through ``scenario`` (:mod:`harness.scenarios`: its parameters and
    its changes as input signals), sampled on ``k*step`` (default: the system's step) to the scenario's end."""
    from harness.fmi.cache import model_description
    from harness.model import resolve_fmu
    from harness.scenarios import find, input_starts, table
    from harness.signals import Signals

    sc = find(system, scenario)
    inputs = None
    if sc.changes:
        mds = {inst.name: model_description(resolve_fmu(inst.fmu)) for inst in system.instances}
        inputs = Signals(system, mds, system.all_connections(mds), table(sc, input_starts(system, sc)))
    return reference(system, stop_time or sc.stop_time, step, dict(sc.parameters), inputs, **options)
