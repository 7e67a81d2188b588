"""An FMI 2.0 modelDescription.xml read with the standard library, into objects with the attributes of FMPy's
(``fmpy.model_description``) that the harness reads: the reader of the harness a drive FMU carries.

A drive FMU (:mod:`harness.export.drive_fmu`) runs its members with its own copy of the harness in its host's
Python, and needs nothing of that Python but numpy: FMPy's reader needs FMPy and lxml, which a host without
Python (the interpreter a standalone FMU carries) and a Python host of another FMPy version do not give it.
Inside the FMU, :func:`harness.fmi.cache.model_description` reads with :func:`read` (the drive's slave switches
its copy over: :func:`harness.fmi.cache.use_standard_library_reader`); everywhere else it reads with FMPy's.
Measured against FMPy's reader on every component FMU (tests/test_handoff.py): the same variables with the same
names, value references, types, causalities, variabilities, initials, starts, units, bounds and descriptions,
the same capabilities and the same output dependencies.

FMI 2.0 co-simulation and model exchange only (the members a drive FMU packs are FMI 2.0 co-simulation FMUs);
anything else is refused in one line.
"""
from __future__ import annotations

import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from harness.errors import SystemDescriptionError

_TYPES = ("Real", "Integer", "Boolean", "String", "Enumeration")
# FMI 2.0's default ``initial`` of a variability and causality (the standard's table)
_INITIAL = {"constant": {"output": "exact", "local": "exact"},
            "fixed": {"parameter": "exact", "calculatedParameter": "calculated", "local": "calculated"},
            "tunable": {"parameter": "exact", "calculatedParameter": "calculated", "local": "calculated"},
            "discrete": {"input": "exact", "output": "calculated", "local": "calculated"},
            "continuous": {"input": "exact", "output": "calculated", "local": "calculated", "independent": None}}
_CAPABILITIES = ("needsExecutionTool", "canHandleVariableCommunicationStepSize", "canInterpolateInputs",
                 "canRunAsynchronuously", "canBeInstantiatedOnlyOncePerProcess", "canNotUseMemoryManagementFunctions",
                 "canGetAndSetFMUstate", "canSerializeFMUstate", "providesDirectionalDerivative")


class Record:
    """A plain record of the attributes given."""

    def __init__(self, **values):
        self.__dict__.update(values)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({getattr(self, 'name', None) or getattr(self, 'modelName', '')!r})"


class ModelDescription(Record):
    """The model description (FMPy's attribute names)."""


class Interface(Record):
    """The CoSimulation or ModelExchange element: modelIdentifier and the capabilities as booleans."""


class ModelVariable(Record):
    """One ScalarVariable: name, valueReference, type, description, causality, variability, initial, start, unit,
    displayUnit, min, max, nominal, quantity, declaredType, derivative (strings as in the file, as FMPy keeps them)."""


class SimpleType(Record):
    """One TypeDefinitions/SimpleType: name, type, unit, displayUnit, quantity, min, max, nominal."""


class Unknown(Record):
    """One ModelStructure entry: variable, dependencies (variables, None when not declared), dependenciesKind."""


def read(path: str | Path) -> ModelDescription:
    """The model description of an FMU file (or of an unpacked FMU folder) with the standard library."""
    p = Path(path)
    try:
        if p.is_dir():
            text = (p / "modelDescription.xml").read_bytes()
        else:
            with zipfile.ZipFile(p) as z:
                text = z.read("modelDescription.xml")
        root = ET.fromstring(text)
    except (OSError, KeyError, zipfile.BadZipFile, ET.ParseError) as e:
        raise SystemDescriptionError(f"{p}: not a readable FMU ({type(e).__name__}: {e})".splitlines()[0]) from None
    if root.get("fmiVersion") != "2.0":
        raise SystemDescriptionError(f"{p.name}: FMI {root.get('fmiVersion')}: the standard-library reader of a "
                                     f"drive FMU reads FMI 2.0 only")
    md = ModelDescription(fmiVersion="2.0", modelName=root.get("modelName"), guid=root.get("guid"),
                          description=root.get("description"), author=root.get("author"),
                          version=root.get("version"), generationTool=root.get("generationTool"),
                          coSimulation=_interface(root.find("CoSimulation")),
                          modelExchange=_interface(root.find("ModelExchange")), scheduledExecution=None,
                          defaultExperiment=None, modelVariables=[], outputs=[], derivatives=[],
                          initialUnknowns=[], typeDefinitions=[])
    de = root.find("DefaultExperiment")
    if de is not None:
        md.defaultExperiment = Record(**{k: de.get(k) for k in ("startTime", "stopTime", "tolerance", "stepSize")})
    types = {}
    for t in root.findall("TypeDefinitions/SimpleType"):
        child = next((c for c in t if c.tag in _TYPES), None)
        a = child.attrib if child is not None else {}
        types[t.get("name")] = SimpleType(name=t.get("name"), type=child.tag if child is not None else None,
                                          description=t.get("description"), unit=a.get("unit"),
                                          displayUnit=a.get("displayUnit"), quantity=a.get("quantity"),
                                          min=a.get("min"), max=a.get("max"), nominal=a.get("nominal"))
    md.typeDefinitions = list(types.values())
    for sv in root.findall("ModelVariables/ScalarVariable"):
        md.modelVariables.append(_variable(sv, types, p.name))
    for name, attr in (("Outputs", md.outputs), ("Derivatives", md.derivatives),
                       ("InitialUnknowns", md.initialUnknowns)):
        for u in root.findall(f"ModelStructure/{name}/Unknown"):
            deps, kinds = u.get("dependencies"), u.get("dependenciesKind")
            attr.append(Unknown(index=int(u.get("index")), variable=md.modelVariables[int(u.get("index")) - 1],
                                dependencies=None if deps is None else
                                [md.modelVariables[int(i) - 1] for i in deps.split()],
                                dependenciesKind=None if kinds is None else kinds.split()))
    return md


def _interface(el) -> Interface | None:
    if el is None:
        return None
    caps = {k: el.get(k) in ("true", "1") for k in _CAPABILITIES}
    return Interface(modelIdentifier=el.get("modelIdentifier"),
                     maxOutputDerivativeOrder=int(el.get("maxOutputDerivativeOrder", 0)), **caps)


def _variable(sv, types: dict, where: str) -> ModelVariable:
    value = next((c for c in sv if c.tag in _TYPES), None)
    if value is None:
        raise SystemDescriptionError(f"{where}: variable {sv.get('name')} has no type element")
    kind = value.tag
    causality = sv.get("causality", "local")
    variability = sv.get("variability") or "continuous"
    declared = value.get("declaredType")
    if declared is not None and declared not in types:
        raise SystemDescriptionError(f"{where}: variable {sv.get('name')} has declaredType {declared!r}, which is "
                                     f"not defined")
    real = kind == "Real"
    bounded = kind in ("Real", "Integer", "Enumeration")
    return ModelVariable(
        name=sv.get("name"), valueReference=int(sv.get("valueReference")), type=kind,
        description=sv.get("description"), causality=causality, variability=variability,
        initial=sv.get("initial") or _INITIAL.get(variability, {}).get(causality), start=value.get("start"),
        unit=value.get("unit") if real else None, displayUnit=value.get("displayUnit") if real else None,
        nominal=value.get("nominal") if real else None, derivative=value.get("derivative") if real else None,
        quantity=value.get("quantity") if bounded else None, min=value.get("min") if bounded else None,
        max=value.get("max") if bounded else None, declaredType=types.get(declared), shape=())
