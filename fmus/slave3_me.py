"""The base slave of the FMI 3.0 MODEL EXCHANGE FMUs: the same declarations, the model's own ODE.

``build_fmus.py --fmi-version 3 --model-exchange`` builds every declaration ``fmus/components/pd_<name>.py`` on this
module's ``PressSlave`` (:func:`fmus.build.fmu_module`; :func:`fmu_class` in process), so the one declaration
becomes a model exchange FMU: no second copy of any port, signal or parameter, and the variables, units, terminals
and value references of the FMI 3.0 co-simulation FMU (:mod:`fmus.slave3`, whose registration this class extends).

What a host integrates is the model's own equations (:mod:`fmus.physics`):

* continuous states: the model's ``states`` (``x``), each with a derivative variable ``der(<state>)`` registered
  after ``time``, so every other value reference is the co-simulation FMU's;
* derivatives: ``Model.derivatives(t, x, u, t0=t)`` with the inputs at t: as the host set them, except a
  motion-input position of a port the model advances (``advances_position``, the co-simulation FMU's
  ``advancedPositions`` annotation, kept): set at ``t_s`` and not set again, it is ``position + speed * (t - t_s)``.
  A host that sets the inputs at every time it evaluates (the FMI ideal) sees them as set; a host that holds
  them between its communication points (fmpy's CVODE right-hand side sets the time and the states, not the
  inputs; the toolkit's master holds them over a step) gets the position its speed implies, not a staircase of
  a stiff belt's or mesh's input (c * w * (t - t_s), the co-simulation FMU's reason for the same rule);
* outputs: ``Model.output(t, x, u)``, as in co-simulation;
* state events: ``Model.switches`` name the model's event indicators (``Model.event_indicators``: a clearance
  closing or opening), and at an event where an indicator has changed sign since the last one (a host also
  enters event mode for its inputs: those leave the memory alone) ``Model.at_event`` updates what the
  co-simulation step keeps as memory there (a contact flag, an impact count, an approach speed); those memory
  entries are states whose derivative is 0, so their change is reported as ``valuesOfContinuousStatesChanged``.

A component whose equations at the given parameters are not an ODE the host could integrate (a state that is
a step quantity, e.g. an acceleration from the input history; contact memory) is refused at initialisation in
one line, with the reason ``Model.ode_form`` gives; nothing is integrated then.

pythonfmu3 0.3.4's wrapper reads fmi3UpdateDiscreteStates' results under the C names
(``discreteStatesNeedUpdate``, ``nominalContinuousStatesChanged``), not those of its own Python result class, so
:meth:`PressSlave.update_discrete_states` returns an object with the C names (else a host's flags stay unset).
"""
from __future__ import annotations

from dataclasses import dataclass
from xml.etree.ElementTree import Element, SubElement

import numpy as np
from pythonfmu3 import Fmi3Causality, Fmi3Variability, Float64
from pythonfmu3.modelexchange import ModelExchange

from . import slave3
from .slave3 import Input, Output, Port, Rotational, Translational, Variable  # noqa: F401
from .slave_core import SlaveState, slave_class
from .units import BASE_UNITS

# what the toolkit's FMI 3.0 model exchange FMUs can do
MODEL_EXCHANGE = {"needsExecutionTool": "false", "canBeInstantiatedOnlyOncePerProcess": "false",
                  "canGetAndSetFMUState": "true", "canSerializeFMUState": "false",
                  "needsCompletedIntegratorStep": "false"}


def derivative_unit(unit: str) -> str | None:
    """The unit of d(unit)/dt among fmus.units.BASE_UNITS (None if it has no name there)."""
    exps = dict(BASE_UNITS[unit])
    exps["s"] = exps.get("s", 0) - 1
    exps = {k: e for k, e in exps.items() if e}
    return next((name for name, e in BASE_UNITS.items() if e == exps), None)


@dataclass
class _UpdateResult:
    """fmi3UpdateDiscreteStates' results under the names pythonfmu3's C wrapper reads (module docstring)."""
    discreteStatesNeedUpdate: bool = False
    terminateSimulation: bool = False
    nominalContinuousStatesChanged: bool = False
    valuesOfContinuousStatesChanged: bool = False
    nextEventTimeDefined: bool = False
    nextEventTime: float = 0.0


