"""Monolithic reference of a system, assembled from the same equations the FMUs use.

Every instance of a toolkit FMU is replaced by its pure model (``fmus.physics``), the system's connections
become algebraic assignments evaluated at every right-hand-side call, and the whole state vector is
integrated by scipy (``Radau`` by default: stiff-capable; tight tolerances), so the result has no coupling
error at all.  Output evaluation follows the direct-feedthrough graph of the components: instances are taken
in topological order of the strongly connected components of the instance graph, and an SCC (e.g. a four-bar
and a differential that feed each other's reactions) is swept as often as it has members, which is exact
whenever the variable-level graph has no algebraic loop (the masters detect and report those).

Models with discrete memory (contact onset speeds, impact counters) may declare event functions:
``events(t, x, u) -> sequence of floats`` (a sign change is an event) and ``on_event(t, x, u, index) -> x``.
The reference stops scipy at each event (``solve_ivp`` root finding) and applies the update, so impacts are
resolved to the integrator's tolerance instead of to a sub-step.

The result has the co-simulation's shape: a DataFrame on the given time grid with ``Instance.variable``
columns for every input and output.
"""
from __future__ import annotations

import importlib
import time
from dataclasses import dataclass
from pathlib import Path

import networkx as nx
import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

ROOT = Path(__file__).resolve().parents[1]


class ReferenceError_(ValueError):
    pass


def component_classes() -> dict[str, type]:
    """Model name -> FMU class, for every FMU declared in fmus/components."""
    out = {}
    for script in sorted((ROOT / "fmus" / "components").glob("pd_*.py")):
        module = importlib.import_module(f"fmus.components.{script.stem}")
        for value in vars(module).values():
            if isinstance(value, type) and value.__module__ == module.__name__ and hasattr(value, "model"):
                out[value.__name__] = value
    return out


def _model_name(fmu) -> str:
    p = Path(str(fmu))
    if p.suffix.lower() != ".fmu":
        return str(fmu)
    from harness.model import model_description

    return model_description(p).modelName


@dataclass
class _Wire:
    src: int        # source instance index
    out: int        # index into the source model's outputs
    factor: float
    offset: float


