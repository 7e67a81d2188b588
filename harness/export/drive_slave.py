"""The slave of a whole-drive FMU (``python -m harness export DRIVE FILE.fmu``, :mod:`harness.export.drive_fmu`).

A drive FMU is a pythonfmu co-simulation FMU whose slave runs the toolkit's own master inside: its resources
carry the drive's member FMUs (``resources/members/<Model>.fmu``) and a private copy of the harness's modules
this file needs (``harness_<hash>``, so drive FMUs of any toolkit version load side by side with each other and
with the harness of the host process).  The drive itself is data, ``spec`` (written by the export into the
staged script): its instances and parameter values, connections and power bonds, the declared master, input
extrapolation and step, and the FMU's interface (parameters, free inputs, chosen outputs with units and
descriptions).

* On the first need (an output read in initialization mode, or ``fmi2ExitInitializationMode``) the members are
  opened in this process (:func:`harness.fmi.open_instance`, the in-process path: their pythonfmu slaves are
  called directly, no nested FMU library is loaded) and initialised by the master with the drive's parameter
  values, as ``harness run`` does; a parameter set after that (still in initialization mode) rebuilds it.
* ``fmi2DoStep(t, H)`` advances the master from t to t + H in sub-steps of the drive's step; a remainder ends
  with a shorter sub-step (every member of the shipped drives takes variable steps; an FMU that cannot is
  refused with one line).  So an importer's step that is a multiple of the drive's step gives exactly the
  result of ``harness run`` at those points.
* Free inputs are passed to their member before each step and held over it; a non-finite value, or one outside
  the range the member declares, fails the step with one line naming the drive, the variable and the value.
* The outputs are the master's consistent values at the communication point; they depend on no input
  directly (an input acts from the next step on), which the ModelStructure says.
* ``fmi2GetFMUstate``/``fmi2SetFMUstate``: the master's snapshot (every member's state, the coupling data,
  the extrapolation history) when every member can roll back.

Errors: pythonfmu turns a Python exception in any call into ``fmi2Fatal`` (its C wrapper, cppfmu's
``fmi2DoStep``: a Python exception becomes ``cppfmu::FatalError`` -> ``fmi2Fatal``; ``do_step`` returning False
gives ``fmi2Discard`` with ``fmi2LastSuccessfulTime`` the step's start; ``fmi2Error`` cannot be reached from
Python); the one line goes through the host's logger first (``fmi2Error`` category ``logStatusError``).  A step
the drive refuses before it moves (an importer step below 1 ns, a step that is not a multiple of the drive's step
when a member cannot take a shorter one, a step from another time than the drive's) stays ``fmi2Fatal`` in FMI
2.0: ``fmi2Discard`` was measured to be ignored by FMPy's ``simulate_fmu`` (it asks ``fmi2GetBooleanStatus``,
which pythonfmu does not offer, and steps on: the drive frozen, the run "complete"), a worse answer than a stop.
In FMI 3.0 it is ``fmi3Error`` (pythonfmu3 passes the status of ``do_step``'s result on): the line is logged,
the drive stays where it was and the instance stays usable.
"""
from __future__ import annotations

import copy
import math
import os
import sys
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status

from harness.master.clock import NS
from harness.errors import HarnessError
from harness.master.extrapolation import extrapolation as make_extrapolation
from harness.fmi import open_instance
from harness.master import master_class
from harness.master.observers import Observer
from harness.master.stepcontrol import FixedStep
from harness.model import Bond, Connection, Experiment, Instance, System


_MODULE_DICT_REFS: list = []


def system_of(spec: dict, members: str) -> System:
    """The drive of ``spec`` as a :class:`System` whose instances are the FMUs in folder ``members``."""
    e = spec["experiment"]
    return System(
        name=spec["name"],
        instances=[Instance(i["name"], os.path.join(members, i["fmu"]), dict(i["parameters"]))
                   for i in spec["instances"]],
        connections=[Connection(c["source"], c["target"], c["factor"], c["offset"], c["unit_conversion"])
                     for c in spec["connections"]],
        bonds=[Bond(b["motion_out"], b["motion_in"], b["translational"]) for b in spec["bonds"]],
        experiment=Experiment(stop_time=e["stop_time"], step=e["step"], master=e["master"],
                              extrapolation=e["extrapolation"]),
        free_inputs={i["name"]: i["description"] or "free input" for i in spec["inputs"]})



