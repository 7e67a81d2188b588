"""SSP 1.0 import: reads SSP written by any tool: components with ``source`` relative to the
archive (or the .ssd's folder), inline and referenced (``.ssv``) parameter values on components or on the
system (``Component.parameter`` names; a binding's ``prefix`` is prepended to the names of its source, as
the SSP 1.0 schema says; ``sourceBase="component"`` reads the .ssv from inside the component's FMU, as
SSP 1.0 resolves it against the component's source), connections with linear, integer, boolean and
enumeration mapping transformations (the last by item names, looked up in both variables' types), the
default experiment and the OSP fixed-step annotation.  The FMUs' FMI 3.0 terminals are read
(:meth:`_Reader.terminal_edges`, :meth:`_Reader.bonds_from_terminals`): a connection that names two
terminals connects their members (two flanges: a power bond), and member connections that make up a flange
pair are that bond, also without this toolkit's annotation.  A component with
``implementation="ModelExchange"`` runs through its FMU's Model Exchange interface (:func:`harness.fmi.cache.model_exchange_only`,
:mod:`harness.fmi.me`).  A Real parameter value given with a ``unit`` other than its FMU variable's is
converted through the unit definitions (SSP's and FMI's unit model, :mod:`harness.ssp.values`), looked up in
the .ssv's ``ssv:Units``, then the .ssd's ``ssd:Units``, then the FMU's ``UnitDefinitions``; a value that
cannot be converted that way is refused in one line naming the file, component, parameter, value and both
units.  Parameter mappings (``.ssm`` or inline; :class:`harness.ssp.values.Mapping`) rename and transform a
binding's values.  Nested systems are flattened (:meth:`_Reader.collect`, :meth:`_Reader.resolve`): a
component of system ``Sub`` becomes instance ``Sub/Component``, and connections through system connectors are
followed to the FMU output that drives them.  An SSP may be given unpacked, as a folder holding
SystemStructure.ssd; a DefaultExperiment's startTime is the run's start.  Anything else that changes the
meaning of the system (signal dictionaries, non-FMU components, inputs of the whole system) is refused with
one line naming the element and the file.

The parameter values (bindings, .ssv and .ssm files, units) are read by :class:`harness.ssp.bindings.Bindings`, a
part of the one reader :class:`_Reader`, whose checks share one message form.
"""
from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree as ET

from harness.errors import SystemDescriptionError
from harness.fmi.cache import model_exchange_only, terminals, unzipped
from harness.model import Bond, Connection, Experiment, Instance, System, model_description
from harness.ssp.bindings import Bindings
from harness.ssp.format import FMU_TYPE, OSP_ANNOTATION, OWN_ANNOTATION
from harness.ssp.values import VALUE_TABLES, Quantity, Unit, _q, units, value_table


# --------------------------------------------------------------------------------------------------------
# import
# --------------------------------------------------------------------------------------------------------
def _unpack(path: Path) -> Path:
    """Extract an .ssp once (the one archive cache, :func:`harness.fmi.cache.unzipped`); return the folder."""
    try:
        return unzipped(path, "_ssp")
    except zipfile.BadZipFile as e:
        raise SystemDescriptionError(f"{path}: not an SSP archive ({e})") from None


def load_ssp(path: str | Path) -> System:
    """Read an .ssp archive, an .ssd file, or an SSP unpacked into a folder (holding SystemStructure.ssd)
    into a System."""
    path = Path(path)
    if not path.exists():
        raise SystemDescriptionError(f"{path}: no such file")
    archive = None
    if path.is_dir():
        ssd_path, root_dir = path / "SystemStructure.ssd", path
        if not ssd_path.is_file():
            raise SystemDescriptionError(f"{path}: a folder given as an SSP must hold SystemStructure.ssd (it does not)")
    elif path.suffix.lower() == ".ssp":
        root_dir, archive = _unpack(path), path
        ssd_path = root_dir / "SystemStructure.ssd"
        if not ssd_path.exists():
            raise SystemDescriptionError(f"{path}: the archive has no SystemStructure.ssd")
    elif path.suffix.lower() == ".ssd":
        ssd_path, root_dir = path, path.parent
    else:
        raise SystemDescriptionError(f"{path}: expected an .ssp or .ssd file")
    reader = _Reader(ssd_path, root_dir, archive)
    try:
        tree = ET.parse(ssd_path)
    except (ET.ParseError, LookupError, ValueError) as e:  # also a declared encoding Python lacks
        raise SystemDescriptionError(f"{reader.label(ssd_path)}: not well-formed XML ({e})") from None
    return reader.system(tree.getroot())


