"""Reading OSP's own configuration: ``OspSystemStructure.xml`` beside ``<Model>_OspModelDescription.xml`` files.

What is read, and what it becomes (a :class:`~harness.model.System`):

* ``Simulators``: one :class:`~harness.model.Instance` each (``source`` a path or ``file:`` URI relative to the
  file; other schemes, such as ``proxyfmu://``, are refused), its ``InitialValues`` as parameters (Real, Integer,
  Boolean, String), its ``stepSize`` as the instance's own step (:mod:`harness.master.multirate`).
* ``VariableConnection``: one connection, from the side whose FMU variable is an output (or calculated
  parameter) to the other.
* ``VariableGroupConnection``: the two variable groups of the simulators' OspModelDescriptions (found by name,
  also nested, as libcosim finds them), their nested groups matched in the order they are declared, then their
  variables in order; groups of different sizes are refused in one line.
* ``Functions``: a ``LinearTransformation`` between its ``in`` and ``out`` signal connections becomes one
  connection with its factor and offset; ``Sum`` and ``VectorSum`` are refused by name.
* Units: each side's unit is the one the OspModelDescription gives the variable (``unit`` of ``Variable``,
  defined in its ``UnitDefinitions``), else the FMU's.  Where the two differ the connection converts
  (value_SI = factor * value + offset on each side); units of different dimensions, or a unit without a
  definition, are refused in one line naming the connection and both units.
* A toolkit power bond (ports ``<port>.phi/.w/.tau`` or ``.s/.v/.f``) becomes a :class:`~harness.model.Bond` (the
  position connection goes with it), so the divergence watch and ECCO step control see it, where the file
  joins its speed and effort by a ``VariableGroupConnection`` of two mechanical port groups
  (``AngularMechanicalPort``, ``LinearMechanicalPort``) or by the two connections of one ``powerBond``; other
  port groups stay plain connections, other ``powerBond`` connections too, said once in a warning.
* ``BaseStepSize`` (libcosim's default 0.1 s when absent), ``StartTime``, ``EndTime``; ``Algorithm`` ``fixedStep``
  (the schema's default) runs with ``jacobi-sampled``, the harness master that samples as libcosim does; ``ecco``
  with the harness's ECCO step control (:mod:`harness.master.stepcontrol`), its ``EccoConfiguration`` the
  controller's options (first, least and largest step, change rates, gains, tolerances).  The harness's ECCO
  estimates the bond error from its own power bookkeeping, so it does not take libcosim's steps bit for bit.

Every refusal is a :class:`~harness.errors.SystemDescriptionError` in one line naming the file and the element.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote, urlparse
from xml.etree import ElementTree as ET

from harness.errors import SystemDescriptionError
from harness.model import Bond, Connection, Experiment, Instance, System, SystemWarning, model_description
from harness.ssp.values import Unit

STRUCTURE = "OspSystemStructure.xml"
MODEL_DESCRIPTION = "_OspModelDescription.xml"
LIBCOSIM_BASE_STEP = 0.1   # libcosim's BaseStepSize when the file gives none (osp_config_parser.cpp)
# EccoConfiguration element -> StepOptions field (harness.master.stepcontrol) and the first step
ECCO = {"SafetyFactor": "safety", "MinimumStepSize": "min_step", "MaximumStepSize": "max_step",
        "MinimumChangeRate": "min_factor", "MaximumChangeRate": "max_factor", "ProportionalGain": "kP",
        "IntegralGain": "kI", "RelativeTolerance": "rtol", "AbsoluteTolerance": "atol"}


def _tag(el: ET.Element) -> str:
    """An element's name without its namespace (OSP's files come in several namespaces and versions)."""
    return el.tag.rsplit("}", 1)[-1]


def _children(el: ET.Element | None, name: str | None = None) -> list[ET.Element]:
    return [c for c in (el if el is not None else []) if name is None or _tag(c) == name]


def _child(el: ET.Element | None, name: str) -> ET.Element | None:
    found = _children(el, name)
    return found[0] if found else None


def is_osp_structure(path) -> bool:
    """Whether ``path`` is an OspSystemStructure.xml (by name, or an .xml file whose root element is one) or a
    folder holding one."""
    p = Path(str(path))
    if p.is_dir():
        return (p / STRUCTURE).is_file()
    if p.name == STRUCTURE:
        return True
    if p.suffix.lower() != ".xml" or not p.is_file():
        return False
    try:
        for _, el in ET.iterparse(p, events=("start",)):
            return _tag(el) == "OspSystemStructure"
    except ET.ParseError:
        return False
    return False


@dataclass
class Group:
    """A variable group of an OspModelDescription: its kind (``LinearMechanicalPort``, ``Force``, ...), its own
    variables (name, unit) in order and its nested groups in order."""
    name: str
    kind: str
    variables: list[tuple[str, str | None]] = field(default_factory=list)
    groups: list["Group"] = field(default_factory=list)


@dataclass
class ModelDescription:
    """An OspModelDescription: its unit definitions and variable groups (top level by name)."""
    path: Path
    units: dict[str, Unit]
    groups: dict[str, Group]

    def find(self, name: str) -> Group | None:
        """The group called ``name``: a top-level one, else the first nested one (libcosim's search)."""
        if name in self.groups:
            return self.groups[name]
        todo = list(self.groups.values())
        while todo:
            g = todo.pop(0)
            for sub in g.groups:
                if sub.name == name:
                    return sub
            todo.extend(g.groups)
        return None

    def unit_of(self, variable: str) -> str | None:
        todo = list(self.groups.values())
        while todo:
            g = todo.pop(0)
            for v, unit in g.variables:
                if v == variable and unit:
                    return unit
            todo.extend(g.groups)
        return None


def read_model_description(path: Path) -> ModelDescription:
    """An ``<Model>_OspModelDescription.xml``: unit definitions and variable groups (any OSP-IS group kind)."""
    root = _parse(path, "OspModelDescription")
    units = {u.get("name"): Unit.from_xml(_child(u, "BaseUnit"))
             for u in _children(_child(root, "UnitDefinitions"), "Unit")}

    def group(el: ET.Element) -> Group:
        g = Group(el.get("name") or "", _tag(el))
        for c in el:
            if _tag(c) == "Variable":
                g.variables.append((c.get("ref") or "", c.get("unit")))
            elif isinstance(c.tag, str):
                g.groups.append(group(c))
        return g

    groups = {}
    for el in _children(_child(root, "VariableGroups")):
        if isinstance(el.tag, str):
            g = group(el)
            groups[g.name] = g
    return ModelDescription(path, units, groups)


def _parse(path: Path, root_name: str) -> ET.Element:
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, LookupError, ValueError) as e:
        raise SystemDescriptionError(f"{path}: not well-formed XML ({e})") from None
    except OSError as e:
        raise SystemDescriptionError(f"{path}: cannot be read ({e.strerror or e})") from None
    if _tag(root) != root_name:
        raise SystemDescriptionError(f"{path}: the root element is {_tag(root)}, not {root_name}")
    return root


