"""The FMI-version-neutral part of the one base slave: the behaviour of every FMU and its saved state.

``fmus.slave`` puts :class:`PressBehaviour` on pythonfmu's ``Fmi2Slave`` (FMI 2.0) and ``fmus.slave3`` on
pythonfmu3's ``Fmi3Slave`` (FMI 3.0); what differs between the versions is only how variables are
registered, the names of the value-access calls and how the modelDescription is written.  So an FMU of
either version is the same declaration (``fmus/components/pd_*.py``) run by the same code, and this module
imports neither pythonfmu: an FMI 3.0 FMU does not need the FMI 2.0 exporter at run time, nor the reverse.
The declarations are :mod:`fmus.declaration`; the port convention is described in ``fmus.slave``; what the
exporters' C wrappers need besides is :mod:`fmus.wrapper_glue`.
"""
from __future__ import annotations

import functools
import json

import math
from dataclasses import dataclass, fields
from typing import ClassVar
from xml.etree.ElementTree import Element, SubElement

import numpy as np

from .declaration import Component, Input, Output, Port, Rotational, Translational, Variable  # noqa: F401
from .physics.base import DIFFERENCE_STEP, Model, ParameterError
from .refusal import CATEGORY as REFUSAL_CATEGORY
from .refusal import Refusal
from .units import BASE_UNITS
from .wrapper_glue import hold_module_dict, offer_to_loader


def _copied(value):
    """A copy of a state attribute that no later change of the slave reaches (arrays, lists and dicts are
    copied; numbers, flags, tuples and the model, immutable once built, are kept by reference)."""
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, list):
        return list(value)
    if isinstance(value, dict):
        return dict(value)
    return value


def _key_part(value):
    """A state attribute as part of a hashable, comparable key."""
    if isinstance(value, np.ndarray):
        return value.tobytes()
    if isinstance(value, list):
        return tuple(value)
    if isinstance(value, dict):
        return tuple(value.items())
    return value


@dataclass(frozen=True)
class SlaveState:
    """The complete internal state of a slave (fmi2GetFMUstate / fmi3GetFMUState): each field ``f`` is the
    slave's attribute ``_f``.  The model object (``model``) is immutable once built (fmus.physics.base.Model:
    everything that evolves lives in ``x``), so it is kept by reference; the containers are copied both ways, so
    a saved state can be restored any number of times.  A base slave with more state extends this class and
    names it in its ``_state_type`` (tests/test_slave_state.py checks that every attribute a step changes is a
    field).

    The fields but :attr:`DERIVED` also key what the slave caches from its state
    (:meth:`PressBehaviour._feedthrough`)."""
    x: np.ndarray            # the model's state
    u: list                  # the inputs as set
    y: list                  # the outputs last computed
    time: float
    outputs_stale: bool      # the outputs must be recomputed before the next get
    initialised: bool
    par: dict                # the parameters as set
    model: Model | None      # the model built from them (None: to be built)
    input_set: list          # per input: set since the last step (else held over it)
    last_step: float         # size of the last step taken

    # computed from the other fields (the outputs and whether they are up to date): not part of a cache key
    DERIVED: ClassVar[frozenset] = frozenset({"y", "outputs_stale"})

    @classmethod
    def of(cls, slave) -> "SlaveState":
        return cls(**{f.name: _copied(getattr(slave, f"_{f.name}")) for f in fields(cls)})

    def restore(self, slave) -> None:
        for f in fields(self):
            setattr(slave, f"_{f.name}", _copied(getattr(self, f.name)))

    @classmethod
    def key(cls, slave) -> tuple:
        """The slave's present state but the derived fields, as a key (compared with ``==``)."""
        return tuple(_key_part(getattr(slave, f"_{f.name}")) for f in fields(cls) if f.name not in cls.DERIVED)


