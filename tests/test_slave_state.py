"""The FMU state of every slave is complete: whatever attribute of the slave a step changes (discovered from
``vars(slave)``, not from a list kept here) is a field of its saved state, comes back when the state is restored,
and (unless it is derived from the others) is part of the key of what the slave caches from its state."""
from __future__ import annotations

import importlib
from dataclasses import fields

import numpy as np
import pytest

from fmus.build import catalog
from fmus.slave import fmu_class
from fmus.slave_core import SlaveState
from input_ranges import fold

# attributes a step may change that are not state: the cache keyed by the state itself
NOT_STATE = {"_feedthrough_cache"}
CATALOG = catalog()


def declaration(name: str) -> type:
    return getattr(importlib.import_module(f"fmus.components.{CATALOG[name].stem}"), name)


def me_class(name: str):
    """The FMI 3.0 model exchange slave of a declaration (pythonfmu3 is a dependency)."""
    from fmus.slave3_me import fmu_class as me_fmu_class

    return me_fmu_class(declaration(name))


def _frozen(value):
    """A comparable snapshot of an attribute value: containers by content, other objects by identity."""
    if isinstance(value, np.ndarray):
        return ("array", value.shape, value.tobytes())
    if isinstance(value, (list, tuple)):
        return tuple(_frozen(v) for v in value)
    if isinstance(value, dict):
        return tuple((k, _frozen(v)) for k, v in value.items())
    if value is None or isinstance(value, (bool, int, float, str, bytes)):
        return value
    return ("object", id(value))


def snapshot(slave) -> dict:
    return {k: _frozen(v) for k, v in vars(slave).items()}


def started(cls):
    s = cls(instance_name="probe")
    s.setup_experiment(0.0)
    s.enter_initialization_mode()
    s.exit_initialization_mode()
    return s


def _inside(s, vr: int, value: float) -> float:
    """``value`` folded into the range the slave declares for the input ``vr`` (it refuses one outside)."""
    declared = s._io[s._in_by_vr[vr]]
    return fold(value, declared.min, declared.max)


def exercise(s, k: int) -> None:
    """What a master does at one communication point: set inputs, step (a step size of its own), read outputs and
    their derivatives."""
    h = 1e-3 * (1.0 + 0.1 * k)
    ins, outs = sorted(s._in_by_vr), sorted(s._out_by_vr)
    if ins:
        s.set_real(ins, [_inside(s, vr, 0.01 * (i + 1) * np.sin(0.3 * k + i)) for i, vr in enumerate(ins)])
    s.do_step(k * h, h)
    if ins:    # a position set again, the others held over the next step: both kinds of input in the state
        s.set_real(ins[:1], [_inside(s, ins[0], 0.02 * np.cos(0.3 * k))])
    s.get_real(outs)
    if ins and outs and type(s).model.provides_output_jacobian():
        s.directional_derivative(outs, ins, [1.0] * len(ins))


def exercise_me(s, k: int) -> None:
    """What a model exchange host does: set inputs, time and states, read derivatives, indicators and outputs,
    update the discrete states at an event."""
    ins, outs = sorted(s._in_by_vr), sorted(s._out_by_vr)
    if ins:
        s.set_float64(ins, [0.01 * (i + 1) * np.sin(0.3 * k + i) for i in range(len(ins))])
    s.time = 1e-3 * k
    x = s.get_continuous_states()
    s.get_continuous_state_derivatives()
    s.set_continuous_states([v + 1e-6 for v in x])
    s.get_event_indicators()
    s.update_discrete_states()
    s.get_float64(outs)


def _perturbed(value):
    if isinstance(value, np.ndarray):
        return value + 1.0 if value.size else np.ones(1)
    if isinstance(value, bool):
        return not value
    if isinstance(value, (int, float)):
        return value + 1.0
    if isinstance(value, list):
        return value + [0.5]
    if isinstance(value, tuple):
        return value + (True,)
    if isinstance(value, dict):
        return {**value, "perturbed": 1.0}
    return object()


@pytest.mark.parametrize("name", sorted(CATALOG))
def test_every_attribute_a_step_changes_is_saved_restored_and_keyed(name):
    check_state_completeness(name, started(fmu_class(declaration(name))))


@pytest.mark.parametrize("name", ["Inertia", "FourBar", "CamRocker"])
def test_the_model_exchange_state_is_complete_too(name):
    """The model exchange slave's own attributes (the time each advanced position was set, the indicators'
    signs): the probe also steps the host's way, setting time and states, and reading derivatives."""
    check_state_completeness(name, started(me_class(name)), me=True)


def check_state_completeness(name: str, s, me: bool = False) -> None:
    state_type = s._state_type
    attributes = {f"_{f.name}" for f in fields(state_type)}
    step = exercise_me if me else exercise
    step(s, 0)
    before = snapshot(s)
    for k in range(1, 4):
        step(s, k)
    after = snapshot(s)
    changed = {a for a in after if before.get(a, object()) != after[a]} - NOT_STATE
    assert changed, "the steps changed nothing: the probe does not exercise the slave"
    assert changed <= attributes, f"{name}: a step changes {sorted(changed - attributes)}, not in {state_type.__name__}"

    # restored: every attribute (not only the state's) is as it was when the state was saved
    saved, at_save = s._get_fmu_state(), snapshot(s)
    for k in range(4, 7):
        step(s, k)
    s._set_fmu_state(saved)
    restored = snapshot(s)
    differ = {a for a in at_save if a not in NOT_STATE and restored.get(a) != at_save[a]}
    assert not differ, f"{name}: not restored: {sorted(differ)}"

    # keyed: a change of any non-derived field changes the cache key
    for f in fields(state_type):
        if f.name in state_type.DERIVED:
            continue
        key = state_type.key(s)
        old = getattr(s, f"_{f.name}")
        setattr(s, f"_{f.name}", _perturbed(old))
        assert state_type.key(s) != key, f"{name}: _{f.name} is not in the cache key"
        setattr(s, f"_{f.name}", old)


def test_the_probe_fails_on_an_incomplete_state(monkeypatch):
    """The check above catches an attribute left out of the state (here: the last step size)."""
    from dataclasses import make_dataclass

    short = make_dataclass("ShortState", [(f.name, f.type) for f in fields(SlaveState) if f.name != "last_step"],
                           bases=(), frozen=True)
    short.DERIVED, short.of, short.restore, short.key = (SlaveState.DERIVED, classmethod(SlaveState.of.__func__),
                                                         SlaveState.restore, classmethod(SlaveState.key.__func__))
    cls = fmu_class(declaration("Inertia"))
    monkeypatch.setattr(cls, "_state_type", short, raising=False)
    with pytest.raises(AssertionError, match="_last_step"):
        check_state_completeness("Inertia", started(cls))