def load_osp(path) -> System:
    """A :class:`~harness.model.System` from an OspSystemStructure.xml (or a folder holding one) and the
    OspModelDescriptions beside its FMUs or beside it (the module docstring)."""
    p = Path(str(path))
    if p.is_dir():
        p = p / STRUCTURE
    if not p.is_file():
        raise SystemDescriptionError(f"{p}: no such OspSystemStructure file")
    return _Reader(p).system()


class _Reader:
    def __init__(self, path: Path):
        self.path = path
        self.root = _parse(path, "OspSystemStructure")
        self.instances: dict[str, Instance] = {}
        self.fmu_md: dict[str, object] = {}       # instance -> fmpy model description
        self.osp_md: dict[str, ModelDescription] = {}

    def fail(self, what: str) -> SystemDescriptionError:
        return SystemDescriptionError(f"{self.path}: {what}")

    # -- the whole -----------------------------------------------------------------------------------------------
    def system(self) -> System:
        for el in _children(_child(self.root, "Simulators"), "Simulator"):
            self.simulator(el)
        if not self.instances:
            raise self.fail("Simulators: no Simulator")
        pairs, bonds_named = self.connections()
        connections, bonds = self.bonds(pairs, bonds_named)
        name = self.path.parent.name if self.path.name == STRUCTURE else self.path.stem
        description = (_child(self.root, "Description").text or "").strip() \
            if _child(self.root, "Description") is not None else ""
        return System(name=name or "osp", instances=list(self.instances.values()), connections=connections,
                      bonds=bonds, experiment=self.experiment(), description=description or f"OSP system {name}")

    def number(self, el: ET.Element | None, what: str, positive: bool = False) -> float | None:
        if el is None:
            return None
        text = (el.text or "").strip()
        try:
            value = float(text)
        except ValueError:
            raise self.fail(f"{what} = {text!r} is not a number") from None
        if not math.isfinite(value) or (positive and value <= 0) or value < 0:
            raise self.fail(f"{what} = {text} must be a finite number {'> 0' if positive else '>= 0'} [s]")
        return value

    def experiment(self) -> Experiment:
        base = self.number(_child(self.root, "BaseStepSize"), "BaseStepSize", positive=True)
        start = self.number(_child(self.root, "StartTime"), "StartTime") or 0.0
        end = self.number(_child(self.root, "EndTime"), "EndTime", positive=True)
        if end is not None and end <= start:
            raise self.fail(f"EndTime = {end:g} s must be after StartTime = {start:g} s")
        algorithm_el = _child(self.root, "Algorithm")
        algorithm = (algorithm_el.text or "").strip() if algorithm_el is not None else "fixedStep"
        step = base if base is not None else LIBCOSIM_BASE_STEP
        if algorithm.lower() == "fixedstep":
            return Experiment(stop_time=end, step=step, master="jacobi-sampled", start_time=start)
        if algorithm.lower() != "ecco":
            raise self.fail(f"Algorithm = {algorithm!r} is not one OSP defines: fixedStep or ecco")
        config = _child(self.root, "EccoConfiguration")
        if config is None:
            raise self.fail("Algorithm ecco needs an EccoConfiguration (libcosim refuses it without one too)")
        values = {}
        for tag in ["StepSize", *ECCO]:
            el = _child(config, tag)
            if el is None:
                raise self.fail(f"EccoConfiguration has no {tag}")
            values[tag] = self.number(el, f"EccoConfiguration/{tag}", positive=True)
        options = {ECCO[k]: v for k, v in values.items() if k in ECCO}
        return Experiment(stop_time=end, step=values["StepSize"], master="jacobi-sampled", step_control="ecco",
                          start_time=start, step_options=options)

    # -- simulators ----------------------------------------------------------------------------------------------
    def source(self, text: str, name: str) -> Path:
        if not text:
            raise self.fail(f"Simulator {name!r}: no source")
        url = urlparse(text)
        if url.scheme in ("", "file") or len(url.scheme) == 1:   # a relative path, file: URI or a drive letter
            raw = unquote(url.path) if url.scheme == "file" else unquote(text)
            p = Path(raw)
            return p if p.is_absolute() else self.path.parent / p
        raise self.fail(f"Simulator {name!r}: source {text!r}: scheme {url.scheme}:// is not a local FMU file (the "
                        f"harness opens .fmu files; run a proxy FMU through its file)")

    def simulator(self, el: ET.Element) -> None:
        name = el.get("name") or ""
        if not name or "." in name:
            raise self.fail(f"Simulator name {name!r} must be non-empty without '.' (instance names of the harness)")
        if name in self.instances:
            raise self.fail(f"Simulator {name!r} is declared twice")
        fmu = self.source(el.get("source") or "", name)
        if not fmu.is_file():
            raise self.fail(f"Simulator {name!r}: FMU {fmu} does not exist")
        md = model_description(fmu)
        self.fmu_md[name] = md
        step = el.get("stepSize")
        own = None
        if step is not None:
            try:
                own = float(step)
            except ValueError:
                raise self.fail(f"Simulator {name!r}: stepSize = {step!r} is not a number") from None
            if not (own > 0 and math.isfinite(own)):
                raise self.fail(f"Simulator {name!r}: stepSize = {step} must be a positive number of seconds")
        params = {}
        for iv in _children(_child(el, "InitialValues"), "InitialValue"):
            params[iv.get("variable") or ""] = self.initial_value(iv, name)
        self.instances[name] = Instance(name, fmu, params, own)
        for folder in (fmu.parent, self.path.parent):   # libcosim's order: beside the FMU, then beside the file
            candidate = folder / f"{md.modelName}{MODEL_DESCRIPTION}"
            if candidate.is_file():
                self.osp_md[name] = read_model_description(candidate)
                break

    def initial_value(self, iv: ET.Element, sim: str):
        var = iv.get("variable") or ""
        typed = next((c for c in iv if isinstance(c.tag, str)), None)
        if typed is None or typed.get("value") is None:
            raise self.fail(f"Simulator {sim!r}: InitialValue {var!r} has no typed value (Real, Integer, Boolean, "
                            f"String with value=...)")
        kind, text = _tag(typed), typed.get("value")
        try:
            if kind == "Real":
                return float(text)
            if kind == "Integer":
                return int(text)
            if kind == "Boolean":
                return {"true": True, "1": True, "false": False, "0": False}[text.strip()]
            if kind == "String":
                return text
        except (ValueError, KeyError):
            raise self.fail(f"Simulator {sim!r}: InitialValue {var!r} = {text!r} is not a {kind}") from None
        raise self.fail(f"Simulator {sim!r}: InitialValue {var!r}: unknown type {kind} (Real, Integer, Boolean, "
                        f"String)")

    # -- connections ---------------------------------------------------------------------------------------------
    def variable(self, sim: str, var: str, where: str):
        if sim not in self.fmu_md:
            raise self.fail(f"{where}: unknown simulator {sim!r} (simulators: {', '.join(self.instances)})")
        for v in self.fmu_md[sim].modelVariables:
            if v.name == var:
                return v
        raise self.fail(f"{where}: FMU {self.fmu_md[sim].modelName} of simulator {sim!r} has no variable {var!r}")

    def pair(self, a: tuple, b: tuple, where: str, units: tuple = (None, None)) -> Connection:
        """The connection between endpoints a and b ((simulator, variable)), from the output side, converting
        units (``units``: the OSP units of a and b, None where the group gives none)."""
        va, vb = self.variable(*a, where), self.variable(*b, where)
        outs = ("output", "calculatedParameter")
        if va.causality in outs and vb.causality not in outs:
            (src, vs, us), (dst, vd, ud) = (a, va, units[0]), (b, vb, units[1])
        elif vb.causality in outs and va.causality not in outs:
            (src, vs, us), (dst, vd, ud) = (b, vb, units[1]), (a, va, units[0])
        else:
            raise self.fail(f"{where}: {a[0]}.{a[1]} is {va.causality} and {b[0]}.{b[1]} is {vb.causality}: one "
                            f"side must be an output")
        c = Connection(f"{src[0]}.{src[1]}", f"{dst[0]}.{dst[1]}")
        return self.convert(c, (src[0], vs, us), (dst[0], vd, ud), where)

    def unit(self, sim: str, var, osp_unit: str | None) -> tuple[str | None, Unit | None]:
        """(name, definition) of a variable's unit: the OspModelDescription's, else the FMU's (None: none)."""
        osp = self.osp_md.get(sim)
        name = osp_unit or (osp.unit_of(var.name) if osp is not None else None)
        if name:
            if osp is not None and name in osp.units:
                return name, osp.units[name]
            return name, _fmu_unit(self.fmu_md[sim], name)
        name = var.unit or getattr(getattr(var, "declaredType", None), "unit", None)
        return (name, _fmu_unit(self.fmu_md[sim], name)) if name else (None, None)

    def convert(self, c: Connection, src: tuple, dst: tuple, where: str) -> Connection:
        (si, sv, su), (di, dv, du) = src, dst
        s_name, s_unit = self.unit(si, sv, su)
        d_name, d_unit = self.unit(di, dv, du)
        if not s_name or not d_name or sv.type != "Real":
            return c
        if s_unit is None or d_unit is None:
            if s_name == d_name:
                return c
            missing = s_name if s_unit is None else d_name
            raise self.fail(f"{where}: {c.source} is in {s_name} and {c.target} in {d_name}, and unit {missing!r} has "
                            f"no definition (UnitDefinitions of the OspModelDescription or the FMU): it cannot be "
                            f"converted")
        if s_unit.exponents != d_unit.exponents:
            raise self.fail(f"{where}: {c.source} is in {s_name} ({s_unit.dimension()}) but {c.target} in {d_name} "
                            f"({d_unit.dimension()}): units of different dimensions do not convert")
        factor = s_unit.factor / d_unit.factor
        offset = (s_unit.offset - d_unit.offset) / d_unit.factor
        return Connection(c.source, c.target, factor, offset, unit_conversion=True)

    def group(self, sim: str, name: str, where: str) -> Group:
        md = self.osp_md.get(sim)
        if md is None:
            raise self.fail(f"{where}: simulator {sim!r} has no OspModelDescription ({self.fmu_md[sim].modelName}"
                            f"{MODEL_DESCRIPTION} beside its FMU or beside {self.path.name}) to find group {name!r} in")
        g = md.find(name)
        if g is None:
            raise self.fail(f"{where}: {md.path.name} declares no variable group {name!r} (groups: "
                            f"{', '.join(md.groups) or 'none'})")
        return g

    def expand(self, a: tuple, ga: Group, b: tuple, gb: Group, where: str) -> list[Connection]:
        """The scalar connections of two groups: nested groups in order, then the variables in order."""
        if len(ga.groups) != len(gb.groups) or len(ga.variables) != len(gb.variables):
            raise self.fail(f"{where}: group {a[0]}:{ga.name} ({len(ga.groups)} groups, {len(ga.variables)} variables) "
                            f"and group {b[0]}:{gb.name} ({len(gb.groups)} groups, {len(gb.variables)} variables) "
                            f"differ in size")
        out = []
        for sa, sb in zip(ga.groups, gb.groups):
            out += self.expand(a, sa, b, sb, where)
        for (va, ua), (vb, ub) in zip(ga.variables, gb.variables):
            out.append(self.pair((a[0], va), (b[0], vb), where, (ua, ub)))
        return out

    def connections(self) -> tuple[list[Connection], dict[str, list[Connection]]]:
        """Every connection, and those of each named power bond."""
        out: list[Connection] = []
        bonds: dict[str, list[Connection]] = {}
        el = _child(self.root, "Connections")
        for k, c in enumerate(_children(el)):
            kind = _tag(c)
            where = f"Connections/{kind} {k + 1}"
            if kind in ("VariableConnection", "VariableGroupConnection"):
                ends = _children(c, "Variable" if kind == "VariableConnection" else "VariableGroup")
                if len(ends) != 2:
                    raise self.fail(f"{where}: needs two {'Variable' if kind == 'VariableConnection' else 'VariableGroup'}"
                                    f" elements, has {len(ends)}")
                a, b = [(e.get("simulator") or "", e.get("name") or "") for e in ends]
                if kind == "VariableConnection":
                    made = [self.pair(a, b, where)]
                else:
                    for sim in (a[0], b[0]):
                        if sim not in self.fmu_md:
                            raise self.fail(f"{where}: unknown simulator {sim!r} (simulators: "
                                            f"{', '.join(self.instances)})")
                    made = self.expand(a, self.group(*a, where), b, self.group(*b, where), where)
                out += made
                if c.get("powerBond"):
                    bonds.setdefault(c.get("powerBond"), []).extend(made)
                elif kind == "VariableGroupConnection" and all(
                        self.group(*end, where).kind.endswith("MechanicalPort") for end in (a, b)):
                    bonds[f"\0{k}"] = made   # a port group pair: a bond if it joins toolkit ports
            elif kind == "SignalGroupConnection":
                raise self.fail(f"{where}: signal group connections feed OSP's VectorSum function, which the harness "
                                f"does not offer")
        out += self.functions(_children(el, "SignalConnection"))
        return out, bonds

    def functions(self, signals: list[ET.Element]) -> list[Connection]:
        found = {}
        for s in signals:
            sig, var = _child(s, "Signal"), _child(s, "Variable")
            if sig is None or var is None:
                raise self.fail("SignalConnection: needs a Signal and a Variable")
            found[(sig.get("function"), sig.get("name"))] = (var.get("simulator") or "", var.get("name") or "")
        out = []
        for f in _children(_child(self.root, "Functions")):
            kind, name = _tag(f), f.get("name") or ""
            where = f"Functions/{kind} {name!r}"
            if kind != "LinearTransformation":
                raise self.fail(f"{where}: OSP's {kind} function is not offered by the harness (LinearTransformation "
                                f"is)")
            ends = [found.get((name, s)) for s in ("in", "out")]
            if None in ends:
                raise self.fail(f"{where}: needs SignalConnections to its 'in' and its 'out'")
            (si, sv), (di, dv) = ends
            vs, vd = self.variable(si, sv, where), self.variable(di, dv, where)
            if vs.causality not in ("output", "calculatedParameter") or vd.causality != "input":
                raise self.fail(f"{where}: 'in' must come from an output ({si}.{sv} is {vs.causality}) and 'out' go to "
                                f"an input ({di}.{dv} is {vd.causality})")
            try:
                factor, offset = float(f.get("factor", "1")), float(f.get("offset", "0"))
            except ValueError:
                raise self.fail(f"{where}: factor and offset must be numbers") from None
            out.append(Connection(f"{si}.{sv}", f"{di}.{dv}", factor, offset, unit_conversion=True))
        return out

    def bonds(self, connections: list[Connection], named: dict) -> tuple[list[Connection], list[Bond]]:
        """Power bonds of toolkit ports become :class:`Bond` objects (taking their position connection along);
        others stay connections (one warning)."""
        bonds, used, plain = [], set(), []
        targets = {c.target: c for c in connections}
        for name, members in named.items():
            bond = _as_bond(members, targets)
            if bond is None:
                if not name.startswith("\0"):
                    plain.append(name)
                continue
            bonds.append(bond)
            used.update(id(c) for c in bond_members(bond, targets))
        if plain:
            warnings.warn(f"{self.path}: power bonds {', '.join(plain)} do not join ports of the form <port>.w/.tau "
                          f"(or .v/.f): they run as plain connections, which ECCO step control does not see",
                          SystemWarning, stacklevel=4)
        return [c for c in connections if id(c) not in used], bonds


