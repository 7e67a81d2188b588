"""The base slave of the FMI 3.0 FMUs (pythonfmu3 ``Fmi3Slave``): the same declarations, the same behaviour.

A declaration ``fmus/components/pd_<name>.py`` (:class:`fmus.declaration.Component`) becomes an FMI 3.0 slave
(``build_fmus.py --fmi-version 3``) as ``class <Name>(<declaration>, PressSlave, Fmi3Slave)`` with this module's
``PressSlave`` (:func:`fmus.build.fmu_module`; :func:`fmu_class` in process), with no second copy of any port,
signal or parameter.  The behaviour (parameter and input checks, lazy outputs, the step, the saved state) is
:class:`fmus.slave_core.PressBehaviour`, shared with FMI 2.0; this class adds what FMI 3.0 names
differently:

* variables: Real parameters, inputs, outputs and states are ``Float64`` with their unit, Integer parameters
  ``Int32`` (FMI 2.0's ``Integer`` is 32 bit); value references are the registration order, as in FMI 2.0,
  and the independent variable ``time`` [s] that FMI 3.0 requires comes last, so every declared variable
  has the value reference of its FMI 2.0 twin;
* the modelDescription: ``UnitDefinitions`` (same element as FMI 2.0), a ``ModelStructure`` of ``Output`` and
  ``InitialUnknown`` elements whose dependencies are value references (FMI 3.0 names variables by value
  reference, not by index), with the same dependencies as the FMI 2.0 FMU; the toolkit's annotation (slave
  module and class, advanced positions) as FMI 3.0's ``Annotations/Annotation type="org.pressdrive"``;
* the ``CoSimulation`` capabilities are set here: pythonfmu3 0.3.4 writes every co-simulation flag with the
  value of its last common option, so ``canHandleVariableCommunicationStepSize`` would otherwise say false.

pythonfmu3 0.3.4 does not pass ``startTime`` of ``fmi3EnterInitializationMode`` to the slave (its
``setup_experiment`` is never called), so outputs before the first step are computed at t = 0 (no output of the
toolkit depends on the time itself there: with default parameters a run from t = 0.5 s equals the FMI 2.0 one,
tests/test_fmi3_export.py) and ``time`` reads 0 until the first step; the time of every step is the
``currentCommunicationPoint`` the host passes to ``fmi3DoStep``.  On Linux the FMU's binary is the host loader
(fmus/loader/pressdrive_loader3.c) in front of pythonfmu3's wrapper, so the FMU also runs in hosts without Python.

The power bonds are FMI 3.0 terminals too (:func:`terminals_and_icons`, packed by the build as
``terminalsAndIcons/terminalsAndIcons.xml``), so a host that reads terminals connects a flange as one connector.
"""
from __future__ import annotations

from xml.etree.ElementTree import Element, SubElement

from pythonfmu3 import Fmi3Causality, Fmi3Slave, Fmi3Status, Fmi3Variability, Float64, Int32

from .refusal import CATEGORY as REFUSAL_CATEGORY
from .refusal import DESCRIPTION as REFUSAL_DESCRIPTION
from .slave_core import (Input, Output, Port, PressBehaviour, Rotational, Translational, Variable,  # noqa: F401
                         slave_class, unit_definitions)

# terminalKind of a power bond: a host connects two terminals of one kind (a motion-out flange to a motion-in one)
TERMINAL_KIND = {False: "org.pressdrive.RotationalFlange", True: "org.pressdrive.TranslationalFlange"}

# what the toolkit's FMI 3.0 co-simulation FMUs can do (the same capabilities as their FMI 2.0 twins)
CO_SIMULATION = {"needsExecutionTool": "false", "canBeInstantiatedOnlyOncePerProcess": "false",
                 "canGetAndSetFMUState": "true", "canSerializeFMUState": "false",
                 "canHandleVariableCommunicationStepSize": "true"}


