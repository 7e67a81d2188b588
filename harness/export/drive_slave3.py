"""The FMI 3.0 slave of a whole-drive FMU (pythonfmu3; ``export DRIVE X.fmu --fmi-version 3``).

The behaviour is :class:`harness.export.drive_slave.DriveBehaviour`'s (the members stay FMI 2.0 FMUs, run in-process by
the same master); this class registers the variables as FMI 3.0 types (Real ``Float64``, Integer ``Int32``,
the independent variable ``time`` last) and writes FMI 3.0's ModelStructure (``Output``/``InitialUnknown`` by
value reference).
"""
from __future__ import annotations

from xml.etree.ElementTree import Element, SubElement

from pythonfmu3 import (Fmi3Causality, Fmi3Initial, Fmi3Slave, Fmi3Status, Fmi3StepResult, Fmi3Variability,
                        Float64, Int32)

from harness.export.drive_behaviour import DriveBehaviour

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

    _TYPES = dict(integer=Int32, real=Float64, causality=Fmi3Causality, variability=Fmi3Variability,
                  initial=Fmi3Initial, unit=True)

    def _register(self) -> None:
        super()._register()
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
        self._default_experiment(root)
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