@dataclass(frozen=True)
class ModelExchangeState(SlaveState):
    """The co-simulation slave's state and what a model exchange slave keeps besides (rollback, the cache key)."""
    pos_time: dict               # per advanced position input, the time it was last set
    last_sides: tuple            # the event indicators' signs at the last event


class PressSlave(slave3.PressSlave, ModelExchange):
    """Base class of the FMI 3.0 model exchange FMUs (module docstring).  It derives from the co-simulation base
    for its registration and value access; its modelDescription has a ``ModelExchange`` element only."""

    @property
    def time(self) -> float:
        return self._time

    @time.setter
    def time(self, t: float) -> None:   # fmi3SetTime
        self._time = float(t)
        self._outputs_stale = True

    def _register(self) -> None:
        super()._register()
        cls = type(self)
        by_name = {v.name: v for v in self.vars.values()}
        for i, st in enumerate(cls.model.states):
            by_name[st.name].setter = self._state_setter(i)
        for i, st in enumerate(cls.model.states):
            unit = derivative_unit(st.unit)
            self.register_variable(Float64(f"der({st.name})", causality=Fmi3Causality.local,
                                           variability=Fmi3Variability.continuous, description=f"d {st.name}/dt",
                                           derivative=by_name[st.name].value_reference, getter=self._der_getter(i),
                                           **({"unit": unit} if unit else {})), nested=False)
        for i, sw in enumerate(cls.model.switches):
            self.register_variable(Float64(sw.name, causality=Fmi3Causality.local,
                                           variability=Fmi3Variability.continuous, description=sw.doc,
                                           unit=sw.unit, getter=self._indicator_getter(i)),
                                   nested=False, has_event_indicator=True)

    def _units_by_name(self) -> dict[str, str]:
        """The co-simulation FMU's units, those of the derivatives and of the event indicators."""
        units = super()._units_by_name()
        model = type(self).model
        units.update({f"der({s.name})": u for s in model.states if (u := derivative_unit(s.unit))})
        units.update({s.name: s.unit for s in model.switches})
        return units

    def _state_setter(self, i):
        def set_(value):
            self._x[i] = value
            self._outputs_stale = True
        return set_

    def _der_getter(self, i):
        return lambda: float(self._derivatives()[i])

    def _indicator_getter(self, i):
        return lambda: float(self._indicators()[i])

    def _indicators(self) -> list[float]:
        if not type(self).model.switches:
            return []
        mdl = self._model if self._initialised else self._build_model()
        return [float(z) for z in mdl.event_indicators(self._time, self._x, self._inputs_now())]

    _state_type = ModelExchangeState

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._pos_time = {ip: 0.0 for ip, _ in self._advanced}   # time each advanced position was last set
        self._last_sides: tuple[bool, ...] = ()   # the indicators' signs at the last event (or initialisation)

    def set_float64(self, vrs, values):
        super().set_float64(vrs, values)
        self._mark_positions()

    def _mark_positions(self) -> None:
        """A motion-input position just set holds from the present time (module docstring)."""
        for ip, _ in self._advanced:
            if self._input_set[ip]:
                self._pos_time[ip] = self._time
                self._input_set[ip] = False

    def _inputs_now(self) -> list:
        """The inputs at the present time: as the host set them, except that a motion-input position the model
        advances is taken as ``position + speed * (t - t_set)`` when the host has not set it since ``t_set``
        (module docstring)."""
        if not self._advanced:
            return self._u
        u = list(self._u)
        for ip, iw in self._advanced:
            u[ip] += u[iw] * (self._time - self._pos_time[ip])
        return u

    def _ode_model(self):
        mdl = self._build_model()
        why = mdl.ode_form()
        if why is not None:
            self._fail(f"no model exchange form at these parameters: {why}")
        return mdl

    def exit_initialization_mode(self):
        self._ode_model()
        super().exit_initialization_mode()
        self._pos_time = {ip: self._time for ip in self._pos_time}
        self._input_set = [False] * len(self._u)
        self._last_sides = self._sides() if type(self).model.switches else ()

    def _derivatives(self) -> np.ndarray:
        self._check_inputs()
        dx = np.asarray(self._model.derivatives(self._time, self._x, self._inputs_now(), self._time), dtype=float)
        if not np.all(np.isfinite(dx)):
            bad = type(self).model.states[int(np.argmin(np.isfinite(dx)))].name
            self._fail(f"derivative of state {bad} is not finite at t = {self._time:.9g} s")
        return dx

    # -- the ModelExchange calls pythonfmu3's wrapper makes ------------------------------------------------
    def get_continuous_states(self):
        if not self._initialised:
            self._refresh()
        return [float(v) for v in self._x]

    def set_continuous_states(self, values):
        self._x = np.array(values, dtype=float)
        self._outputs_stale = True

    def get_number_of_continuous_states(self) -> int:
        return len(type(self).model.states)

    def get_continuous_state_derivatives(self):
        return [float(v) for v in self._derivatives()]

    def get_number_of_event_indicators(self) -> int:
        return len(type(self).model.switches)

    def get_event_indicators(self):
        return self._indicators()

    def get_nominals_of_continuous_states(self, size: int):
        return [1.0] * size

    def update_discrete_states(self):
        """At an event (an indicator's sign change the host located, an input changed in event mode): the model's
        memory update (``Model.at_event``) at the present time; the results under the names the C wrapper reads
        (module docstring)."""
        result = _UpdateResult()
        if type(self).model.switches and self._initialised:
            sides = self._sides()
            if sides != self._last_sides:    # an indicator changed sign since the last event (or initialisation)
                x = np.asarray(self._model.at_event(self._time, self._x.copy(), self._inputs_now()), dtype=float)
                if not np.array_equal(x, self._x):
                    self._x = x
                    self._outputs_stale = True
                    result.valuesOfContinuousStatesChanged = True
                self._last_sides = self._sides()
        return result

    def _sides(self) -> tuple[bool, ...]:
        return tuple(z > 0.0 for z in self._indicators())

    def do_step(self, current_time, step_size):
        self._fail("a model exchange FMU is integrated by its host (fmi3DoStep is co-simulation)")

    # -- model description -------------------------------------------------------------------------------
    def to_xml(self, model_options=dict()) -> Element:
        root = super().to_xml(model_options)
        cs = root.find("CoSimulation")
        me = Element("ModelExchange", {"modelIdentifier": cs.get("modelIdentifier"), **MODEL_EXCHANGE})
        root.insert(list(root).index(cs), me)
        root.remove(cs)
        for extra in root.findall("ModelExchange")[1:]:   # pythonfmu3's own element (ModelExchange mixin)
            root.remove(extra)

        # ModelStructure in FMI 3.0's order: Output, ContinuousStateDerivative, InitialUnknown.
        # An output of a model with states depends on them too (the co-simulation FMU lists only its inputs).
        vr = {v.name: v.value_reference for v in self.vars.values()}
        states = [vr[s.name] for s in type(self).model.states]
        old = root.find("ModelStructure")
        structure = Element("ModelStructure")
        for o in old.findall("Output"):
            deps = sorted({int(d) for d in o.get("dependencies", "").split()} | set(states))
            SubElement(structure, "Output", valueReference=o.get("valueReference"),
                       dependencies=" ".join(map(str, deps)))
        ders = [vr[f"der({s.name})"] for s in type(self).model.states]
        for d in ders:
            SubElement(structure, "ContinuousStateDerivative", valueReference=str(d))
        unknowns = {int(u.get("valueReference")): u.get("dependencies") for u in old.findall("InitialUnknown")}
        unknowns.update({v: None for v in states + ders})
        for v in sorted(unknowns):
            attrs = {"valueReference": str(v)}
            if unknowns[v] is not None:
                attrs["dependencies"] = unknowns[v]
            SubElement(structure, "InitialUnknown", attrs)
        for sw in type(self).model.switches:
            SubElement(structure, "EventIndicator", valueReference=str(vr[sw.name]))
        root.insert(list(root).index(old), structure)
        root.remove(old)
        return root


def fmu_class(declaration: type) -> type:
    """The FMI 3.0 model exchange slave class of a declaration (:func:`fmus.slave_core.slave_class`)."""
    return slave_class(declaration, PressSlave)
