"""libcosim's scenario files (``run SYSTEM --scenario FILE.json``), run as libcosim runs them.

The format (libcosim's ``scenario_parser``; JSON, or YAML with the same keys)::

    {"defaults": {"model": "Reference Generator", "variable": "x_wp", "action": "override"},
     "events": [{"time": 300, "variable": "x_wp", "value": 10.0},
                {"time": 300, "model": "Ship", "variable": "q[1]", "action": "bias", "value": 0.5},
                {"time": 400, "variable": "x_wp", "action": "reset"}],
     "end": 700}

Each event names a model (an instance), a variable and an action, each taken from ``defaults`` where the event
leaves it out.  What happens, as libcosim's scenario manager and slave simulator do it:

* Before each communication step from ``t``, every event whose time (from the start of the run) is at or
  before ``t`` and has not run yet runs: ``override`` replaces the variable's value by ``value``, ``bias`` adds
  ``value`` to it, ``reset`` removes what an earlier event did to it.  A later event on a variable replaces the
  earlier one's action.
* On an input (or parameter) the action applies to the value the FMU is given for the step from ``t`` on: a
  connected Real input's connection delivers ``value`` (override) or its value plus ``value`` (bias) from then;
  an unconnected input or a parameter is set to it (a parameter must be tunable).
* On an output the action applies to the value read after each step from then: the first modified value is the
  one at ``t + h``, and what the output's consumers and the result see.
* At the step after the last event ran, once the scenario's ``end`` (if any) is reached, every action of the
  scenario is removed (libcosim's "cleanup"): without ``end``, the last events act for one step.
* ``end`` does not stop the run; ``run --scenario`` stops at it unless ``--stop-time`` says otherwise.

Refused in one line naming the file and the event: an unknown model or variable, an action that is none of
override, bias and reset (libcosim's), a value of the wrong type, an action on a connected Integer or Boolean
input or on a non-Real output (the harness passes those values through the master, which offers no action on
them).
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

from harness.errors import SystemDescriptionError
from harness.master import coupling
from harness.master.clock import NS

ACTIONS = ("override", "bias", "reset")


def is_libcosim_scenario(path) -> bool:
    """A .json/.yaml/.yml file holding libcosim's ``events`` list (not the harness's own ``changes``)."""
    p = Path(str(path))
    if p.suffix.lower() not in (".json", ".yaml", ".yml") or not p.is_file():
        return False
    try:
        data = _parse(p)
    except SystemDescriptionError:
        return False
    return isinstance(data, dict) and isinstance(data.get("events"), list) and "changes" not in data


def _parse(p: Path):
    text = p.read_text()
    try:
        if p.suffix.lower() == ".json":
            return json.loads(text)
        import yaml

        return yaml.safe_load(text)
    except Exception as e:
        raise SystemDescriptionError(f"scenario file {p}: cannot be parsed ({type(e).__name__}: "
                                     f"{' '.join(str(e).split())})") from None


class Event:
    __slots__ = ("t_ns", "instance", "variable", "action", "value", "index")

    def __init__(self, t_ns, instance, variable, action, value, index):
        self.t_ns, self.instance, self.variable, self.action, self.value = t_ns, instance, variable, action, value
        self.index = index


class LibcosimScenario:
    """A libcosim scenario file as the run loop's inputs (the interface of :class:`harness.signals.Signals` the
    loop uses: ``instances``, ``step_times``, ``next_time``, ``apply``), acting on the master (:meth:`attach`)."""

    names: list = []
    instances: frozenset = frozenset()   # no signal refreshes the outputs at a point: libcosim refreshes none

    def __init__(self, path):
        self.path = Path(path)
        data = _parse(self.path)
        where = f"scenario file {self.path}"
        if not isinstance(data, dict) or not isinstance(data.get("events"), list):
            raise SystemDescriptionError(f"{where}: not a libcosim scenario (a mapping with an 'events' list)")
        defaults = data.get("defaults") or {}
        self.events: list[Event] = []
        for k, e in enumerate(data["events"]):
            what = f"{where}: event {k + 1}"
            if not isinstance(e, dict):
                raise SystemDescriptionError(f"{what}: not a mapping")
            got = {key: e.get(key, defaults.get(key)) for key in ("model", "variable", "action")}
            for key, value in got.items():
                if value is None:
                    raise SystemDescriptionError(f"{what}: no {key} (neither in the event nor in defaults)")
            if got["action"] not in ACTIONS:
                raise SystemDescriptionError(f"{what}: action {got['action']!r} is none of libcosim's "
                                             f"({', '.join(ACTIONS)})")
            t = e.get("time")
            if isinstance(t, bool) or not isinstance(t, (int, float)) or not t >= 0:
                raise SystemDescriptionError(f"{what}: time = {t!r} must be a number >= 0 [s]")
            if got["action"] != "reset" and "value" not in e:
                raise SystemDescriptionError(f"{what}: {got['action']} needs a value")
            self.events.append(Event(int(round(float(t) * NS)), str(got["model"]), str(got["variable"]),
                                     got["action"], e.get("value"), k + 1))
        end = data.get("end")
        if end is not None and (isinstance(end, bool) or not isinstance(end, (int, float)) or end < 0):
            raise SystemDescriptionError(f"{where}: end = {end!r} must be a time >= 0 [s]")
        self.end = None if end is None else float(end)
        self.step_times = frozenset(e.t_ns for e in self.events)
        self._master = None

    def digest(self) -> str:
        return hashlib.sha256(self.path.read_bytes()).hexdigest()[:16]

    # -- checked against the run's system -----------------------------------------------------------------------
    def for_run(self, system, mds: dict, connections) -> "LibcosimScenario":
        """Check every event against the system (module docstring); the object itself, ready to run."""
        targets = {c.target for c in connections}
        for e in self.events:
            what = f"scenario file {self.path}: event {e.index}"
            if e.instance not in mds:
                raise SystemDescriptionError(f"{what}: no model {e.instance!r} in system {system.name} (models: "
                                             f"{', '.join(mds)})")
            v = next((v for v in mds[e.instance].modelVariables if v.name == e.variable), None)
            if v is None:
                raise SystemDescriptionError(f"{what}: model {e.instance} ({mds[e.instance].modelName}) has no "
                                             f"variable {e.variable!r}")
            ref = f"{e.instance}.{e.variable}"
            if v.causality == "output" and v.type != "Real":
                raise SystemDescriptionError(f"{what}: {ref} is a {v.type} output; the harness acts on Real outputs")
            if v.causality not in ("output", "input", "parameter"):
                raise SystemDescriptionError(f"{what}: {ref} has causality {v.causality}; libcosim acts on inputs, "
                                             f"parameters and outputs")
            if ref in targets and v.type != "Real":
                raise SystemDescriptionError(f"{what}: {ref} is a connected {v.type} input; the harness acts on "
                                             f"connected Real inputs and unconnected ones")
            if e.action != "reset":
                e.value = _typed(e.value, v.type, what)
        return self

    def start_values(self, start_ns: int) -> dict:
        return {}

    def bind(self, fmus: dict) -> None:
        self._fmus = fmus

    def attach(self, master) -> None:
        """Resolve the events on the master's coupling: connected Real inputs by their entry of ``u``, outputs
        by their instance's output block (wrapped to apply the actions), others on the FMU."""
        self._master = master
        self._u_entry = {}
        for it in master.insts:
            for name, k in it.input_pos.items():
                self._u_entry[f"{it.name}.{name}"] = it.input_slice.start + k
        self._links = {k: (float(master.factor[k]), float(master.offset[k])) for k in self._u_entry.values()}
        self._outputs = {}
        for e in self.events:
            it = master.insts[master.index[e.instance]]
            var = it.fmu.variables[e.variable]
            if var.causality == "output" and not isinstance(it.fmu, _Modified):
                it.fmu = _Modified(it.fmu, it.out)
            if var.causality == "output":
                self._outputs[(e.instance, e.variable)] = (it.fmu, it.out.names.index(e.variable))
        self._remaining = list(self.events)
        self._done: list[Event] = []
        self._original: dict = {}
        self._running = True

    # -- the run loop's inputs --------------------------------------------------------------------------------------
    def next_time(self, t_ns: int):
        later = [e.t_ns for e in self._remaining if e.t_ns > t_ns]
        return min(later) if later else None

    def apply(self, t_ns: int) -> None:
        """libcosim's ``step_commencing``: the cleanup when the scenario is over, else the events due."""
        if not self._running:
            return
        rel = t_ns - self._start_ns() if self._master is not None else t_ns
        timed_out = True if self.end is None else rel >= int(round(self.end * NS))
        if not self._remaining and timed_out:
            self._running = False
            for e in self._done:
                self._act(e.instance, e.variable, None)
            return
        due = [e for e in self._remaining if rel >= e.t_ns]
        for e in due:
            self._act(e.instance, e.variable, None if e.action == "reset" else (e.action, e.value))
            self._remaining.remove(e)
            self._done.append(e)

    def _start_ns(self) -> int:
        if not hasattr(self, "_t0"):
            self._t0 = self._master.t_ns
        return self._t0

    def _act(self, instance: str, variable: str, action) -> None:
        """Put ``action`` (None: no action) on the variable."""
        ref = f"{instance}.{variable}"
        m = self._master
        if (instance, variable) in self._outputs:
            fmu, k = self._outputs[(instance, variable)]
            fmu.modifiers[k] = action
            return
        if ref in self._u_entry:
            k = self._u_entry[ref]
            factor, offset = self._links[k]
            if action is not None:
                kind, value = action
                factor, offset = (0.0, float(value)) if kind == "override" else (factor, offset + float(value))
            coupling.relink(m, k, factor, offset)
            return
        fmu = m.insts[m.index[instance]].fmu
        if ref not in self._original:
            self._original[ref] = fmu.get_value(variable)
        original = self._original[ref]
        if action is None:
            fmu.set_value(variable, original)
        else:
            kind, value = action
            fmu.set_value(variable, value if kind == "override" else original + value)


def _typed(value, kind: str, what: str):
    if kind == "Real" and isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    if kind in ("Integer", "Enumeration") and isinstance(value, int) and not isinstance(value, bool):
        return value
    if kind == "Boolean" and isinstance(value, bool):
        return value
    if kind == "String" and isinstance(value, str):
        return value
    raise SystemDescriptionError(f"{what}: value {value!r} is not a {kind}")


class _Modified:
    """An FMU instance whose Real output block reads with the scenario's actions applied (``modifiers``: per
    position in the block, None or (kind, value)); every other call goes to the instance."""

    def __init__(self, inner, block):
        self._inner, self._block = inner, block
        self.modifiers: list = [None] * block.n

    def __getattr__(self, name):
        return getattr(self._inner, name)

    def _apply(self, values):
        for k, action in enumerate(self.modifiers):
            if action is not None:
                kind, value = action
                values[k] = value if kind == "override" else values[k] + value
        return values

    def get_list(self, block):
        values = self._inner.get_list(block)
        return self._apply(list(values)) if block is self._block else values

    def get(self, block):
        values = self._inner.get(block)
        return self._apply(values.copy()) if block is self._block else values


__all__ = ["LibcosimScenario", "is_libcosim_scenario", "ACTIONS"]