class _CounterRises(Observer):
    """The instant each event counter the drive offers (``<counter>.rise_time``) last rose, on the drive's own
    steps: at every accepted point the counter compared with its value at the previous one."""

    def __init__(self, slave):
        self.slave = slave

    def on_step(self, master, t_prev_ns, t_ns):
        s = self.slave
        for counter, rise in s._counters.items():
            value = float(master.y[master.signal_index[counter]])
            if value > s._counted.get(counter, value):
                s._rise[rise] = t_ns / NS
            s._counted[counter] = value

class DriveBehaviour:
    """What a drive FMU's slave does, whatever its FMI version (module docstring); a version's class derives from
    this and its exporter's slave class and adds ``_register`` and ``to_xml``.  A subclass sets ``spec``."""

    spec: dict = {}
    _ERROR = Fmi2Status.error
    _STEP_REFUSED = None    # pythonfmu: fatal (module docstring: its fmi2Discard is ignored by FMPy)
    # the master state a snapshot does not hold (the interface-Jacobian master's estimate)
    _EXTRA_STATE = ("jacobian", "theta", "_jac_h", "_jacobian_stale")

    def __init_subclass__(cls, **kwargs):
        """pythonfmu 0.7's C wrapper re-executes the FMU's module on every fmi2Instantiate and then releases its
        borrowed ``__dict__`` once: a reference is taken here, on each execution of the class statement, so the
        second instantiation in a process does not crash (as fmus.slave_core._hold_module_dict does)."""
        super().__init_subclass__(**kwargs)
        module = sys.modules.get(cls.__module__)
        if module is not None:
            _MODULE_DICT_REFS.append(vars(module))

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        spec = type(self).spec
        self.description = spec["description"]
        self._drive = spec["name"]
        self._values: dict[str, float | int] = {}
        self._master = None
        self._fmus: dict = {}
        self._dirty = False        # a parameter set after the master was built (initialization mode)
        self._running = False      # after fmi2ExitInitializationMode
        self._setup = (0.0, None, None)
        self._step_ns = int(round(spec["experiment"]["step"] * NS))
        self._outputs = [o["name"] for o in spec["outputs"]]
        # an event counter's instant of its last rise (drive_fmu.drive_spec): output -> time [s], and the counter
        # output -> (its rise_time output, its value after the last sub-step)
        self._rise = {o["name"]: 0.0 for o in spec["outputs"] if o.get("rise_of")}
        self._counters = {o["rise_of"]: o["name"] for o in spec["outputs"] if o.get("rise_of")}
        self._counted: dict[str, float] = {}
        for p in spec["parameters"]:
            self._values[p["name"]] = p["start"]
        for i in spec["inputs"]:
            self._values[i["name"]] = i["start"]
        self._register()

    # the exporter's variable types, set by a version's class: ``integer``, ``real`` (the variable classes),
    # ``causality``, ``variability``, ``initial`` (its enums) and ``unit`` (True: a Real takes its unit when
    # registered, as pythonfmu3's do; False: to_xml writes it)
    _TYPES: dict = {}

    def _register(self) -> None:
        """Every drive parameter, input and output as a variable of the exporter's types (``_TYPES``), in the
        spec's order (their value references)."""
        T, spec = self._TYPES, type(self).spec
        C, V = T["causality"], T["variability"]

        def unit(v: dict) -> dict:
            return {"unit": v["unit"] or None} if T["unit"] else {}

        for p in spec["parameters"]:
            if p["type"] == "Integer":
                var = T["integer"](p["name"], causality=C.calculatedParameter, variability=V.fixed,
                                   initial=T["initial"].approx, description=p["description"],
                                   getter=self._getter(p["name"]))
            else:
                var = T["real"](p["name"], causality=C.parameter, variability=V.fixed, description=p["description"],
                                getter=self._getter(p["name"]), setter=self._par_setter(p["name"]), **unit(p))
            self.register_variable(var, nested=False)
        for i in spec["inputs"]:
            self.register_variable(T["real"](i["name"], causality=C.input, variability=V.continuous,
                                             description=i["description"], getter=self._getter(i["name"]),
                                             setter=self._in_setter(i), **unit(i)), nested=False)
        for o in spec["outputs"]:
            self.register_variable(T["real"](o["name"], causality=C.output, variability=V.continuous,
                                             description=o["description"], getter=self._out_getter(o["name"]),
                                             **unit(o)), nested=False)

    def _default_experiment(self, root: Element) -> None:
        """The drive's experiment as the model description's DefaultExperiment (start, stop, its own step)."""
        e = type(self).spec["experiment"]
        de = root.find("DefaultExperiment")
        if de is None:
            de = Element("DefaultExperiment")
            root.insert(list(root).index(root.find("ModelVariables")), de)
        de.set("startTime", "0.0")
        de.set("stopTime", repr(float(e["stop_time"])))
        de.set("stepSize", repr(float(e["step"])))


    # -- variables -----------------------------------------------------------------------------------------
    def _getter(self, name):
        return lambda: self._values[name]

    def _par_setter(self, name):
        def set_(value):
            if self._running:
                self._fail(f"parameter {name} = {value!r} set after initialization: it is a fixed parameter "
                           f"(set it before fmi2ExitInitializationMode)")
            self._values[name] = value
            if self._master is not None:
                self._dirty = True
        return set_

    def _in_setter(self, var: dict):
        lo = -math.inf if var.get("min") is None else float(var["min"])
        hi = math.inf if var.get("max") is None else float(var["max"])

        def set_(value):
            v = float(value)
            if not (math.isfinite(v) and lo <= v <= hi):
                self._fail(f"input {var['name']} = {value!r} {var['unit']} is outside its range "
                           f"[{lo:g}, {hi:g}] (finite values only)".replace("  ", " "))
            self._values[var["name"]] = v
        return set_

    def _out_getter(self, name):
        if name in self._rise:
            return lambda: self._rise[name]

        def get():
            m = self._ensure_master()
            return float(m.y[m.signal_index[name]])
        return get

    # -- life cycle ----------------------------------------------------------------------------------------
    def _refuse_step(self, message: str):
        """A step refused before the drive moves: the one line through the host's logger and the variant's
        non-fatal answer (module docstring)."""
        if self._STEP_REFUSED is None:
            self._fail(message)
        self.log(f"drive {self._drive} ({self.instance_name}): {message}", self._ERROR, "logStatusError")
        return self._STEP_REFUSED

    def _fail(self, message: str):
        line = f"drive {self._drive} ({self.instance_name}): {message}"
        self.log(line, self._ERROR, "logStatusError")
        raise RuntimeError(line)

    def _release(self) -> None:
        if self._master is not None:
            self._master.terminate()
            self._master.free()
        else:
            for f in self._fmus.values():
                f.free()
        self._master, self._fmus = None, {}

    def _ensure_master(self):
        """The master with every member initialised at the start time (built on first need, rebuilt after a
        parameter changed in initialization mode)."""
        if self._master is not None and not self._dirty:
            return self._master
        self._release()
        spec = type(self).spec
        members = os.path.join(self.resources, "members")
        system = system_of(spec, members)
        e = spec["experiment"]
        params = {i["name"]: dict(i["parameters"]) for i in spec["instances"]}
        for ref, value in self._values.items():
            inst, var = ref.split(".", 1)
            params[inst][var] = value
        start, stop, tol = self._setup
        try:
            from harness.model import model_description
            mds = {i.name: model_description(i.fmu) for i in system.instances}
            for inst in system.instances:
                self._fmus[inst.name] = open_instance(inst.fmu, inst.name, logging_on=False, in_process=True)
            m = master_class(e["master"])(self._fmus, system.all_connections(mds), system.bonds,
                                          make_extrapolation(e["extrapolation"]))
            m.use_rates(e.get("rates") or {}, self._step_ns)   # each member at its own rate, as the drive's run
            m.initialize(int(round(start * NS)), None if stop is None else int(round(stop * NS)), tol, params)
        except HarnessError as err:
            self._release()
            self._fail(f"initialization failed: {' '.join(str(err).split())}")
        self._master, self._dirty = m, False
        return m

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self._setup = (float(start_time), None if stop_time is None else float(stop_time),
                       None if tolerance is None else float(tolerance))

    def enter_initialization_mode(self):
        pass

    def exit_initialization_mode(self):
        self._ensure_master()
        self._running = True

    def terminate(self):
        self._release()

    def do_step(self, current_time, step_size):
        m = self._ensure_master()
        t_ns, h_ns = int(round(current_time * NS)), int(round(step_size * NS))
        if h_ns < 1:
            return self._refuse_step(f"communication step {step_size!r} s is below the smallest the drive's master "
                                     f"admits (1 ns, its time resolution)")
        if abs(t_ns - m.t_ns) > 1:
            return self._refuse_step(f"doStep at t = {current_time!r} s, but the drive is at t = {m.t_ns / NS!r} s "
                                     f"(it steps forward from where it is; roll back with the FMU state)")
        end = m.t_ns + h_ns
        if h_ns % self._step_ns:
            fixed = [n for n, f in self._fmus.items() if not f.can_vary_step]
            if fixed:
                return self._refuse_step(f"communication step {step_size!r} s is not a multiple of the drive's "
                                         f"step {self._step_ns / NS!r} s and member {fixed[0]} cannot take a "
                                         f"shorter step")
        for ref in type(self)._input_names():
            inst, var = ref.split(".", 1)
            self._fmus[inst].set_value(var, self._values[ref])
        try:
            # the master's one loop, in the drive's own steps; each counter's last rise read at every one
            m.run(FixedStep(self._step_ns), end, observers=(_CounterRises(self),))
        except HarnessError as err:
            self._fail(f"t = {m.t_ns / NS:.9g} s: {' '.join(str(err).split())}")
        return True

    @classmethod
    def _input_names(cls) -> list[str]:
        return [i["name"] for i in cls.spec["inputs"]]

    # -- FMU state -----------------------------------------------------------------------------------------
    def _get_fmu_state(self):
        m = self._ensure_master()
        slot = f"fmu-state-{id(object())}"
        m.snapshot(slot)
        extra = {k: copy.deepcopy(getattr(m, k)) for k in self._EXTRA_STATE if hasattr(m, k)}
        return (m._slots.pop(slot), extra, dict(self._values), self._running, dict(self._rise), dict(self._counted))

    def _set_fmu_state(self, state):
        m = self._ensure_master()
        saved, extra, values, running, rise, counted = state
        m._slots["fmu-state"] = saved
        m.restore("fmu-state")
        del m._slots["fmu-state"]
        for k, v in extra.items():
            setattr(m, k, copy.deepcopy(v))
        self._values = dict(values)
        self._running = running
        self._rise, self._counted = dict(rise), dict(counted)