ENUMERATION_MAPPING = "EnumerationMappingTransformation"
NESTED = "/"   # joins a nested system's name and its element's: instance "Sub/Component" (names hold no ".")


@dataclass
class _Edge:
    """A connection between two endpoints, ("fmu", instance, variable) or ("connector", system path, name)."""
    source: tuple
    target: tuple
    factor: float = 1.0
    offset: float = 0.0
    mapping: dict | None = None   # an integer or boolean value table (Connection.mapping)
    mapping_kind: str | None = None   # the transformation it came from: IntegerMapping... or BooleanMapping...


def _label(endpoint: tuple) -> str:
    kind, owner, name = endpoint
    if kind == "fmu":
        return f"{owner}.{name}"
    return f"system connector '{NESTED.join(owner + (name,)) if owner else name}'"


def _as_bond(members: list, ends: dict) -> Bond | None:
    """The Bond that member edges between two terminals (``ends``: instance -> Terminal) make, if they are a
    power bond's: the members of both terminals are phi, w, tau (or s, v, f), each named
    ``<terminal>.<member>`` (the toolkit's port convention, :class:`harness.model.Bond`), with the motion
    members going one way and the effort the other."""
    for tr in (False, True):
        names = Bond("", "", tr).names()
        by_member = {}
        for m in members:
            (_, a, va), (_, b, vb) = m.source, m.target
            ta, tb = ends[a], ends[b]
            if a == b or va != f"{ta.name}.{va.split('.', 1)[-1]}" or vb != f"{tb.name}.{vb.split('.', 1)[-1]}":
                return None
            by_member[va.split(".", 1)[-1]] = (f"{a}.{ta.name}", f"{b}.{tb.name}", vb.split(".", 1)[-1])
        if sorted(by_member) != sorted(names) or any(k != v[2] for k, v in by_member.items()):
            continue
        (out_p, in_p, _), (out_v, in_v, _), (from_e, to_e, _) = (by_member[n] for n in names)
        if (out_p, in_p) == (out_v, in_v) == (to_e, from_e):
            return Bond(out_p, in_p, tr)
    return None


def _composed(first: dict | None, then: dict | None) -> dict | None:
    """The value table of two mapped connections in a row (through a system connector): ``then`` after
    ``first``; a value ``first`` maps to one ``then`` has no entry for has none in the result either."""
    if first is None or then is None:
        return then if first is None else first
    return {k: then[v] for k, v in first.items() if v in then}


