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

from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status

from harness.export.drive_behaviour import DriveBehaviour, system_of  # noqa: F401 (system_of: public here too)


class DriveSlave(DriveBehaviour, Fmi2Slave):
    """The FMI 2.0 drive slave (pythonfmu); a subclass sets ``spec`` (module docstring)."""

    _ERROR = Fmi2Status.error
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