class DriveSlave(DriveBehaviour, Fmi2Slave):
    """The FMI 2.0 drive slave (pythonfmu); a subclass sets ``spec`` (module docstring)."""

    _TYPES = dict(integer=Integer, real=Real, causality=Fmi2Causality, variability=Fmi2Variability,
                  initial=Fmi2Initial, unit=False)

    # -- model description ---------------------------------------------------------------------------------
    def to_xml(self, model_options=dict()) -> Element:
        spec = type(self).spec
        root = super().to_xml(model_options)
        root.set("description", spec["description"])
        units = {}
        for group in ("parameters", "inputs", "outputs"):
            for v in spec[group]:
                units[v["name"]] = v
        index = {v.name: k + 1 for k, v in enumerate(self.vars.values())}
        for sv in root.find("ModelVariables"):
            v = units[sv.get("name")]
            el = sv.find("Real")
            if el is not None:
                if v.get("unit"):
                    el.set("unit", v["unit"])
                for bound in ("min", "max"):
                    if v.get(bound) is not None:
                        el.set(bound, repr(float(v[bound])))
        pos = list(root).index(root.find("CoSimulation")) + 1
        defs = Element("UnitDefinitions")
        for name, base in sorted(spec["units"].items()):
            u = SubElement(defs, "Unit", name=name)
            SubElement(u, "BaseUnit", {k: str(x) for k, x in base.items()})
        if len(defs):
            root.insert(pos, defs)
        self._default_experiment(root)
        root.remove(root.find("ModelStructure"))
        structure = SubElement(root, "ModelStructure")
        if self._outputs:
            out_el = SubElement(structure, "Outputs")
            init_el = SubElement(structure, "InitialUnknowns")
            knowns = " ".join(str(index[v["name"]]) for g in ("parameters", "inputs") for v in spec[g]
                              if not (g == "parameters" and v["type"] == "Integer"))
            for name in self._outputs:
                # no direct feed-through: an input acts from the next step on (module docstring)
                SubElement(out_el, "Unknown", index=str(index[name]), dependencies="")
            for p in spec["parameters"]:
                if p["type"] == "Integer":    # the structural parameters (calculatedParameter): fixed values
                    SubElement(init_el, "Unknown", index=str(index[p["name"]]), dependencies="")
            for name in self._outputs:
                SubElement(init_el, "Unknown", index=str(index[name]), dependencies=knowns)
        return root
