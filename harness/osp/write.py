"""Writing a system as OSP's own configuration (``python -m harness export DRIVE DIR --format osp``).

The folder gets ``OspSystemStructure.xml``, each FMU (``<Model>.fmu``) and one ``<Model>_OspModelDescription.xml``
per model, which libcosim finds beside the FMU.  In them:

* every instance is a ``Simulator`` with its parameters as ``InitialValues`` (and the start values of the inputs
  the system leaves free on purpose, ``System.free_inputs``) and, when it declares its own step (``Instance.step``;
  not the rates of the system's experiment, chosen for the harness's own master and not for libcosim's sampling:
  the trimmer's knife load at 25 steps misses its peak torque under libcosim, 1.32 % for 1 %)
  (:mod:`harness.master.multirate`), its ``stepSize``;
* every toolkit port of an FMU (``<port>.phi/.w/.tau`` or ``.s/.v/.f``) is an ``AngularMechanicalPort`` (a
  ``Torque`` and an ``AngularVelocity`` group) or ``LinearMechanicalPort`` (``Force``, ``LinearVelocity``) with
  its position as an ``AngularDisplacement`` (``LinearDisplacement``) group, the variables in the FMU's units,
  defined in the description's ``UnitDefinitions``;
* each power bond connects the two ports' groups: with ``fixedStep`` one ``VariableGroupConnection`` of the
  two mechanical port groups (effort one way, speed the other, matched in order) and one of their position
  groups; with ``ecco`` its position as a plain ``VariableConnection`` and its speed and effort as the two
  ``VariableConnection`` elements of one ``powerBond``, each variable with its causality, as libcosim's ECCO
  algorithm takes a bond (it reads no causality from group connections).  libcosim 0.11 loads a file with at
  most ONE ``powerBond`` (its uniqueness check runs inside the loop that adds the bonds: "The number of
  powerbonds (1) is not equal to the number of unique power bond names (3)"), so an ECCO export of a drive with
  more bonds is a correct file libcosim 0.11 refuses;
* a connection with a factor or an offset (a unit conversion of the system) goes through one of OSP's
  ``LinearTransformation`` functions; an Integer or Boolean value table has no OSP form and is refused;
* ``BaseStepSize`` is the step a host that samples outputs after each step takes (libcosim, Ecos:
  :func:`harness.ssp.host_step`, the drive's ``sampled_host_step`` where it declares one, else its experiment's
  step; each instance's own step must be a whole multiple of it), ``StartTime``/``EndTime`` its experiment's, ``Algorithm`` ``fixedStep``
  (or ``ecco`` with an ``EccoConfiguration`` of the harness's ECCO defaults and the experiment's options).

Elements are written in the order libcosim's schema (``OspSystemStructure.xsd`` 0.1) requires.
"""
from __future__ import annotations

import shutil
from pathlib import Path
from xml.etree import ElementTree as ET

from harness.errors import SystemDescriptionError
from harness.master.clock import NS
from harness.master.multirate import rates_of
from harness.model import System, host_step, model_description, resolve_fmu
from harness.osp.read import MODEL_DESCRIPTION, STRUCTURE

NS_STRUCTURE = "http://opensimulationplatform.com/MSMI/OSPSystemStructure"
NS_MODEL = "https://open-simulation-platform.com/OspModelDescription/1.0.1"
BASE_UNITS = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
PORTS = {False: ("phi", "w", "tau", "AngularMechanicalPort", "Torque", "AngularVelocity", "AngularDisplacement"),
         True: ("s", "v", "f", "LinearMechanicalPort", "Force", "LinearVelocity", "LinearDisplacement")}
# the harness's ECCO defaults (harness.master.stepcontrol.Ecco and StepOptions), by OSP's EccoConfiguration names
ECCO_DEFAULTS = {"SafetyFactor": 0.99, "MinimumChangeRate": 0.2, "MaximumChangeRate": 1.5, "ProportionalGain": 0.2,
                 "IntegralGain": 0.15, "RelativeTolerance": 1e-4, "AbsoluteTolerance": 1e-4}


def _number(x: float) -> str:
    return repr(float(x))


def ports_of(md) -> list[tuple[str, bool]]:
    """(port, translational) of every toolkit port of an FMU: a name with ``.phi``, ``.w`` and ``.tau`` (or
    ``.s``, ``.v``, ``.f``) variables."""
    names = {v.name for v in md.modelVariables}
    out = []
    for v in md.modelVariables:
        for tr, (p, w, e, *_) in PORTS.items():
            if v.name.endswith("." + w):
                port = v.name[: -len(w) - 1]
                if {f"{port}.{p}", f"{port}.{e}"} <= names:
                    out.append((port, tr))
    return out