class _Reader(Bindings):
    """Reads one .ssd.  ``archive``: the user's .ssp when the .ssd was extracted from one; messages then name
    files as ``x.ssp!SystemStructure.ssd`` (:meth:`label`), not by their place in the extraction cache."""

    def __init__(self, ssd_path: Path, root_dir: Path, archive: Path | None = None):
        self.ssd_path, self.root_dir, self.archive = ssd_path, root_dir, archive
        self.units: dict[str, Unit] = {}   # the .ssd's ssd:Units
        self.connector_values: dict[tuple, object] = {}   # system connector endpoint -> its bound value

    def label(self, path: Path) -> str:
        """A file as the user knows it: inside their .ssp (``x.ssp!resources/a.ssv``), or its path."""
        if self.archive is not None:
            try:
                return f"{self.archive}!{Path(path).relative_to(self.root_dir).as_posix()}"
            except ValueError:
                pass
        return str(path)

    def fail(self, what: str) -> SystemDescriptionError:
        return SystemDescriptionError(f"{self.label(self.ssd_path)}: {what}")

    def system(self, root: ET.Element) -> System:
        if root.tag != _q("ssd:SystemStructureDescription"):
            raise self.fail(f"root element is <{root.tag}>, not ssd:SystemStructureDescription")
        sys_el = root.find(_q("ssd:System"))
        if sys_el is None:
            raise self.fail("no ssd:System element")
        self.units = units(root, "ssd:Units")
        name = sys_el.get("name") or root.get("name") or self.ssd_path.stem
        instances: list[Instance] = []
        edges: list[_Edge] = []
        self.collect(sys_el, (), name, instances, edges)
        edges, terminal_bonds = self.terminal_edges(edges, instances)
        connections = self.resolve(edges, name, instances)
        # a value bound on a connected input is only its start (export_ssp binds the consistent one for hosts
        # that set no input before initialization): the harness initialises the input from its source
        driven = {c.target for c in connections}
        for inst in instances:
            for k in [k for k in inst.parameters if f"{inst.name}.{k}" in driven]:
                del inst.parameters[k]
        bonds, conversions, exp_extra, free_inputs = self.own_annotation(sys_el)
        names = {inst.name for inst in instances}
        free_inputs = {ref: why for ref, why in free_inputs.items() if ref.partition(".")[0] in names}
        bonded = set()
        for b in bonds:
            bonded.update((c.source, c.target) for c in b.connections())
        for c in connections:
            if (c.source, c.target) in conversions:
                c.unit_conversion = True
        connections = [c for c in connections if (c.source, c.target) not in bonded]
        connections, found = self.bonds_from_terminals(connections, instances)
        bonds += terminal_bonds + found
        experiment = self.experiment(root, exp_extra)
        self.drop_unknown_bindings(instances)
        return System(name=name, instances=instances, connections=connections, bonds=bonds,
                      experiment=experiment, description=sys_el.get("description", ""), free_inputs=free_inputs)

    def collect(self, sys_el: ET.Element, path: tuple, name: str, instances: list, edges: list) -> None:
        """The components of ``sys_el`` and of every system nested in it (recursively) into ``instances``,
        named by their path (``Sub/Component``; :data:`NESTED`), and every connection into ``edges``, with
        system connectors as endpoints of their own (:meth:`resolve` joins them up)."""
        where = f"system '{'/'.join(path) or name}'"
        if sys_el.find(_q("ssd:SignalDictionaries")) is not None:
            raise self.fail(f"ssd:SignalDictionaries in {where} are not supported")
        prefix = "".join(f"{p}{NESTED}" for p in path)
        local: dict[str, str] = {}           # element name in this system -> "component" / "system"
        elements = sys_el.find(_q("ssd:Elements"))
        for el in (list(elements) if elements is not None else []):
            el_name = el.get("name")
            if el.tag == _q("ssd:System"):
                if not el_name:
                    raise self.fail(f"an ssd:System in {where} has no name")
                local[el_name] = "system"
                self.collect(el, path + (el_name,), name, instances, edges)
                continue
            if el.tag == _q("ssd:SignalDictionaryReference"):
                raise self.fail(f"ssd:SignalDictionaryReference '{el_name}' is not supported")
            if el.tag != _q("ssd:Component"):
                raise self.fail(f"element <{el.tag}> in ssd:Elements is not supported")
            local[el_name] = "component"
            instances.append(self.component(el, prefix))
        by_name = {i.name: i for i in instances}
        connectors = {c.get("name") for c in sys_el.findall(f"{_q('ssd:Connectors')}/{_q('ssd:Connector')}")}
        for pname, value in self.parameter_bindings(sys_el, where).items():
            if pname in connectors:  # a value for a connector of this system: what it passes on (resolve)
                self.connector_values[("connector", path, pname)] = value
                continue
            inst, var = self._parameter_target(pname, prefix, by_name)
            if inst is None:
                raise self.fail(f"{where}: parameter '{pname}' names no component (expected Component.parameter "
                                f"or a connector of the system)")
            inst.parameters[var] = self.convert(value, inst, var)
        for c in sys_el.findall(f"{_q('ssd:Connections')}/{_q('ssd:Connection')}"):
            edges.append(self.connection(c, path, prefix, local, where))

    @staticmethod
    def _parameter_target(pname: str, prefix: str, by_name: dict):
        """(instance, variable) a system-level parameter name ``Element.variable`` (or, into nested systems,
        ``Sub.Element.variable``) sets, or (None, None)."""
        parts = pname.split(".")
        for i in range(len(parts) - 1, 0, -1):
            inst = by_name.get(prefix + NESTED.join(parts[:i]))
            if inst is not None:
                return inst, ".".join(parts[i:])
        return None, None

    def resolve(self, edges: list, name: str, instances: list) -> list[Connection]:
        """FMU-to-FMU connections from the connections of every level: a path through system connectors is
        followed to the FMU output that drives it, and the linear transformations on the way are composed
        (target = f2 (f1 source + o1) + o2).  A system connector that nothing drives but that its system's
        parameter bindings give a value (as OMSimulator writes a value set on a system input) passes that
        value on: the FMU inputs it reaches start from it (transformed on the way) and keep it.  Any other
        connector of the outermost system that drives something is an input of the whole system, which
        nothing drives here: refused.  Connections that end at a system
        connector only pass values on (the outermost system's outputs are its components' outputs, recorded
        as such)."""
        driver: dict[tuple, _Edge] = {}
        by_name = {i.name: i for i in instances}
        for e in edges:
            if e.target in driver:
                raise self.fail(f"{_label(e.target)} is the target of two connections "
                                f"({_label(driver[e.target].source)} and {_label(e.source)})")
            driver[e.target] = e
        out = []
        for e in edges:
            if e.target[0] != "fmu":
                continue
            source, factor, offset, table, seen = e.source, e.factor, e.offset, e.mapping, {e.target}
            kinds = {e.mapping_kind} - {None}
            while source[0] == "connector":
                if source in seen:
                    raise self.fail(f"system connectors {_label(source)} form a loop")
                seen.add(source)
                up = driver.get(source)
                if up is None and source in self.connector_values:
                    break
                if up is None:
                    system = "/".join(source[1]) or name
                    raise self.fail(f"system connector '{source[2]}' of system '{system}' drives "
                                    f"{_label(e.target)} but nothing drives it"
                                    + (" (an input of the whole system: connect it inside)" if not source[1] else ""))
                source, factor, offset = up.source, factor * up.factor, factor * up.offset + offset
                table = _composed(up.mapping, table)
                kinds |= {up.mapping_kind} - {None}
            if source[0] == "connector":  # a system connector given a value drives nothing else: a constant
                inst, var = by_name[e.target[1]], e.target[2]
                value = self.connector_values[source]
                if (factor, offset) != (1.0, 0.0):  # on the number as written
                    value = factor * (value.value if isinstance(value, Quantity) else value) + offset
                if ENUMERATION_MAPPING in kinds:
                    raise self.fail(f"{_label(source)} passes a bound value to {_label(e.target)} through an "
                                    f"ssc:{ENUMERATION_MAPPING}: its item names have no type there; give the value "
                                    f"of the target's item instead")
                if table is not None:
                    if value not in table:
                        raise self.fail(f"{_label(source)} passes {value!r} to {_label(e.target)}, and the "
                                        f"connections' value mapping has no entry for it (entries for "
                                        f"{sorted(table)})")
                    value = table[value]
                inst.parameters[var] = self.convert(value, inst, var)
                continue
            if kinds:
                self.check_mapping_kinds(kinds, source, e.target, by_name[source[1]])
            if ENUMERATION_MAPPING in kinds:
                table = self.enumeration_values(table, source, e.target, by_name)
            out.append(Connection(source=f"{source[1]}.{source[2]}", target=f"{e.target[1]}.{e.target[2]}",
                                  factor=factor, offset=offset, mapping=table))
        return out

    def check_mapping_kinds(self, kinds: set, source: tuple, target: tuple, inst: Instance) -> None:
        """SSP 1.0: an IntegerMappingTransformation is valid for Integer and Enumeration values, a
        BooleanMappingTransformation for Boolean ones; anything else on the way from ``source`` is refused."""
        var = next((v for v in model_description(inst.fmu).modelVariables if v.name == source[2]), None)
        if var is None:   # no such variable: the system's validation names it
            return
        want = {"Boolean": {"BooleanMappingTransformation"}, "Integer": {"IntegerMappingTransformation"},
                "Enumeration": {"IntegerMappingTransformation", ENUMERATION_MAPPING}}.get(var.type, set())
        wrong = sorted(kinds - want)
        what = f"connection {_label(source)} -> {_label(target)}"
        if wrong:
            raise self.fail(f"{what}: ssc:{wrong[0]} does not apply to {var.type} values (IntegerMapping"
                            f"Transformation: Integer and Enumeration; BooleanMappingTransformation: Boolean; "
                            f"{ENUMERATION_MAPPING}: Enumeration)")
        if len(kinds) > 1:
            raise self.fail(f"{what}: an ssc:{ENUMERATION_MAPPING} (item names) and an "
                            f"ssc:IntegerMappingTransformation (values) on one path are not supported")

    def enumeration_values(self, names: dict, source: tuple, target: tuple, by_name: dict) -> dict:
        """An ssc:EnumerationMappingTransformation's table of item names as the table of their values: each
        name looked up in the source's and the target's enumeration type (SSP 1.0: the mapping is "based on
        a mapping table of their enumeration item names"); a name the type has not is refused in one line."""
        what = f"connection {_label(source)} -> {_label(target)}"
        items = []
        for end in (source, target):
            var = next((v for v in model_description(by_name[end[1]].fmu).modelVariables if v.name == end[2]), None)
            dt = getattr(var, "declaredType", None) if var is not None else None
            if var is None or var.type != "Enumeration" or dt is None or not getattr(dt, "items", None):
                raise self.fail(f"{what}: ssc:{ENUMERATION_MAPPING} needs an Enumeration variable with a declared "
                                f"type at both ends; {_label(end)} is not one")
            items.append({i.name: int(i.value) for i in dt.items})
        out = {}
        for a, b in names.items():
            for name, known, end in ((a, items[0], source), (b, items[1], target)):
                if name not in known:
                    raise self.fail(f"{what}: ssc:{ENUMERATION_MAPPING} maps '{name}', which is no item of "
                                    f"{_label(end)}'s type (items: {', '.join(known)})")
            out[items[0][a]] = items[1][b]
        return out

    def component(self, el: ET.Element, prefix: str = "") -> Instance:
        name = el.get("name")
        if not name:
            raise self.fail("an ssd:Component has no name")
        name = prefix + name
        ctype = el.get("type", FMU_TYPE)
        if ctype != FMU_TYPE:
            raise self.fail(f"component '{name}' has type '{ctype}'; only FMUs ({FMU_TYPE}) are supported")
        implementation = el.get("implementation", "any")
        if implementation not in ("any", "CoSimulation", "ModelExchange"):
            raise self.fail(f"component '{name}': implementation='{implementation}' is not supported "
                            f"(only CoSimulation and ModelExchange)")
        source = el.get("source")
        if not source:
            raise self.fail(f"component '{name}' has no source")
        if source.startswith("file:"):
            source = source[5:].lstrip("/") if not source.startswith("file:///") else source[7:]
        fmu = Path(source)
        if not fmu.is_absolute():
            fmu = (self.root_dir / source) if (self.root_dir / source).exists() else (self.ssd_path.parent / source)
        if not fmu.exists():
            raise self.fail(f"component '{name}': source {source} not found")
        if implementation == "ModelExchange":  # run through its ME interface (harness.fmi.me), not as CS
            try:
                fmu = model_exchange_only(fmu)
            except SystemDescriptionError as e:
                raise self.fail(f"component '{name}': implementation='ModelExchange', but {e}") from None
        inst = Instance(name=name, fmu=fmu, parameters=self.parameter_bindings(el, f"component '{name}'", fmu),
                        step=self.step_size_hint(el, name))
        inst.parameters = {k: self.convert(v, inst, k) for k, v in inst.parameters.items()}
        return inst

    def step_size_hint(self, el: ET.Element, name: str) -> float | None:
        """The component's own step from OSP's annotation (``osp:StepSizeHint value``, libcosim's per-component
        step: :mod:`harness.master.multirate`), or None."""
        for ann in el.findall(f"{_q('ssd:Annotations')}/{_q('ssc:Annotation')}"):
            if ann.get("type") != OSP_ANNOTATION:
                continue
            hint = ann.find(_q("osp:StepSizeHint"))
            if hint is not None:
                try:
                    value = float(hint.get("value", ""))
                except ValueError:
                    value = float("nan")
                if not (value > 0 and value < float("inf")):
                    raise self.fail(f"component '{name}': osp:StepSizeHint value={hint.get('value')!r} must be a "
                                    f"positive number of seconds")
                return value
        return None

    def drop_unknown_bindings(self, instances: list[Instance]) -> None:
        """A parameter binding names a variable its component's FMU lacks: OMSimulator warns and runs, so the
        binding is dropped with ONE warning naming every such binding (an edited parameter set, or one written
        for another version of the FMU).  A ``--set`` or ``start_values`` of a missing name stays an error."""
        dropped = []
        for inst in instances:
            names = {v.name for v in model_description(inst.fmu).modelVariables}
            for var in [k for k in inst.parameters if k not in names]:
                del inst.parameters[var]
                dropped.append(f"{inst.name}.{var}")
        if dropped:
            import warnings

            from harness.model import SystemWarning

            warnings.warn(f"{self.label(self.ssd_path)}: parameter binding(s) of {', '.join(dropped)} name no "
                          f"variable of the component's FMU: ignored, the run goes on with the FMU's start "
                          f"values", SystemWarning, stacklevel=2)

    def connection(self, c: ET.Element, path: tuple, prefix: str, local: dict, where: str) -> "_Edge":
        """One ssd:Connection of the system at ``path`` as an edge between endpoints: ("fmu", instance,
        variable) or ("connector", system path, connector) for a connector of this system (no element
        named) or of a system nested in it."""
        def endpoint(element, connector):
            if not element:
                return ("connector", path, connector)
            kind = local.get(element)
            if kind is None:
                raise self.fail(f"{where}: a connection names element '{element}', which the system does not have")
            if kind == "system":
                return ("connector", path + (element,), connector)
            return ("fmu", prefix + element, connector)

        s_el, e_el = c.get("startElement"), c.get("endElement")
        s_con, e_con = c.get("startConnector"), c.get("endConnector")
        factor, offset, table, table_kind = 1.0, 0.0, None, None
        what = f"connection {s_el or ''}.{s_con} -> {e_el or ''}.{e_con}"
        for t in c:
            kind = t.tag.rsplit("}", 1)[-1]
            if kind == "LinearTransformation":
                factor = float(t.get("factor", "1")); offset = float(t.get("offset", "0"))
            elif kind in VALUE_TABLES:   # Integer/Enumeration or Boolean values through a table (Connection.mapping)
                try:
                    table, table_kind = value_table(t), kind
                except ValueError as e:
                    raise self.fail(f"{what}: {e}") from None
            elif kind == ENUMERATION_MAPPING:   # by item names: made a table of values in resolve
                table, table_kind = {m.get("source"): m.get("target") for m in t.findall(_q("ssc:MapEntry"))}, kind
                if not table or None in table or None in table.values():
                    raise self.fail(f"{what}: ssc:{kind} needs ssc:MapEntry elements with a source and a target")
            elif kind not in ("Annotations", "ConnectionGeometry"):   # the geometry is the diagram's only
                raise self.fail(f"{what}: ssc:{kind} is not supported")
        return _Edge(endpoint(s_el, s_con), endpoint(e_el, e_con), factor, offset, table, table_kind)

    # -- FMI 3.0 terminals ----------------------------------------------------------------------------------------
    def _terminal(self, endpoint: tuple, by_name: dict):
        """(instance, Terminal) when ``endpoint`` names a terminal of its FMU and no variable, else None."""
        inst = by_name.get(endpoint[1]) if endpoint[0] == "fmu" else None
        t = terminals(inst.fmu).get(endpoint[2]) if inst is not None else None
        # the terminal file first: most FMUs have none, and their descriptions are then read where used
        if t is None or any(v.name == endpoint[2] for v in model_description(inst.fmu).modelVariables):
            return None
        return inst, t

    def terminal_edges(self, edges: list, instances: list) -> tuple[list, list]:
        """Connections that name a terminal of an FMU at both ends (FMI 3.0 terminalsAndIcons.xml) instead of a
        variable, with their members' edges in their place; a pair of power-bond flanges becomes a Bond.

        SSP 1.0 cannot say this (an ssd:Connector is one variable of the component; the standard predates FMI
        3.0's terminals), so an SSP written for other tools lists the members (as :func:`export_ssp` does, and
        OMSimulator 3.0 refuses a connector it cannot find); a hand-written .ssd may name the terminals
        instead.  Their members are paired as FMI 3.0 says (matchingRule plug: the same memberNames on both
        sides; bus: the memberNames both have; sequence: in order), each pair from its output to its input;
        terminals of different terminalKinds, a terminal to a variable, a transformation on the connection,
        or members that are not an output and an input are refused in one line."""
        by_name = {i.name: i for i in instances}
        out, bonds = [], []
        for e in edges:
            ends = (self._terminal(e.source, by_name), self._terminal(e.target, by_name))
            if ends == (None, None):
                out.append(e)
                continue
            what = f"connection {_label(e.source)} -> {_label(e.target)}"
            if None in ends:
                raise self.fail(f"{what}: connects a terminal to a variable or system connector: connect it to "
                                f"a terminal of another FMU, or connect its members")
            (ia, ta), (ib, tb) = ends
            if ta.kind != tb.kind:
                raise self.fail(f"{what}: terminalKind '{ta.kind}' and '{tb.kind}' differ (FMI 3.0 connects "
                                f"terminals of one kind)")
            if (e.factor, e.offset, e.mapping) != (1.0, 0.0, None) or ta.unsupported or tb.unsupported:
                extra = ta.unsupported or tb.unsupported
                raise self.fail(f"{what}: " + (f"a terminal with {extra} is not supported" if extra else
                                               "a transformation on a terminal connection is not supported"))
            members = []
            for (ma, va), (mb, vb) in self._paired(ta, tb, what):
                ca, cb = (self._causality(i, v) for i, v in ((ia, va), (ib, vb)))
                if (ca, cb) == ("output", "input"):
                    members.append(_Edge(("fmu", ia.name, va), ("fmu", ib.name, vb)))
                elif (ca, cb) == ("input", "output"):
                    members.append(_Edge(("fmu", ib.name, vb), ("fmu", ia.name, va)))
                else:
                    raise self.fail(f"{what}: member '{ma}' is {ia.name}.{va} ({ca}) and {ib.name}.{vb} ({cb}): "
                                    f"a connected member needs an output on one side and an input on the other")
            bond = _as_bond(members, {ia.name: ta, ib.name: tb})
            if bond is not None:
                bonds.append(bond)
            else:
                out.extend(members)
        return out, bonds

    def _paired(self, ta, tb, what: str) -> list:
        """((member, variable) of ``ta``, (member, variable) of ``tb``) pairs by the terminals' matchingRule."""
        a = {m: v for m, v, _ in ta.members}
        b = {m: v for m, v, _ in tb.members}
        rule = ta.matching or tb.matching
        if rule != tb.matching and tb.matching:
            raise self.fail(f"{what}: matchingRule '{ta.matching}' and '{tb.matching}' differ")
        if rule == "plug":
            if set(a) != set(b):
                raise self.fail(f"{what}: matchingRule 'plug' needs the same members on both terminals "
                                f"({', '.join(sorted(a))} / {', '.join(sorted(b))})")
            return [((m, a[m]), (m, b[m])) for m in a]
        if rule == "bus":
            return [((m, a[m]), (m, b[m])) for m in a if m in b]
        if rule == "sequence":
            if len(a) != len(b):
                raise self.fail(f"{what}: matchingRule 'sequence' needs as many members on both terminals "
                                f"({len(a)} / {len(b)})")
            return [((ma, va), (mb, vb)) for (ma, va, _), (mb, vb, _) in zip(ta.members, tb.members)]
        raise self.fail(f"{what}: matchingRule '{rule}' is not one of FMI 3.0's (plug, bus, sequence)")

    @staticmethod
    def _causality(inst: Instance, var: str) -> str:
        v = next((v for v in model_description(inst.fmu).modelVariables if v.name == var), None)
        return v.causality if v is not None else "missing"

    def bonds_from_terminals(self, connections: list, instances: list) -> tuple[list, list]:
        """The power bonds the FMUs' terminals show among plain connections: two flange terminals whose three
        members are connected as a bond connects them (motion out, effort back; no transformation) become that
        Bond, as when the SSP names them (:meth:`terminal_edges`) or carries this toolkit's annotation.  An SSP
        of these FMUs saved by another tool keeps its bonds so.  Returns (the other connections, the bonds)."""
        plain = {(c.source, c.target): c for c in connections
                 if (c.factor, c.offset, c.mapping, c.unit_conversion) == (1.0, 0.0, None, False)}
        driver = {target: source for source, target in plain}   # input -> the output that drives it
        ports = {f"{i.name}.{t.name}": (i, t) for i in instances for t in terminals(i.fmu).values()}
        bonds, used = [], set()
        for port_in, (inst, t) in ports.items():
            for tr in (False, True):
                position = Bond(port_in, port_in, tr).names()[0]
                source = driver.get(f"{port_in}.{position}")
                port_out = source.rsplit(".", 1)[0] if source else None
                if port_out not in ports or ports[port_out][1].kind != t.kind:
                    continue
                bond = Bond(port_out, port_in, tr)
                links = [(x.source, x.target) for x in bond.connections()]
                if all(k in plain for k in links) and _as_bond(
                        [_Edge(("fmu", *a.split(".", 1)), ("fmu", *b.split(".", 1))) for a, b in links],
                        {inst.name: t, ports[port_out][0].name: ports[port_out][1]}) is not None:
                    bonds.append(bond)
                    used.update(links)
        return [c for c in connections if (c.source, c.target) not in used], bonds

    def own_annotation(self, sys_el: ET.Element):
        """This toolkit's annotation: the bonds, the unit conversions, the experiment's own settings and the
        inputs left unconnected on purpose (name -> reason)."""
        bonds, conversions, extra, free = [], set(), {}, {}
        for ann in sys_el.findall(f"{_q('ssd:Annotations')}/{_q('ssc:Annotation')}"):
            if ann.get("type") != OWN_ANNOTATION:
                continue
            # pd:Drive wraps the three (one child per ssc:Annotation); older archives hold them directly
            own = ann.find(_q("pd:Drive"))
            own = ann if own is None else own
            for b in own.findall(f"{_q('pd:Bonds')}/{_q('pd:Bond')}"):
                bonds.append(Bond(b.get("motionOut"), b.get("motionIn"), b.get("translational") == "true"))
            for cv in own.findall(f"{_q('pd:UnitConversions')}/{_q('pd:Conversion')}"):
                conversions.add((cv.get("source"), cv.get("target")))
            for f in own.findall(f"{_q('pd:FreeInputs')}/{_q('pd:FreeInput')}"):
                if f.get("name") and (f.get("reason") or "").strip():
                    free[f.get("name")] = f.get("reason")
            e = own.find(_q("pd:Experiment"))
            if e is not None:
                extra = dict(e.attrib)
        return bonds, conversions, extra, free

    def experiment(self, root: ET.Element, extra: dict) -> Experiment | None:
        de = root.find(_q("ssd:DefaultExperiment"))
        if de is None:
            return None
        start = float(de.get("startTime", "0"))
        if not (start >= 0.0 and start < float("inf")):
            raise self.fail(f"ssd:DefaultExperiment startTime={de.get('startTime')}: must be a finite time >= 0 s")
        stop = de.get("stopTime")
        step = None
        for info in de.iter(_q("osp:FixedStepAlgorithm")):   # libcosim's form
            step = float(info.get("baseStepSize"))
        for info in de.iter(_q("osp:FixedStepMaster")):      # the older SimulationInformation form
            step = float(info.get("stepSize"))
        if "step" in extra:   # the harness's own step, where the OSP one is for hosts of another algorithm
            step = float(extra["step"])
        return Experiment(stop_time=float(stop) if stop is not None else None, step=step,
                          master=extra.get("master", "jacobi"), extrapolation=int(extra.get("extrapolation", 0)),
                          step_control=extra.get("stepControl"), rates=_rates(extra.get("rates")),
                          tolerance=float(extra["tolerance"]) if "tolerance" in extra else None, start_time=start)


def _rates(text: str | None) -> dict | None:
    """The experiment's rates as the toolkit's annotation writes them (``"trim=25 motor=2"``)."""
    if not text:
        return None
    return {k: int(v) for k, v in (item.split("=", 1) for item in text.split())}