class PressSlave(PressBehaviour, Fmi3Slave):
    """Base class of the FMI 3.0 co-simulation FMUs (module docstring)."""

    _ERROR = Fmi3Status.error
    _OK = Fmi3Status.ok
    # the exporter's categories and the one of a refused parameter value (fmus.refusal)
    log_categories = {**Fmi3Slave.log_categories, REFUSAL_CATEGORY: REFUSAL_DESCRIPTION}

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        # pythonfmu3's constructor sets these as instance attributes (None): the declaration's class values win
        cls = type(self)
        self.author, self.license, self.version = cls.author, cls.license, cls.version
        self.description = cls.description.strip().splitlines()[0] if cls.description else cls.__name__

    def _register(self) -> None:
        units = self._units_by_name()
        for s in self._param_specs:
            kind, unit = (Int32, {}) if s.is_integer else (Float64, {"unit": units[s.name]})
            variability = Fmi3Variability.tunable if s.name in type(self).tunable else Fmi3Variability.fixed
            self.register_variable(kind(s.name, causality=Fmi3Causality.parameter, variability=variability,
                                        description=s.doc, getter=self._par_getter(s.name),
                                        setter=self._par_setter(s.name), **unit), nested=False)
        n_in = len(type(self).model.inputs)
        for i, v in enumerate(self._io):
            if v.causality == "input":
                var = Float64(v.name, causality=Fmi3Causality.input, variability=Fmi3Variability.continuous,
                              description=v.doc, unit=units[v.name], getter=self._in_getter(i),
                              setter=self._in_setter(i))
            else:
                var = Float64(v.name, causality=Fmi3Causality.output, variability=Fmi3Variability.continuous,
                              description=v.doc, unit=units[v.name], getter=self._out_getter(i - n_in))
            self.register_variable(var, nested=False)
        for i, st in enumerate(type(self).model.states):
            self.register_variable(Float64(st.name, causality=Fmi3Causality.local,
                                           variability=Fmi3Variability.continuous, description=st.doc,
                                           unit=units[st.name], getter=self._state_getter(i)), nested=False)
        # FMI 3.0 requires exactly one independent variable; registered last, so every other value reference
        # is the one the FMI 2.0 FMU of the same declaration gives the variable
        self.register_variable(Float64("time", causality=Fmi3Causality.independent,
                                       variability=Fmi3Variability.continuous, description="simulation time",
                                       unit="s", getter=lambda: self._time), nested=False)

    def get_float64(self, vrs):
        values = self._get_outputs(vrs)
        return super().get_float64(vrs) if values is None else values

    def set_float64(self, vrs, values):
        if not self._set_inputs(vrs, values):
            super().set_float64(vrs, values)

    # -- model description -------------------------------------------------------------------------------
    def to_xml(self, model_options=dict()) -> Element:
        root = super().to_xml(model_options)
        cs = root.find("CoSimulation")
        for name, value in CO_SIMULATION.items():
            cs.set(name, value)
        if type(self).model.provides_output_jacobian():   # FMI 3.0's name is plural; the loader answers it
            cs.set("providesDirectionalDerivatives", "true")
        root.insert(list(root).index(cs) + 1, unit_definitions([*self._units_by_name().values(), "s"]))

        ranges = self._input_ranges()
        for element in root.find("ModelVariables"):
            for key, value in ranges.get(element.get("name"), {}).items():
                element.set(key, value)

        vr = {v.name: v.value_reference for v in self.vars.values()}
        root.remove(root.find("ModelStructure"))
        structure = SubElement(root, "ModelStructure")
        outputs = sorted(self._output_dependencies(), key=lambda o: vr[o[0]])
        for name, deps, _ in outputs:
            SubElement(structure, "Output", valueReference=str(vr[name]),
                       dependencies=" ".join(map(str, sorted(vr[d] for d in deps))))
        for name, _, init_deps in outputs:
            SubElement(structure, "InitialUnknown", valueReference=str(vr[name]),
                       dependencies=" ".join(map(str, sorted(vr[d] for d in init_deps))))

        # the slave module and class and the positions this slave advances itself (harness.fmi.fmu reads the
        # FMI 2.0 form, VendorAnnotations/Tool; this is the same element in FMI 3.0's place for annotations)
        annotations = SubElement(root, "Annotations")
        tool = SubElement(annotations, "Annotation", type="org.pressdrive")
        SubElement(tool, "Slave", {"module": type(self).__module__, "class": type(self).__name__,
                                   "advancedPositions": " ".join(self._advanced_positions())})
        return root


def fmu_class(declaration: type) -> type:
    """The FMI 3.0 co-simulation slave class of a declaration (:func:`fmus.slave_core.slave_class`)."""
    return slave_class(declaration, PressSlave)


def terminals_and_icons(ports: tuple[Port, ...]) -> Element | None:
    """``fmiTerminalsAndIcons`` with one terminal per power bond (None for an FMU without bonds: the schema
    wants at least one terminal).  A rotational flange is ``phi``, ``w``, ``tau``; a translational one ``s``,
    ``v``, ``f``; ``matchingRule="plug"`` (every member is connected to the member of the same name).  Motion
    members are signals.  The effort is FMI 3.0's flow variable: on a motion-out port it is the torque/force
    the connected part exerts on this flange (``inflow``, positive into the FMU: ``tau*w`` is the power flowing
    in), on a motion-in port the reaction this component exerts on the driving flange (``outflow``)."""
    if not ports:
        return None
    root = Element("fmiTerminalsAndIcons", fmiVersion="3.0")
    terminals = SubElement(root, "Terminals")
    for port in ports:
        terminal = SubElement(terminals, "Terminal", name=port.name, matchingRule="plug",
                              terminalKind=TERMINAL_KIND[port.translational],
                              description=f"{port.doc} (motion {port.motion})")
        motion, speed, effort = port.variables()
        for v, kind in ((motion, "signal"), (speed, "signal"),
                        (effort, "outflow" if port.motion == "in" else "inflow")):
            SubElement(terminal, "TerminalMemberVariable", variableName=v.name,
                       memberName=v.name.removeprefix(f"{port.name}."), variableKind=kind)
    return root