def model_description_xml(md) -> ET.Element:
    """The OspModelDescription of an FMU: its ports as OSP's mechanical port groups, in its own units."""
    root = ET.Element("OspModelDescription", {"xmlns": NS_MODEL, "version": "1.0"})
    variables = {v.name: v for v in md.modelVariables}
    used = set()
    groups = ET.Element("VariableGroups")
    for port, tr in ports_of(md):
        p, w, e, kind, effort, flow, position = PORTS[tr]
        g = ET.SubElement(groups, kind, {"name": port})
        for tag, var, label in ((effort, e, "effort"), (flow, w, "flow")):
            sub = ET.SubElement(g, tag, {"name": f"{port}.{label}"})
            _variable(sub, variables[f"{port}.{var}"], used)
        pos = ET.SubElement(groups, position, {"name": f"{port}.position"})
        _variable(pos, variables[f"{port}.{p}"], used)
    definitions = {u.name: u for u in (getattr(md, "unitDefinitions", None) or [])}
    units = ET.SubElement(root, "UnitDefinitions")
    for name in sorted(used):
        unit = ET.SubElement(units, "Unit", {"name": name})
        d = definitions.get(name)
        b = d.baseUnit if d is not None else None
        attrs = {} if b is None else {k: str(int(getattr(b, k) or 0)) for k in BASE_UNITS if getattr(b, k)}
        if b is not None and (b.factor != 1 or b.offset != 0):
            attrs.update(factor=_number(b.factor), offset=_number(b.offset))
        ET.SubElement(unit, "BaseUnit", attrs)
    root.append(groups)
    return root


def _variable(parent: ET.Element, v, used: set) -> None:
    attrs = {"ref": v.name}
    unit = v.unit or getattr(getattr(v, "declaredType", None), "unit", None)
    if unit:
        attrs["unit"] = unit
        used.add(unit)
    ET.SubElement(parent, "Variable", attrs)


def structure_xml(system: System, sources: dict[str, str], mds: dict, stop_time: float | None = None,
                  algorithm: str = "fixedStep") -> ET.Element:
    """The OspSystemStructure of ``system`` (``sources``: instance -> FMU file name in the folder; ``mds``:
    instance -> model description)."""
    exp = system.experiment
    root = ET.Element("OspSystemStructure", {"xmlns": NS_STRUCTURE, "version": "0.1"})
    if exp is not None and exp.start_time:
        ET.SubElement(root, "StartTime").text = _number(exp.start_time)
    stop = stop_time if stop_time is not None else (exp.stop_time if exp is not None else None)
    if stop is not None:
        ET.SubElement(root, "EndTime").text = _number(stop)
    if exp is None or exp.step is None:
        raise SystemDescriptionError(f"system {system.name}: no step to write as BaseStepSize (give the system a "
                                     f"default experiment with a step)")
    base = host_step(system)
    rates_of(system.instances, int(round(base * NS)), f"export --format osp: system {system.name}")
    ET.SubElement(root, "BaseStepSize").text = _number(base)
    if algorithm not in ("fixedStep", "ecco"):
        raise SystemDescriptionError(f"algorithm = {algorithm!r}: OSP's are fixedStep and ecco")
    ET.SubElement(root, "Algorithm").text = algorithm
    sims = ET.SubElement(root, "Simulators")
    for inst in system.instances:
        attrs = {"name": inst.name, "source": sources[inst.name]}
        if inst.step is not None:
            attrs["stepSize"] = _number(inst.step)
        sim = ET.SubElement(sims, "Simulator", attrs)
        variables = {v.name: v for v in mds[inst.name].modelVariables}
        values = dict(inst.parameters)
        for ref in system.free_inputs:   # an input left free on purpose keeps its start value: said so explicitly
            owner, _, name = ref.partition(".")
            if owner == inst.name and name not in values and variables[name].start is not None:
                values[name] = _start(variables[name])
        if values:
            ivs = ET.SubElement(sim, "InitialValues")
            for name, value in values.items():
                ET.SubElement(ET.SubElement(ivs, "InitialValue", {"variable": name}),
                              *_typed(variables[name].type, value))
    functions = ET.Element("Functions")
    conns = ET.Element("Connections")
    bonded, grouped = {}, set()
    for b in system.bonds:
        tr = system.bond_is_translational(b, mds)
        p, w, e = PORTS[tr][:3]
        if algorithm == "ecco":
            bonded[f"{b.motion_in}.{w}"] = bonded[f"{b.motion_out}.{e}"] = b.label
            continue
        for suffix in ("", ".position"):
            gc = ET.SubElement(conns, "VariableGroupConnection")
            for port in (b.motion_out, b.motion_in):
                inst, name = port.split(".", 1)
                ET.SubElement(gc, "VariableGroup", {"simulator": inst, "name": name + suffix})
        grouped.update(c.target for c in b.connections(tr))
    for k, c in enumerate(system.all_connections(mds)):
        if c.target in grouped:
            continue
        if c.mapping is not None:
            raise SystemDescriptionError(f"system {system.name}: connection {c.source} -> {c.target} has a value table "
                                         f"{c.mapping!r}, which OSP cannot express (its connections pass values "
                                         f"unchanged)")
        if c.factor != 1 or c.offset != 0:
            name = f"transform{k}"
            ET.SubElement(functions, "LinearTransformation",
                          {"name": name, "factor": _number(c.factor), "offset": _number(c.offset)})
            for signal, end in (("in", c.source), ("out", c.target)):
                sc = ET.SubElement(conns, "SignalConnection")
                ET.SubElement(sc, "Signal", {"function": name, "name": signal})
                ET.SubElement(sc, "Variable", dict(zip(("simulator", "name"), end.split(".", 1))))
            continue
        bond = bonded.get(c.target)
        vc = ET.SubElement(conns, "VariableConnection", {"powerBond": bond} if bond else {})
        for end, causality in ((c.source, "output"), (c.target, "input")):
            attrs = dict(zip(("simulator", "name"), end.split(".", 1)))
            if bond:
                attrs["causality"] = causality
            ET.SubElement(vc, "Variable", attrs)
    if len(functions):
        root.append(functions)
    root.append(conns)
    if algorithm == "ecco":
        root.append(_ecco(exp))
    return root