def _encoded(value):
    """A state field as JSON: arrays, tuples and dicts tagged (dict keys may be numbers), floats exact (repr)."""
    if isinstance(value, np.ndarray):
        return {"__array__": value.tolist(), "dtype": str(value.dtype)}
    if isinstance(value, tuple):
        return {"__tuple__": [_encoded(v) for v in value]}
    if isinstance(value, dict):
        return {"__dict__": [[_encoded(k), _encoded(v)] for k, v in value.items()]}
    if isinstance(value, list):
        return [_encoded(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def _decoded(value):
    if isinstance(value, list):
        return [_decoded(v) for v in value]
    if isinstance(value, dict):
        if "__array__" in value:
            return np.array(value["__array__"], dtype=value["dtype"])
        if "__tuple__" in value:
            return tuple(_decoded(v) for v in value["__tuple__"])
        if "__dict__" in value:
            return {_decoded(k): _decoded(v) for k, v in value["__dict__"]}
    return value


def state_to_bytes(state: SlaveState) -> bytes:
    """A saved state as bytes (fmi2SerializeFMUstate): every field but the model (rebuilt from the parameters
    when the state is set), as JSON whose floats round-trip exactly."""
    body = {f.name: _encoded(getattr(state, f.name)) for f in fields(state) if f.name != "model"}
    return json.dumps({"state": type(state).__name__, "fields": body}).encode("utf-8")


def state_from_bytes(data: bytes) -> dict:
    """The fields of :func:`state_to_bytes`'s bytes (the model None), for the slave's ``_set_fmu_state``."""
    return {k: _decoded(v) for k, v in json.loads(bytes(data).decode("utf-8"))["fields"].items()}


class PressBehaviour(Component):
    """What every press-drive slave does, whatever its FMI version (module docstring).  A version's base class
    derives from this and its exporter's slave class and adds ``_register``, the value-access calls and
    ``to_xml``; the FMU's class derives from its declaration (:class:`fmus.declaration.Component`) and that base.
    """

    _state_type: ClassVar[type[SlaveState]] = SlaveState   # what _get_fmu_state saves

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        hold_module_dict(cls)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.modelName = type(self).__name__
        cls = type(self)
        self._io = cls.interface()
        self._param_specs = cls.model.Params.specs()
        unknown = sorted(set(cls.tunable) - {s.name for s in self._param_specs})
        if unknown:
            raise TypeError(f"{cls.__name__}: tunable names no parameter of {cls.model.__name__}: {unknown[0]!r}")
        self._par = {s.name: s.default for s in self._param_specs}
        self._u = [v.start for v in self._io if v.causality == "input"]
        self._input_set = [True] * len(self._u)  # input set since the last step (else held over it)
        self._last_step = 0.0                # size of the last step taken (do_step)
        names = [v.name for v in self._io if v.causality == "input"]
        # (position, velocity) input indices of the motion-input ports the model advances over a step
        self._advanced = [(names.index(pos), names.index(f"{port.name}.{'v' if port.translational else 'w'}"))
                          for port, pos in zip(cls.ports, cls._port_positions()) if pos is not None]
        # (index, name, min, max) of every input that declares a range: a value outside is refused (_check_inputs)
        self._ranges = [(i, v.name, v.min, v.max) for i, v in enumerate(v for v in self._io if v.causality == "input")
                        if v.min is not None or v.max is not None]
        self._y = [0.0] * len(cls.model.outputs)
        self._x = np.zeros(len(cls.model.states))
        self._time = 0.0
        self._model: Model | None = None
        self._initialised = False
        self._outputs_stale = True  # outputs must be recomputed before the next get
        self._register()
        # fast paths of the value access (_get_outputs, _set_inputs)
        n_in = len(cls.model.inputs)
        self._out_by_vr = {vr: i - n_in for vr, v in self.vars.items() for i, io in enumerate(self._io)
                           if io.causality == "output" and v.name == io.name}
        self._in_by_vr = {vr: i for vr, v in self.vars.items() for i, io in enumerate(self._io)
                          if io.causality == "input" and v.name == io.name}
        self._feedthrough_cache = (None, None)  # (key, feed-through block) of the last directional derivative
        if cls.model.provides_output_jacobian():
            offer_to_loader(self.instance_name, self.directional_derivative)

    def _par_getter(self, name):
        return lambda: self._par[name]

    def _par_setter(self, name):
        tunable = name in type(self).tunable

        def set_(value):
            if self._initialised and not tunable:
                raise RuntimeError(f"{self.instance_name}: parameter {name} is fixed after initialisation")
            if self._initialised and value == self._par[name]:
                return   # a held value set again (a master sets its signals at every step): nothing changes
            before = (self._par[name], self._model)
            self._par[name] = value
            self._model = None
            self._outputs_stale = True
            if self._initialised:
                # a tunable parameter during the run: the model is rebuilt at once from the present state, so a
                # refused value fails this call (fmus.refusal) and the instance keeps the value it had
                try:
                    self._build_model()
                except RuntimeError:
                    self._par[name], self._model = before
                    raise
        return set_

    def _in_getter(self, i):
        return lambda: self._u[i]

    def _in_setter(self, i):
        def set_(value):
            self._u[i] = value
            self._input_set[i] = True
            self._outputs_stale = True
        return set_

    def _out_getter(self, i):
        def get():
            if self._outputs_stale:
                self._refresh()
            return self._y[i]
        return get

    def _state_getter(self, i):
        def get():
            if not self._initialised:
                self._refresh()
            return float(self._x[i])
        return get

    # -- FMI value access (fast paths of the versions' get/set calls: one Python call per FMI call instead of one
    # getter per variable) ----------------------------------------------------------------------------------
    def _get_outputs(self, vrs):
        """Outputs only: refresh once, then index (same values as the per-variable getters); None when a
        reference is not an output (the caller then takes the exporter's per-variable path)."""
        out = self._out_by_vr
        try:
            idx = [out[vr] for vr in vrs]
        except KeyError:
            return None
        if self._outputs_stale and idx:
            self._refresh()
        y = self._y
        return [y[i] for i in idx]

    def _set_inputs(self, vrs, values) -> bool:
        """Inputs only: store and mark the outputs stale (as the per-variable setters do); False, storing
        nothing, when a reference is not an input."""
        inp = self._in_by_vr
        for vr in vrs:
            if vr not in inp:
                return False
        u, fresh = self._u, self._input_set
        for vr, value in zip(vrs, values):
            i = inp[vr]
            u[i] = value
            fresh[i] = True
            self._outputs_stale = True
        return True

    # -- behaviour ---------------------------------------------------------------------------------------
    def _fail(self, message: str):
        line = f"{self.instance_name} ({type(self).__name__}): {message}"
        self.log(line, self._ERROR)
        raise RuntimeError(line)

    def _build_model(self) -> Model:
        if self._model is None:
            cls = type(self).model
            try:
                self._model = cls(cls.Params.from_mapping(self._par))
            except ParameterError as e:
                # the refusal for programs (fmus.refusal: its own log category), then the line for people
                refusal = Refusal.of(e, next((s.unit for s in self._param_specs if s.name == e.name), ""))
                self.log(refusal.to_message(), self._OK, category=REFUSAL_CATEGORY)
                self._fail(refusal.sentence())
        return self._model

    def _refresh(self) -> None:
        mdl = self._build_model()
        if not self._initialised:
            self._x = np.asarray(mdl.initial_state(self._u), dtype=float)
        self._y = [float(v) for v in mdl.output(self._time, self._x, self._inputs_now())]
        self._outputs_stale = False

    def _inputs_now(self) -> list:
        """The inputs as the model saw them at the slave's time: a motion-input position not set since the last
        step started is advanced over that step with its velocity, as ``Model.advance`` advanced it.

        Why: libcosim, Ecos and FMPy's ``simulate_ssp`` read the outputs right after ``fmi2DoStep``, before any new
        input.  An output computed from the state at t+h and the position held from t (a stiff mesh or coupler
        spring: c * (phi_in - phi)) is then wrong by c * w * h, a first-order error with a large constant.  A
        position set at t+h (a master that refreshes feed-through: the harness's ``jacobi``, OMSimulator) is used
        as set."""
        u = self._u
        if not (self._initialised and self._advanced):
            return u
        u = list(u)
        h, fresh = self._last_step, self._input_set
        for ip, iw in self._advanced:
            if not fresh[ip]:   # held over the last step: the model advanced it by h
                u[ip] += u[iw] * h
        return u

    # -- directional derivatives (FMI co-simulation: outputs with respect to inputs at the current time) --------
    def directional_derivative(self, unknowns, knowns, seed) -> list[float]:
        """sum_j d unknowns_i / d knowns_j * seed_j: the outputs' partial derivatives with respect to the inputs at
        the current time and state (fmi2GetDirectionalDerivative / fmi3GetDirectionalDerivative in co-simulation),
        from the model's :meth:`~fmus.physics.base.Model.output_jacobian`; in initialisation mode those of the
        initial outputs (:meth:`_initial_feedthrough`).  The unknowns are value references of outputs, the knowns
        of inputs; anything else or a seed of another length is refused in one line (ValueError).

        The outputs use a motion-input position held over the last step advanced by its speed (``_inputs_now``),
        so the derivative is taken through that too: with the position held, d/d speed gains h * d/d position,
        which is what setting the speed alone and reading the outputs again gives."""
        cls = type(self)
        knowns, unknowns = list(knowns), list(unknowns)
        if len(seed) != len(knowns):
            raise ValueError(f"{self.instance_name} ({cls.__name__}): {len(seed)} seed values for {len(knowns)} knowns")
        rows, cols = [], []
        for vrs, index, kind, out in ((unknowns, self._out_by_vr, "an output", rows), (knowns, self._in_by_vr,
                                                                                        "an input", cols)):
            for vr in vrs:
                if vr not in index:
                    name = self.vars[vr].name if vr in self.vars else "no variable"
                    raise ValueError(f"{self.instance_name} ({cls.__name__}): directional derivative: value reference "
                                     f"{vr} ({name}) is not {kind}; the FMU gives d outputs / d inputs")
                out.append(index[vr])
        D = self._feedthrough()
        return [float(v) for v in D[np.ix_(rows, cols)] @ np.asarray(seed, dtype=float)] if rows else []

    def _feedthrough(self) -> np.ndarray:
        """D = d outputs / d inputs as the FMU's outputs see the inputs (``directional_derivative``), kept while
        model, mode, time, state and inputs stay the same (a master asks for it one seed at a time)."""
        u = self._inputs_now()
        mdl = self._build_model()    # a new object after a parameter changed
        key = self._state_type.key(self)
        if self._feedthrough_cache[0] == key:
            return self._feedthrough_cache[1]
        if not self._initialised:
            D = self._initial_feedthrough(mdl)
            self._feedthrough_cache = (key, D)
            return D
        D = np.asarray(mdl.output_jacobian(self._time, self._x, u), dtype=float)
        if self._advanced:
            h = self._last_step
            for ip, iw in self._advanced:
                if not self._input_set[ip]:     # u_now[ip] = u[ip] + h * u[iw]
                    D[:, iw] += h * D[:, ip]
        self._feedthrough_cache = (key, D)
        return D

    def _initial_feedthrough(self, mdl: Model) -> np.ndarray:
        """d outputs / d inputs before initialisation has ended, where the state is the model's initial state for
        the inputs (``_refresh``: x = initial_state(u)), so the initial outputs output(t, initial_state(u), u)
        also move with the inputs through the state.  The models give no slope of their initial state (kinematic
        closures solved by branches, among others), so this one is by central differences of that composite
        (step DIFFERENCE_STEP * max(1, |u_j|), as Model.output_jacobian_by_differences); after initialisation the
        state is the state and the slopes are the models' own."""
        u = [float(v) for v in self._u]
        D = np.zeros((len(self._y), len(u)))
        for j, uj in enumerate(u):
            step = DIFFERENCE_STEP * max(1.0, abs(uj))
            up, um = list(u), list(u)
            up[j], um[j] = uj + step, uj - step
            yp = np.asarray(mdl.output(self._time, np.asarray(mdl.initial_state(up), dtype=float), up), dtype=float)
            ym = np.asarray(mdl.output(self._time, np.asarray(mdl.initial_state(um), dtype=float), um), dtype=float)
            D[:, j] = (yp - ym) / (up[j] - um[j])
        return D

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self._time = float(start_time)

    def enter_initialization_mode(self):
        self._build_model()

    def exit_initialization_mode(self):
        self._check_inputs()
        mdl = self._build_model()
        self._x = np.asarray(mdl.initial_state(self._u), dtype=float)
        self._initialised = True
        self._outputs_stale = True

    def _check_inputs(self) -> None:
        """Every input finite and within the min/max its modelDescription declares, else the refused parameter's
        error path (:meth:`_fail`: one line naming the instance, the variable, the value and the range): a host
        that does not read the declared ranges gets the answer from the FMU itself."""
        u = self._u
        for i, name, lo, hi in self._ranges:
            value = u[i]
            if (lo is not None and value < lo) or (hi is not None and value > hi):
                self._fail(f"input {name} = {float(value)!r} at t = {self._time:.9g} s is outside its declared range "
                           f"[{'-inf' if lo is None else f'{lo:g}'}, {'inf' if hi is None else f'{hi:g}'}]")
        if math.isfinite(sum(u)):  # every input is finite (a NaN or an infinity makes the sum non-finite)
            return
        for v, value in zip(self._io, u):
            if not math.isfinite(value):
                self._fail(f"input {v.name} = {value!r} at t = {self._time:.9g} s is not finite")

    def do_step(self, current_time, step_size):
        self._check_inputs()
        x = self._model.advance(current_time, step_size, self._x, self._u)
        if not math.isfinite(sum(x.tolist())) and not np.all(np.isfinite(x)):  # the sum alone may overflow
            bad = type(self).model.states[int(np.argmin(np.isfinite(x)))].name
            self._fail(f"state {bad} became non-finite in the step from t = {current_time:.9g} s, h = {step_size:.3g} s")
        self._x = x
        self._last_step = step_size
        self._input_set = [False] * len(self._u)
        self._time = current_time + step_size
        self._outputs_stale = True
        return True

    # -- FMU state (rollback): SlaveState ----------------------------------------------------------------------
    def _get_fmu_state(self) -> SlaveState:
        return self._state_type.of(self)

    def _set_fmu_state(self, state) -> None:
        if isinstance(state, dict):   # deserialized (state_from_bytes): the model is built again from par
            state = self._state_type(model=None, **state)
        state.restore(self)
        if self._model is None and self._initialised:
            self._build_model()

    # serialized states (pythonfmu calls these on the class): fmi2SerializeFMUstate / fmi2DeSerializeFMUstate
    _fmu_state_to_bytes = staticmethod(state_to_bytes)
    _fmu_state_from_bytes = staticmethod(state_from_bytes)

    # -- what the modelDescription says, in names (each version writes it in its own XML) ---------------------
    def _units_by_name(self) -> dict[str, str]:
        """The unit of every Real (Float64) variable: inputs, outputs, Real parameters and states."""
        units = {v.name: v.unit for v in self._io}
        units.update({s.name: s.unit for s in self._param_specs if not s.is_integer})
        units.update({s.name: s.unit for s in type(self).model.states})
        return units

    def _input_ranges(self) -> dict[str, dict[str, str]]:
        """The declared min/max of every input that has one, as modelDescription attributes."""
        out = {}
        for v in self._io:
            if v.causality == "input":
                bounds = {k: f"{x:.16g}" for k, x in (("min", v.min), ("max", v.max)) if x is not None}
                if bounds:
                    out[v.name] = bounds
        return out

    def _advanced_positions(self) -> list[str]:
        """The motion-input positions this slave advances itself over a step (``advances_position``)."""
        return [pos for pos in type(self)._port_positions() if pos is not None]

    def _output_dependencies(self) -> list[tuple[str, tuple[str, ...], tuple[str, ...]]]:
        """(output, its direct input dependencies in continuous time, its dependencies at initialisation) for
        every output: ``feedthrough`` (anything else depends on no input, so importers see no false algebraic
        loop); at initialisation also every parameter."""
        params = tuple(s.name for s in self._param_specs)
        direct = {v.name: tuple(type(self).feedthrough.get(v.name, ())) for v in self._io if v.causality == "output"}
        return [(name, deps, deps + params) for name, deps in direct.items()]


def unit_definitions(units) -> Element:
    """``UnitDefinitions`` of the given unit names (sorted), as exponents of SI base units (the same element in
    FMI 2.0 and 3.0)."""
    unit_defs = Element("UnitDefinitions")
    for name in sorted(set(units)):
        unit = SubElement(unit_defs, "Unit", name=name)
        SubElement(unit, "BaseUnit", {k: str(e) for k, e in BASE_UNITS[name].items()})
    return unit_defs


@functools.lru_cache(maxsize=None)
def slave_class(declaration: type, base: type) -> type:
    """The slave class of a declaration (:class:`fmus.declaration.Component`) on the FMI version's ``base``
    (a ``PressSlave``), as the FMU's module defines it (:func:`fmus.build.fmu_module`):
    ``class <Name>(<declaration>, <base>)``, made in this process (each version's ``fmu_class``)."""
    return type(declaration.__name__, (declaration, base), {"__module__": declaration.__module__,
                                                            "__qualname__": declaration.__qualname__})