class Monolithic:
    """The assembled ODE of a system: ``rhs(t, X)``, ``signals(t, X)`` and ``simulate(...)``."""

    def __init__(self, system, parameters: dict | None = None):
        classes = component_classes()
        parameters = dict(parameters or {})
        self.names, self.models, self.slices, self.classes = [], [], [], []
        n = 0
        for inst in system.instances:
            mname = _model_name(inst.fmu)
            if mname not in classes:
                raise ReferenceError_(f"instance {inst.name}: FMU {mname} is not a toolkit component, "
                                      f"so no monolithic reference can be assembled")
            cls = classes[mname]
            values = {s.name: s.default for s in cls.model.Params.specs()}
            values.update(inst.parameters)
            prefix = inst.name + "."
            values.update({k[len(prefix):]: v for k, v in parameters.items() if k.startswith(prefix)})
            model = cls.model(cls.model.Params.from_mapping(values))
            self.names.append(inst.name)
            self.models.append(model)
            self.classes.append(cls)
            self.slices.append(slice(n, n + len(cls.model.states)))
            n += len(cls.model.states)
        self.n_states = n
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

    def _evaluation_order(self) -> list[int]:
        """Instance indices in the order their outputs must be evaluated (SCCs repeated len(SCC) times)."""
        g = nx.DiGraph()
        g.add_nodes_from(range(len(self.models)))
        for dst, wires in enumerate(self.wires):
            ft = self.classes[dst].feedthrough
            for j, w in enumerate(wires):
                name = self.models[dst].inputs[j]
                if w is not None and any(name in deps for deps in ft.values()):
                    g.add_edge(w.src, dst)
        order = []
        cond = nx.condensation(g)
        for comp in nx.topological_sort(cond):
            members = sorted(cond.nodes[comp]["members"])
            order.extend(members * len(members))
        return order

    # -- evaluation ----------------------------------------------------------------------------------------
    def initial_state(self) -> np.ndarray:
        """Consistent initial states: each model's initial_state from the inputs its neighbours produce."""
        x = np.zeros(self.n_states)
        u = [list(s) for s in self.start_inputs]
        for _ in range(2):  # initial states may depend on inputs that depend on other initial states
            for i in self.sweeps:
                x[self.slices[i]] = self.models[i].initial_state(u[i])
            u, _y = self.signals(0.0, x)
        return x

    def signals(self, t: float, x: np.ndarray):
        """(inputs, outputs) of every instance at time t for the global state x."""
        u = [list(s) for s in self.start_inputs]
        y: list = [None] * len(self.models)
        for i in self.sweeps:
            for j, w in enumerate(self.wires[i]):
                if w is not None and y[w.src] is not None:
                    u[i][j] = w.factor * y[w.src][w.out] + w.offset
            y[i] = self.models[i].output(t, x[self.slices[i]], u[i])
        for i, wires in enumerate(self.wires):  # final assignment with every output known
            for j, w in enumerate(wires):
                if w is not None:
                    u[i][j] = w.factor * y[w.src][w.out] + w.offset
        return u, y

    def rhs(self, t: float, x: np.ndarray) -> np.ndarray:
        u, _ = self.signals(t, x)
        dx = np.empty_like(x)
        for i, m in enumerate(self.models):
            dx[self.slices[i]] = m.derivatives(t, x[self.slices[i]], u[i], t)
        return dx

    def _event_functions(self):
        funcs = []
        for i, m in enumerate(self.models):
            if not hasattr(m, "events"):
                continue
            x0 = np.zeros(len(m.states))
            k = len(m.events(0.0, x0, self.start_inputs[i]))
            for e in range(k):
                def f(t, x, i=i, e=e):
                    u, _ = self.signals(t, x)
                    return m_events(self.models[i], t, x[self.slices[i]], u[i])[e]
                f.terminal = True
                funcs.append((i, e, f))
        return funcs

    def simulate(self, stop_time: float, step: float, method: str = "Radau", rtol: float = 1e-9,
                 atol: float = 1e-10, max_step: float | None = None) -> pd.DataFrame:
        n_steps = int(round(stop_time / step))
        grid = np.arange(n_steps + 1) * step
        x = self.initial_state()
        events = self._event_functions()
        t = 0.0
        states = np.empty((len(grid), self.n_states))
        states[0] = x
        k_next = 1
        limit = max_step if max_step is not None else min(m.max_substep for m in self.models) * 10
        limit = limit if np.isfinite(limit) else step
        t_wall = time.perf_counter()
        while k_next <= n_steps:
            sol = solve_ivp(self.rhs, (t, grid[-1]), x, method=method, rtol=rtol, atol=atol, max_step=limit,
                            dense_output=True, events=[f for _, _, f in events] or None, t_eval=None)
            if sol.status < 0:
                raise ReferenceError_(f"reference integration failed at t = {sol.t[-1]:.6g} s: {sol.message}")
            t_end = sol.t[-1]
            while k_next <= n_steps and grid[k_next] <= t_end:
                states[k_next] = sol.sol(grid[k_next])
                k_next += 1
            x = sol.y[:, -1].copy()
            t = t_end
            if sol.status == 1:  # an event: apply the model's discrete update and restart
                for (i, e, _f), te in zip(events, sol.t_events):
                    if len(te):
                        u, _ = self.signals(t, x)
                        x[self.slices[i]] = self.models[i].on_event(t, x[self.slices[i]], u[i], e)
        self.wall_time = time.perf_counter() - t_wall
        return self.frame(grid, states)

    def frame(self, grid: np.ndarray, states: np.ndarray) -> pd.DataFrame:
        cols: dict[str, list] = {}
        for k, t in enumerate(grid):
            u, y = self.signals(float(t), states[k])
            for i, m in enumerate(self.models):
                for name, value in zip(m.inputs, u[i]):
                    cols.setdefault(f"{self.names[i]}.{name}", []).append(float(value))
                for name, value in zip(m.outputs, y[i]):
                    cols.setdefault(f"{self.names[i]}.{name}", []).append(float(value))
        df = pd.DataFrame(cols, index=pd.Index(grid, name="time"))
        df.attrs["complete"] = True
        return df


def m_events(model, t, x, u):
    return model.events(t, x, u)


def reference(system, stop_time: float | None = None, step: float | None = None, parameters: dict | None = None,
              **options) -> pd.DataFrame:
    """The monolithic reference of ``system`` sampled on the co-simulation grid ``k*step``."""
    exp = system.experiment
    stop_time = stop_time if stop_time is not None else exp.stop_time
    step = step if step is not None else exp.step
    return Monolithic(system, parameters).simulate(stop_time, step, **options)
