"""The one base slave every press-drive FMU is built on (pythonfmu ``Fmi2Slave``; FMI 3.0: ``fmus.slave3``).

A declaration (:class:`fmus.declaration.Component`, ``fmus/components/pd_<name>.py``) only says what the FMU is::

    class FourBar(Component):
        model = fourbar.FourBarModel                       # equations (fmus.physics)
        description = "..."
        ports = (Rotational("crank", motion="in", doc=...),
                 Rotational("rocker", motion="out", doc=...))
        signals = (Output("transmission_angle", "rad", "..."),)
        feedthrough = {"crank.tau": ("crank.phi", "crank.w", "rocker.tau")}

and the FMU's class, ``class FourBar(<declaration>, PressSlave)`` (written by the build, :func:`fmu_class` in
process), gets the rest from this class (the behaviour itself is version-neutral,
:class:`fmus.slave_core.PressBehaviour`; the same declaration builds an FMI 3.0 FMU on ``fmus.slave3.PressSlave``,
``build_fmus.py --fmi-version 3``):

* registers the parameters of ``model.Params`` (Real with unit, Integer for integer fields), the port and
  signal inputs/outputs, and the model states as ``local`` variables;
* writes a standard modelDescription: ``UnitDefinitions``, a unit on every Real, and a ``ModelStructure``
  whose ``Outputs`` carry their true direct dependencies (``feedthrough``; everything else depends on no
  input, so importers see no false algebraic loop) and whose ``InitialUnknowns`` list every output;
* integrates the model inside ``do_step`` over exactly ``communicationStepSize`` (``Model.advance``);
* computes outputs lazily, so outputs that depend directly on inputs follow ``fmi2SetReal`` at once;
* saves and restores the complete internal state (``fmi2GetFMUstate``/``fmi2SetFMUstate``) bit for bit;
* gives directional derivatives, d outputs / d inputs at the current time from the model's ``output_jacobian``
  (``providesDirectionalDerivative``): pythonfmu's wrapper does not forward ``fmi2GetDirectionalDerivative``, so
  the host loader answers it from ``directional_derivative`` (fmus/loader/pressdrive_loader.c);
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

from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status

from .refusal import CATEGORY as REFUSAL_CATEGORY
from .refusal import DESCRIPTION as REFUSAL_DESCRIPTION
from .slave_core import (Input, Output, Port, PressBehaviour, Rotational, Translational, Variable,  # noqa: F401
                         slave_class, unit_definitions)


class PressSlave(PressBehaviour, Fmi2Slave):
    """Base class of the FMI 2.0 FMUs: see the module docstring.  Subclasses set the class attributes of
    :class:`~fmus.slave_core.PressBehaviour`."""

    _ERROR = Fmi2Status.error
    _OK = Fmi2Status.ok
    # the exporter's categories and the one of a refused parameter value (fmus.refusal)
    log_categories = {**Fmi2Slave.log_categories, REFUSAL_CATEGORY: REFUSAL_DESCRIPTION}

    def _register(self) -> None:
        for s in self._param_specs:
            kind = Integer if s.is_integer else Real
            variability = Fmi2Variability.tunable if s.name in type(self).tunable else Fmi2Variability.fixed
            self.register_variable(kind(s.name, causality=Fmi2Causality.parameter, variability=variability,
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

    def get_real(self, vrs):
        values = self._get_outputs(vrs)
        return super().get_real(vrs) if values is None else values

    def set_real(self, vrs, values):
        if not self._set_inputs(vrs, values):
            super().set_real(vrs, values)

    # -- model description -------------------------------------------------------------------------------
    def to_xml(self, model_options=dict()) -> Element:
        root = super().to_xml(model_options)
        root.set("description", type(self).description.strip().splitlines()[0] if type(self).description else
                 type(self).__name__)
        index = {v.name: i + 1 for i, v in enumerate(self.vars.values())}
        units_by_name = self._units_by_name()
        ranges = self._input_ranges()
        for sv in root.find("ModelVariables"):
            real = sv.find("Real")
            if real is not None:
                real.set("unit", units_by_name[sv.get("name")])
                for key, value in ranges.get(sv.get("name"), {}).items():
                    real.set(key, value)
        if type(self).model.provides_output_jacobian():
            # answered by the host loader from directional_derivative (fmus.slave_core), and in process
            root.find("CoSimulation").set("providesDirectionalDerivative", "true")
        pos = list(root).index(root.find("CoSimulation")) + 1
        root.insert(pos, unit_definitions(units_by_name.values()))

        # one element (the FMI 2.0 schema allows one child per Tool): the slave module and class, which the
        # toolkit's master may call directly in its own process (harness.fmi.inprocess), and the advanced positions
        vendor = Element("VendorAnnotations")
        tool = SubElement(vendor, "Tool", name="org.pressdrive")
        SubElement(tool, "Slave", {"module": type(self).__module__, "class": type(self).__name__,
                                   "advancedPositions": " ".join(self._advanced_positions())})
        root.insert(list(root).index(root.find("ModelVariables")), vendor)
        root.remove(root.find("ModelStructure"))
        structure = SubElement(root, "ModelStructure")
        outputs = sorted(self._output_dependencies(), key=lambda o: index[o[0]])
        if outputs:
            out_el = SubElement(structure, "Outputs")
            init_el = SubElement(structure, "InitialUnknowns")
            for name, deps, init_deps in outputs:
                SubElement(out_el, "Unknown", index=str(index[name]),
                           dependencies=" ".join(map(str, sorted(index[d] for d in deps))))
                SubElement(init_el, "Unknown", index=str(index[name]),
                           dependencies=" ".join(map(str, sorted(index[d] for d in init_deps))))
        return root


def fmu_class(declaration: type) -> type:
    """The FMI 2.0 co-simulation slave class of a declaration (:func:`fmus.slave_core.slave_class`)."""
    return slave_class(declaration, PressSlave)
