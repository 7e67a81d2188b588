"""The FMI 3.0 slave of a whole-drive FMU (pythonfmu3; ``export DRIVE X.fmu --fmi-version 3``).

The behaviour is :class:`harness.drive_slave.DriveBehaviour`'s (the members stay FMI 2.0 FMUs, run in-process by
the same master); this class registers the variables as FMI 3.0 types (Real ``Float64``, Integer ``Int32``,
the independent variable ``time`` last) and writes FMI 3.0's ModelStructure (``Output``/``InitialUnknown`` by
value reference).
"""
from __future__ import annotations

from xml.etree.ElementTree import Element, SubElement

from pythonfmu3 import (Fmi3Causality, Fmi3Initial, Fmi3Slave, Fmi3Status, Fmi3StepResult, Fmi3Variability,
                        Float64, Int32)

from harness.drive_slave import DriveBehaviour

CO_SIMULATION = {"needsExecutionTool": "false", "canBeInstantiatedOnlyOncePerProcess": "false",
                 "canSerializeFMUState": "false", "canHandleVariableCommunicationStepSize": "true"}


class DriveSlave3(DriveBehaviour, Fmi3Slave):
    """The FMI 3.0 drive slave; a subclass sets ``spec``."""

    _ERROR = Fmi3Status.error
    _STEP_REFUSED = Fmi3StepResult(status=Fmi3Status.error)   # pythonfmu3 returns do_step's status: fmi3Error

    def __init__(self, **kwargs):
        self._t = 0.0
        super().__init__(**kwargs)
        self.description = type(self).spec["description"]

    def _register(self) -> None:
        spec = type(self).spec
        for p in spec["parameters"]:
            if p["type"] == "Integer":
                self.register_variable(Int32(p["name"], causality=Fmi3Causality.calculatedParameter,
                                             variability=Fmi3Variability.fixed, initial=Fmi3Initial.approx,
                                             description=p["description"], getter=self._getter(p["name"])),
                                       nested=False)
            else:
                self.register_variable(Float64(p["name"], causality=Fmi3Causality.parameter,
                                               variability=Fmi3Variability.fixed, description=p["description"],
                                               unit=p["unit"] or None, getter=self._getter(p["name"]),
                                               setter=self._par_setter(p["name"])), nested=False)
        for i in spec["inputs"]:
            self.register_variable(Float64(i["name"], causality=Fmi3Causality.input,
                                           variability=Fmi3Variability.continuous, description=i["description"],
                                           unit=i["unit"] or None, getter=self._getter(i["name"]),
                                           setter=self._in_setter(i)), nested=False)
        for o in spec["outputs"]:
            self.register_variable(Float64(o["name"], causality=Fmi3Causality.output,
                                           variability=Fmi3Variability.continuous, description=o["description"],
                                           unit=o["unit"] or None, getter=self._out_getter(o["name"])),
                                   nested=False)
        self.register_variable(Float64("time", causality=Fmi3Causality.independent,
                                       variability=Fmi3Variability.continuous, description="simulation time",
                                       unit="s", getter=self._time_now), nested=False)

    def _time_now(self) -> float:
        m = self._master
        return m.t_ns / 1e9 if m is not None else self._setup[0]

    def to_xml(self, model_options=dict()) -> Element:
        spec = type(self).spec
        root = super().to_xml(model_options)
        root.set("description", spec["description"])
        cs = root.find("CoSimulation")
        for name, value in CO_SIMULATION.items():
            cs.set(name, value)
        cs.set("canGetAndSetFMUState", "true" if spec["rollback"] else "false")
        old = root.find("UnitDefinitions")
        if old is not None:
            root.remove(old)
        defs = Element("UnitDefinitions")
        for name, base in sorted({**spec["units"], "s": {"s": 1}}.items()):
            u = SubElement(defs, "Unit", name=name)
            SubElement(u, "BaseUnit", {k: str(x) for k, x in base.items()})
        root.insert(list(root).index(cs) + 1, defs)
        e = spec["experiment"]
        de = root.find("DefaultExperiment")
        if de is None:
            de = Element("DefaultExperiment")
            root.insert(list(root).index(root.find("ModelVariables")), de)
        de.set("startTime", "0.0")
        de.set("stopTime", repr(float(e["stop_time"])))
        de.set("stepSize", repr(float(e["step"])))
        vr = {v.name: v.value_reference for v in self.vars.values()}
        root.remove(root.find("ModelStructure"))
        structure = SubElement(root, "ModelStructure")
        knowns = " ".join(str(vr[v["name"]]) for g in ("parameters", "inputs") for v in spec[g]
                          if not (g == "parameters" and v["type"] == "Integer"))
        for o in spec["outputs"]:
            SubElement(structure, "Output", valueReference=str(vr[o["name"]]), dependencies="")
        for p in spec["parameters"]:
            if p["type"] == "Integer":
                SubElement(structure, "InitialUnknown", valueReference=str(vr[p["name"]]), dependencies="")
        for o in spec["outputs"]:
            SubElement(structure, "InitialUnknown", valueReference=str(vr[o["name"]]), dependencies=knowns)
        return root