def _start(v):
    """A variable's start value as the model description gives it, in its type."""
    text = str(v.start)
    if v.type == "Real":
        return float(text)
    if v.type == "Boolean":
        return text.lower() in ("true", "1")
    return text if v.type == "String" else int(text)


def _typed(kind: str, value) -> tuple:
    if kind == "Real":
        return "Real", {"value": _number(value)}
    if kind in ("Integer", "Enumeration"):
        return "Integer", {"value": str(int(value))}
    if kind == "Boolean":
        return "Boolean", {"value": "true" if value else "false"}
    return "String", {"value": str(value)}


def _ecco(exp) -> ET.Element:
    options = dict(getattr(exp, "step_options", None) or {})
    step = exp.step
    values = dict(ECCO_DEFAULTS)
    values.update({"StepSize": step, "MinimumStepSize": step / 1000, "MaximumStepSize": step * 100})
    names = {"safety": "SafetyFactor", "min_step": "MinimumStepSize", "max_step": "MaximumStepSize",
             "min_factor": "MinimumChangeRate", "max_factor": "MaximumChangeRate", "kP": "ProportionalGain",
             "kI": "IntegralGain", "rtol": "RelativeTolerance", "atol": "AbsoluteTolerance"}
    values.update({names[k]: v for k, v in options.items() if k in names and v is not None})
    if exp.tolerance is not None and "rtol" not in options:
        values["RelativeTolerance"] = values["AbsoluteTolerance"] = exp.tolerance
    el = ET.Element("EccoConfiguration")
    for tag in ("SafetyFactor", "StepSize", "MinimumStepSize", "MaximumStepSize", "MinimumChangeRate",
                "MaximumChangeRate", "ProportionalGain", "IntegralGain", "RelativeTolerance", "AbsoluteTolerance"):
        ET.SubElement(el, tag).text = _number(values[tag])
    return el


def export_osp(system: System, folder, stop_time: float | None = None, algorithm: str = "fixedStep") -> Path:
    """Write ``system`` into ``folder`` as OSP's configuration (module docstring); returns the path of its
    OspSystemStructure.xml."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise SystemDescriptionError(f"export --format osp: {folder} is a file, give a folder")
    folder.mkdir(parents=True, exist_ok=True)
    paths = {inst.name: resolve_fmu(inst.fmu) for inst in system.instances}
    mds = {name: model_description(p) for name, p in paths.items()}
    system.validate(mds)
    sources, by_file, models = {}, {}, {}
    for name, path in paths.items():
        key = path.resolve()
        if key not in by_file:
            model = mds[name].modelName
            stem = model if model not in models.values() else f"{model}_{len(by_file)}"
            by_file[key] = f"{stem}.fmu"
            shutil.copyfile(path, folder / by_file[key])
            if model not in models.values():
                tree = ET.ElementTree(model_description_xml(mds[name]))
                ET.indent(tree)
                tree.write(folder / f"{model}{MODEL_DESCRIPTION}", encoding="utf-8", xml_declaration=True)
            models[key] = model
        sources[name] = by_file[key]
    tree = ET.ElementTree(structure_xml(system, sources, mds, stop_time, algorithm))
    ET.indent(tree)
    out = folder / STRUCTURE
    tree.write(out, encoding="utf-8", xml_declaration=True)
    return out


__all__ = ["export_osp", "structure_xml", "model_description_xml", "ports_of"]