def _fmu_unit(md, name: str) -> Unit | None:
    for u in getattr(md, "unitDefinitions", None) or []:
        if u.name == name:
            return Unit.from_fmpy(u)
    return None


def _port(ref: str, names: tuple) -> str | None:
    inst, _, var = ref.partition(".")
    for n in names:
        if var.endswith("." + n):
            return f"{inst}.{var[:-len(n) - 1]}"
    return None


def _as_bond(members: list[Connection], targets: dict) -> Bond | None:
    """A toolkit bond from a power bond's two connections (speed one way, effort back), or None."""
    if len(members) != 2:
        return None
    for velocity, effort, position, translational in (("w", "tau", "phi", False), ("v", "f", "s", True)):
        speed = [c for c in members if c.source.endswith("." + velocity) and c.target.endswith("." + velocity)]
        back = [c for c in members if c.source.endswith("." + effort) and c.target.endswith("." + effort)]
        if len(speed) != 1 or len(back) != 1:
            continue
        a, b = _port(speed[0].source, (velocity,)), _port(speed[0].target, (velocity,))
        if _port(back[0].source, (effort,)) != b or _port(back[0].target, (effort,)) != a:
            continue
        if any(c.factor != 1 or c.offset != 0 for c in members):
            return None
        pos = targets.get(f"{b}.{position}")
        if pos is None or pos.source != f"{a}.{position}" or pos.factor != 1 or pos.offset != 0:
            return None
        return Bond(a, b, translational)
    return None


def bond_members(bond: Bond, targets: dict) -> list[Connection]:
    """The connections (by target) a bond stands for."""
    return [targets[c.target] for c in bond.connections() if c.target in targets]


__all__ = ["load_osp", "is_osp_structure", "read_model_description", "ModelDescription", "Group", "STRUCTURE",
           "MODEL_DESCRIPTION"]
