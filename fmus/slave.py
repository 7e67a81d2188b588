"""The one base slave every press-drive FMU is built on (pythonfmu ``Fmi2Slave``).

An FMU class only declares what it is::

    class FourBar(PressSlave):
        model = fourbar.FourBarModel                       # equations (fmus.physics)
        description = "..."
        ports = (Rotational("crank", motion="in", doc=...),
                 Rotational("rocker", motion="out", doc=...))
        signals = (Output("transmission_angle", "rad", "..."),)
        feedthrough = {"crank.tau": ("crank.phi", "crank.w", "rocker.tau")}

and this class does the rest:

* registers the parameters of ``model.Params`` (Real with unit, Integer for integer fields), the port and
  signal inputs/outputs, and the model states as ``local`` variables;
* writes a standard modelDescription: ``UnitDefinitions``, a unit on every Real, and a ``ModelStructure``
  whose ``Outputs`` carry their true direct dependencies (``feedthrough``; everything else depends on no
  input, so importers see no false algebraic loop) and whose ``InitialUnknowns`` list every output;
* integrates the model inside ``do_step`` over exactly ``communicationStepSize`` (``Model.advance``);
* computes outputs lazily, so outputs that depend directly on inputs follow ``fmi2SetReal`` at once;
* saves and restores the complete internal state (``fmi2GetFMUstate``/``fmi2SetFMUstate``) bit for bit;
* validates parameters on entering/leaving initialisation and inputs before each step: a bad value is
  logged as one line naming the instance, variable and value, and the call fails (pythonfmu reports a
  Python exception as ``fmi2Fatal``; it offers no way to return ``fmi2Error`` from these calls).

Ports follow the power-bond convention: ``Rotational(name, motion="in")`` has inputs ``name.phi`` [rad],
``name.w`` [rad/s] and output ``name.tau`` [N.m]; ``motion="out"`` is the reverse.  ``Translational`` uses
``.s``/``.v``/``.f``.  On every bond, ``tau`` is the torque that the motion-input component exerts on the
flange of the motion-output component, positive in the positive sense of rotation.  So a motion-output
component integrates ``J*dw/dt = ... + port.tau``, a motion-input component outputs its reaction on the
driver (a load gives ``tau < 0`` while it is driven forwards), and ``tau * w`` is the power flowing into
the motion-output component across the bond.
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from typing import ClassVar, Sequence
from xml.etree.ElementTree import Element, SubElement

import numpy as np
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status

from .physics.base import Model, ParameterError
from .units import BASE_UNITS, check_unit

_ROT = (("phi", "rad", "angle"), ("w", "rad/s", "angular velocity"), ("tau", "N.m", "torque"))
_TRA = (("s", "m", "position"), ("v", "m/s", "velocity"), ("f", "N", "force"))


@dataclass(frozen=True)
class Port:
    """A mechanical power port: motion one way, effort the other."""
    name: str
    motion: str  # "in": motion variables are inputs, effort is an output; "out": the reverse
    doc: str
    translational: bool = False

    def __post_init__(self):
        if self.motion not in ("in", "out"):
            raise ValueError(f"port {self.name}: motion must be 'in' or 'out', got {self.motion!r}")

    def variables(self) -> list["Variable"]:
        (p, pu, pd), (v, vu, vd), (e, eu, ed) = _TRA if self.translational else _ROT
        motion_c, effort_c = ("input", "output") if self.motion == "in" else ("output", "input")
        effort_doc = ("reaction this component exerts on the driving flange" if self.motion == "in"
                      else "torque/force the connected part exerts on this flange")
        return [Variable(f"{self.name}.{p}", motion_c, pu, f"{self.doc}: {pd} (motion {self.motion})"),
                Variable(f"{self.name}.{v}", motion_c, vu, f"{self.doc}: {vd} (motion {self.motion})"),
                Variable(f"{self.name}.{e}", effort_c, eu, f"{self.doc}: {ed}, {effort_doc}")]


def Rotational(name: str, motion: str, doc: str) -> Port:
    return Port(name, motion, doc, translational=False)


def Translational(name: str, motion: str, doc: str) -> Port:
    return Port(name, motion, doc, translational=True)


@dataclass(frozen=True)
class Variable:
    name: str
    causality: str  # "input" | "output"
    unit: str
    doc: str
    start: float = 0.0


def Input(name: str, unit: str, doc: str, start: float = 0.0) -> Variable:
    return Variable(name, "input", unit, doc, start)


def Output(name: str, unit: str, doc: str) -> Variable:
    return Variable(name, "output", unit, doc)


_MODULE_DICT_REFS: list = []


def _hold_module_dict(cls: type) -> None:
    """Work around a reference-count bug of the pythonfmu 0.7 C wrapper.

    On every ``fmi2Instantiate`` its ``findClass`` re-executes the FMU's module source (with the module's
    ``__dict__`` as globals) and then releases that *borrowed* ``__dict__`` once.  A component module that
    defines no functions holds its dict only through the module object, so the first instantiation frees
    it and the second crashes.  Every class statement that derives from PressSlave runs this hook, on
    import and again on each re-execution by the wrapper, so each release is matched by one reference
    taken just before it (tests/test_fmus_built.py::test_many_instances_in_one_process).  Module dicts
    live as long as the process anyway, so the extra references cost nothing elsewhere.
    """
    module = sys.modules.get(cls.__module__)
    if module is not None:
        _MODULE_DICT_REFS.append(vars(module))


class PressSlave(Fmi2Slave):
    """Base class: see the module docstring.  Subclasses set the class attributes below."""

    model: ClassVar[type[Model]]
    description: ClassVar[str] = ""
    ports: ClassVar[tuple[Port, ...]] = ()
    signals: ClassVar[tuple[Variable, ...]] = ()
    feedthrough: ClassVar[dict[str, tuple[str, ...]]] = {}
    # motion-input ports whose position the model advances over a step with the held velocity input
    # (phi(t) = port.phi + port.w*(t - t0)); declared in the modelDescription (VendorAnnotations, tool
    # "org.pressdrive") so a master hands these positions over at the step start, not extrapolated
    advances_position: ClassVar[bool] = True
    author = "press-drive toolkit"
    license = "MIT"
    version = "0.1.0"

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        _hold_module_dict(cls)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.modelName = type(self).__name__
        cls = type(self)
        self._io = cls.interface()
        self._param_specs = cls.model.Params.specs()
        self._par = {s.name: s.default for s in self._param_specs}
        self._u = [v.start for v in self._io if v.causality == "input"]
        self._y = [0.0] * len(cls.model.outputs)
        self._x = np.zeros(len(cls.model.states))
        self._time = 0.0
        self._mdl: Model | None = None
        self._initialised = False
        self._stale = True  # outputs must be recomputed before the next get
        self._register()
        # fast paths of get_real/set_real (one Python call per FMI call instead of one getter per variable)
        n_in = len(cls.model.inputs)
        self._out_by_vr = {vr: i - n_in for vr, v in self.vars.items() for i, io in enumerate(self._io)
                           if io.causality == "output" and v.name == io.name}
        self._in_by_vr = {vr: i for vr, v in self.vars.items() for i, io in enumerate(self._io)
                          if io.causality == "input" and v.name == io.name}

    # -- declaration -----------------------------------------------------------------------------------
    @classmethod
    def interface(cls) -> list[Variable]:
        """All inputs and outputs, checked against the model's own names."""
        io = [v for port in cls.ports for v in port.variables()] + list(cls.signals)
        for v in io:
            check_unit(v.unit)
        ins = {v.name for v in io if v.causality == "input"}
        outs = {v.name for v in io if v.causality == "output"}
        if ins != set(cls.model.inputs) or outs != set(cls.model.outputs):
            raise TypeError(f"{cls.__name__}: declared inputs/outputs {sorted(ins)} / {sorted(outs)} differ "
                            f"from model {cls.model.__name__}: {sorted(cls.model.inputs)} / {sorted(cls.model.outputs)}")
        for out, deps in cls.feedthrough.items():
            if out not in outs or not set(deps) <= ins:
                raise TypeError(f"{cls.__name__}: feedthrough entry {out}: {deps} names unknown variables")
        # order inputs and outputs as the model expects them
        order = {n: i for i, n in enumerate(cls.model.inputs + cls.model.outputs)}
        return sorted(io, key=lambda v: (v.causality != "input", order[v.name]))

    def _register(self) -> None:
        for s in self._param_specs:
            kind = Integer if s.is_integer else Real
            self.register_variable(kind(s.name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                        description=s.doc, getter=self._par_getter(s.name),
                                        setter=self._par_setter(s.name)), nested=False)
        n_in = len(type(self).model.inputs)
        for i, v in enumerate(self._io):
            if v.causality == "input":
                self.register_variable(Real(v.name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                                            description=v.doc, getter=self._in_getter(i), setter=self._in_setter(i)),
                                       nested=False)
            else:
                self.register_variable(Real(v.name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                                            description=v.doc, getter=self._out_getter(i - n_in)), nested=False)
        for i, st in enumerate(type(self).model.states):
            self.register_variable(Real(st.name, causality=Fmi2Causality.local, variability=Fmi2Variability.continuous,
                                        description=st.doc, getter=self._state_getter(i)), nested=False)

    def _par_getter(self, name):
        return lambda: self._par[name]

    def _par_setter(self, name):
        def set_(value):
            if self._initialised:
                raise RuntimeError(f"{self.instance_name}: parameter {name} is fixed after initialisation")
            self._par[name] = value
            self._mdl = None
            self._stale = True
        return set_

    def _in_getter(self, i):
        return lambda: self._u[i]

    def _in_setter(self, i):
        def set_(value):
            self._u[i] = value
            self._stale = True
        return set_

    def _out_getter(self, i):
        def get():
            if self._stale:
                self._refresh()
            return self._y[i]
        return get

    def _state_getter(self, i):
        def get():
            if not self._initialised:
                self._refresh()
            return float(self._x[i])
        return get

    # -- FMI value access (fast paths; anything else goes through pythonfmu's per-variable getters) ----------
    def get_real(self, vrs):
        """Outputs only: refresh once, then index (same values as the per-variable getters)."""
        out = self._out_by_vr
        try:
            idx = [out[vr] for vr in vrs]
        except KeyError:
            return super().get_real(vrs)
        if self._stale and idx:
            self._refresh()
        y = self._y
        return [y[i] for i in idx]

    def set_real(self, vrs, values):
        """Inputs only: store and mark the outputs stale (as the per-variable setters do)."""
        inp = self._in_by_vr
        for vr in vrs:
            if vr not in inp:
                return super().set_real(vrs, values)
        u = self._u
        for vr, value in zip(vrs, values):
            u[inp[vr]] = value
            self._stale = True

    # -- behaviour ---------------------------------------------------------------------------------------
    def _fail(self, message: str):
        line = f"{self.instance_name} ({type(self).__name__}): {message}"
        self.log(line, Fmi2Status.error)
        raise RuntimeError(line)

    def _build_model(self) -> Model:
        if self._mdl is None:
            cls = type(self).model
            try:
                self._mdl = cls(cls.Params.from_mapping(self._par))
            except ParameterError as e:
                unit = next((s.unit for s in self._param_specs if s.name == e.name), "")
                self._fail(f"parameter {e.name} = {e.value!r} {unit}".rstrip() + f" is not admissible: {e.requirement}")
        return self._mdl

    def _refresh(self) -> None:
        mdl = self._build_model()
        if not self._initialised:
            self._x = np.asarray(mdl.initial_state(self._u), dtype=float)
        self._y = [float(v) for v in mdl.output(self._time, self._x, self._u)]
        self._stale = False

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self._time = float(start_time)

    def enter_initialization_mode(self):
        self._build_model()

    def exit_initialization_mode(self):
        self._check_inputs()
        mdl = self._build_model()
        self._x = np.asarray(mdl.initial_state(self._u), dtype=float)
        self._initialised = True
        self._stale = True

    def _check_inputs(self) -> None:
        if math.isfinite(sum(self._u)):  # every input is finite (a NaN or an infinity makes the sum non-finite)
            return
        for v, value in zip(self._io, self._u):
            if not math.isfinite(value):
                self._fail(f"input {v.name} = {value!r} at t = {self._time:.9g} s is not finite")

    def do_step(self, current_time, step_size):
        self._check_inputs()
        x = self._mdl.advance(current_time, step_size, self._x, self._u)
        if not math.isfinite(sum(x.tolist())) and not np.all(np.isfinite(x)):  # the sum alone may overflow
            bad = type(self).model.states[int(np.argmin(np.isfinite(x)))].name
            self._fail(f"state {bad} became non-finite in the step from t = {current_time:.9g} s, h = {step_size:.3g} s")
        self._x = x
        self._time = current_time + step_size
        self._stale = True
        return True

    # The complete internal state.  The model object (self._mdl) is immutable once built (fmus.physics.base.Model:
    # everything that evolves lives in x), so it is kept by reference; the containers are copied both ways, so
    # a saved state can be restored any number of times.
    def _get_fmu_state(self):
        return (self._x.copy(), list(self._u), list(self._y), self._time, self._stale, self._initialised,
                dict(self._par), self._mdl)

    def _set_fmu_state(self, state):
        x, u, y, self._time, self._stale, self._initialised, par, self._mdl = state
        self._x, self._u, self._y, self._par = x.copy(), list(u), list(y), dict(par)

    # -- model description -------------------------------------------------------------------------------
    def to_xml(self, model_options=dict()) -> Element:
        root = super().to_xml(model_options)
        root.set("description", type(self).description.strip().splitlines()[0] if type(self).description else
                 type(self).__name__)
        index = {v.name: i + 1 for i, v in enumerate(self.vars.values())}
        units_by_name = {v.name: v.unit for v in self._io}
        units_by_name.update({s.name: s.unit for s in self._param_specs if not s.is_integer})
        units_by_name.update({s.name: s.unit for s in type(self).model.states})
        for sv in root.find("ModelVariables"):
            real = sv.find("Real")
            if real is not None:
                real.set("unit", units_by_name[sv.get("name")])
        used = sorted(set(units_by_name.values()))
        unit_defs = Element("UnitDefinitions")
        for name in used:
            unit = SubElement(unit_defs, "Unit", name=name)
            exps = BASE_UNITS[name]
            SubElement(unit, "BaseUnit", {k: str(e) for k, e in exps.items()})
        pos = list(root).index(root.find("CoSimulation")) + 1
        root.insert(pos, unit_defs)

        advanced = [f"{port.name}.{'s' if port.translational else 'phi'}" for port in type(self).ports
                    if port.motion == "in" and type(self).advances_position]
        # one element (the FMI 2.0 schema allows one child per Tool): the slave module and class, which the
        # toolkit's master may call directly in its own process (harness.fmi.inprocess), and the advanced positions
        vendor = Element("VendorAnnotations")
        tool = SubElement(vendor, "Tool", name="org.pressdrive")
        SubElement(tool, "Slave", {"module": type(self).__module__, "class": type(self).__name__,
                                   "advancedPositions": " ".join(advanced)})
        root.insert(list(root).index(root.find("ModelVariables")), vendor)
        root.remove(root.find("ModelStructure"))
        structure = SubElement(root, "ModelStructure")
        outputs = [v.name for v in self._io if v.causality == "output"]
        params = [s.name for s in self._param_specs]
        if outputs:
            out_el = SubElement(structure, "Outputs")
            init_el = SubElement(structure, "InitialUnknowns")
            for name in sorted(outputs, key=index.get):
                deps = sorted(index[d] for d in type(self).feedthrough.get(name, ()))
                SubElement(out_el, "Unknown", index=str(index[name]), dependencies=" ".join(map(str, deps)))
                init_deps = sorted(deps + [index[p] for p in params])
                SubElement(init_el, "Unknown", index=str(index[name]), dependencies=" ".join(map(str, init_deps)))
        return root
