"""SSP 1.0 export: a system as an .ssp archive, and the ``export`` command.

The export (``python -m harness export X OUT.ssp``) writes ``SystemStructure.ssd`` with

* one ``ssd:Component`` per instance (``source="resources/<Model>.fmu"``), its connectors typed and with
  units (the inputs a connection drives, the outputs and the parameters it sets), and its parameter values
  inline as an ``ssv:ParameterSet`` named ``default`` (Ecos applies it with ``init(parameter_set="default")``;
  libcosim applies inline values on load), with each connected input's consistent start value
  (:func:`consistent_inputs`);
* every connection (power bonds expanded into their member variables: SSP 1.0 has no terminals, an
  ``ssd:Connector`` is one variable, so the FMI 3.0 FMUs' flange terminals are not named in the .ssd; a host
  that reads terminals finds them in the FMUs), with ``ssc:LinearTransformation`` where one is declared and
  ``ssc:IntegerMappingTransformation`` / ``ssc:BooleanMappingTransformation`` for a value mapping;
* the units used, a ``DefaultExperiment`` carrying the OSP ``FixedStepAlgorithm`` annotation so libcosim takes
  the step at which its algorithm meets the drive's accuracy (:func:`host_step`), and a ``org.pressdrive``
  annotation that keeps what SSP cannot say (power bonds, master, extrapolation, the harness's own step) so
  that export -> import is a lossless round trip;

and packs the FMUs into ``resources/``.
"""
from __future__ import annotations

import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from fmus.units import BASE_UNITS
from harness.errors import SystemDescriptionError
from harness.model import System, host_step, model_description, resolve_fmu  # host_step: public here too
from harness.ssp.format import FMU_TYPE, OSP_ANNOTATION, OWN_ANNOTATION, PARAMETER_SET
from harness.ssp.start_values import consistent_inputs
from harness.ssp.values import _q


def _num(value) -> str:
    return repr(float(value)) if isinstance(value, float) else str(value)


# --------------------------------------------------------------------------------------------------------
# export
# --------------------------------------------------------------------------------------------------------
def export_ssp(system: System, out: str | Path) -> Path:
    """Write ``system`` as an SSP archive at ``out`` (FMUs included) and return its path."""
    out = Path(out)
    if out.suffix.lower() != ".ssp":
        raise SystemDescriptionError(f"{out}: an SSP archive must end in .ssp")
    from harness.results import check_writable
    from harness.ssp.start_values import copy_with_start_values

    check_writable(out, "export")   # one line before the work for a place that cannot be written
    fmu_paths = {inst.name: resolve_fmu(inst.fmu) for inst in system.instances}
    starts = consistent_inputs(system)
    # each instance of a toolkit FMU gets a copy that starts from the instance's values by itself, for hosts
    # that apply no parameter binding (FMPy's simulate_ssp): harness.ssp.start_values
    sources, packed = {}, {}
    for inst in system.instances:
        p = fmu_paths[inst.name]
        copy = copy_with_start_values(p, inst.name, {**inst.parameters, **starts.get(inst.name, {})})
        if copy is None:
            sources[inst.name] = f"resources/{p.name}"
            packed[sources[inst.name]] = p
        else:
            sources[inst.name] = f"resources/{p.stem}_{inst.name}.fmu"
            packed[sources[inst.name]] = copy
    ssd = build_ssd(system, sources, starts)
    tmp = out.with_suffix(".ssp.part")
    try:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("SystemStructure.ssd", ET.tostring(ssd, encoding="utf-8", xml_declaration=True))
            for name, content in sorted(packed.items()):
                if isinstance(content, bytes):
                    z.writestr(name, content)
                else:
                    z.write(content, name)
        tmp.replace(out)
    except OSError as e:   # e.g. the disk full, the folder gone meanwhile
        tmp.unlink(missing_ok=True)
        raise SystemDescriptionError(f"export {out}: cannot write: {e.strerror or e}") from None
    return out


def build_ssd(system: System, sources: dict[str, str], starts: dict[str, dict] | None = None) -> ET.Element:
    """The SystemStructure.ssd element tree of a system (``sources``: instance -> FMU path in the archive;
    ``starts``: instance -> {input: start value}, bound with the instance's parameters: :func:`consistent_inputs`)."""
    root = ET.Element(_q("ssd:SystemStructureDescription"), {"version": "1.0", "name": system.name})
    sys_el = ET.SubElement(root, _q("ssd:System"), {"name": system.name})
    if system.description:
        sys_el.set("description", system.description.strip().splitlines()[0])
    elements = ET.SubElement(sys_el, _q("ssd:Elements"))
    connections = system.all_connections()
    driven = {c.target for c in connections}
    used_units: set[str] = set()
    for inst in system.instances:
        md = model_description(resolve_fmu(inst.fmu))
        comp = ET.SubElement(elements, _q("ssd:Component"),
                             {"name": inst.name, "type": FMU_TYPE, "source": sources[inst.name]})
        conns = ET.SubElement(comp, _q("ssd:Connectors"))
        variables = {v.name: v for v in md.modelVariables}
        for v in md.modelVariables:
            # an input no connection drives is no connector (unless a value is bound to it): FMPy's simulate_ssp
            # (0.3.x get_connections) wires a declared input without a connection to the source of the input
            # declared before it; the trimmer's unused take-off aux.tau took the cutting torque and doubled the
            # shaft's torque
            if (v.causality == "output" or v.name in inst.parameters
                    or (v.causality == "input" and f"{inst.name}.{v.name}" in driven)):
                c = ET.SubElement(conns, _q("ssd:Connector"), {"name": v.name, "kind": v.causality})
                attrs = {}
                if v.type == "Real" and v.unit:
                    attrs["unit"] = v.unit
                    used_units.add(v.unit)
                ET.SubElement(c, _q(f"ssc:{v.type}"), attrs)
        # OMSimulator 3.0 reads a bound name that begins with its component's name as a path from the system
        # (component knife, input knife.phi: "Unknown signal model.root.knife.phi", and the process dies): such
        # an input is not bound, it starts from its FMU's start value
        start = {k: v for k, v in (starts or {}).get(inst.name, {}).items() if not k.startswith(f"{inst.name}.")}
        bound = {**inst.parameters, **start}
        if bound:
            bindings = ET.SubElement(comp, _q("ssd:ParameterBindings"))
            binding = ET.SubElement(bindings, _q("ssd:ParameterBinding"))
            values = ET.SubElement(binding, _q("ssd:ParameterValues"))
            pset = ET.SubElement(values, _q("ssv:ParameterSet"), {"version": "1.0", "name": PARAMETER_SET})
            params = ET.SubElement(pset, _q("ssv:Parameters"))
            for name, value in bound.items():
                if name not in variables:
                    raise SystemDescriptionError(f"instance {inst.name}: FMU {md.modelName} has no parameter {name}")
                v = variables[name]
                p = ET.SubElement(params, _q("ssv:Parameter"), {"name": name})
                if v.type == "Boolean":
                    attrs = {"value": "true" if value else "false"}
                elif v.type == "String":
                    attrs = {"value": str(value)}
                else:
                    attrs = {"value": _num(float(value) if v.type == "Real" else int(value))}
                if v.type == "Real" and v.unit:
                    attrs["unit"] = v.unit
                ET.SubElement(p, _q(f"ssv:{v.type}"), attrs)
        if inst.step is not None:   # its own step, as libcosim reads it (harness.master.multirate)
            ET.SubElement(_annotation(comp, OSP_ANNOTATION), _q("osp:StepSizeHint"), {"value": _num(float(inst.step))})
    # SSP 1.0's schema wants at least one ssd:Connection in ssd:Connections: a system of one FMU has none
    conn_el = ET.SubElement(sys_el, _q("ssd:Connections")) if connections else None
    for c in connections:
        src_inst, src_var = c.source.split(".", 1)
        dst_inst, dst_var = c.target.split(".", 1)
        e = ET.SubElement(conn_el, _q("ssd:Connection"), {"startElement": src_inst, "startConnector": src_var,
                                                          "endElement": dst_inst, "endConnector": dst_var})
        if c.factor != 1.0 or c.offset != 0.0:
            ET.SubElement(e, _q("ssc:LinearTransformation"), {"factor": _num(float(c.factor)),
                                                              "offset": _num(float(c.offset))})
        if c.mapping is not None:   # an Integer/Enumeration or Boolean connection's value table
            _value_table(e, c.mapping, _variable_type(system, c.source) == "Boolean")
    # SSP 1.0 allows exactly one child element per ssc:Annotation: everything of ours goes into pd:Drive
    own = ET.SubElement(_annotation(sys_el, OWN_ANNOTATION), _q("pd:Drive"))
    bonds_el = ET.SubElement(own, _q("pd:Bonds"))
    for b in system.bonds:
        kind = "true" if system.bond_is_translational(b, None) else "false"
        ET.SubElement(bonds_el, _q("pd:Bond"), {"motionOut": b.motion_out, "motionIn": b.motion_in,
                                                 "translational": kind})
    conv = ET.SubElement(own, _q("pd:UnitConversions"))
    for c in system.connections:
        if c.unit_conversion:
            ET.SubElement(conv, _q("pd:Conversion"), {"source": c.source, "target": c.target})
    if system.free_inputs:   # inputs unconnected on purpose, with the reason: no warning in the imported drive
        free = ET.SubElement(own, _q("pd:FreeInputs"))
        for ref, why in system.free_inputs.items():
            ET.SubElement(free, _q("pd:FreeInput"), {"name": ref, "reason": why})
    exp = system.experiment
    if exp is not None:
        ET.SubElement(own, _q("pd:Experiment"), {k: str(v) for k, v in (
            ("master", exp.master), ("extrapolation", exp.extrapolation), ("stepControl", exp.step_control),
            ("tolerance", exp.tolerance), ("step", _num(float(exp.step)) if exp.step else None),
            ("rates", " ".join(f"{k}={v}" for k, v in exp.rates.items()) if exp.rates else None)) if v is not None})
    units_el = ET.SubElement(root, _q("ssd:Units"))
    for name in sorted(used_units):
        u = ET.SubElement(units_el, _q("ssc:Unit"), {"name": name})
        ET.SubElement(u, _q("ssc:BaseUnit"), {k: str(e) for k, e in BASE_UNITS.get(name, {}).items()})
    if exp is not None:
        de = ET.SubElement(root, _q("ssd:DefaultExperiment"), {"startTime": _num(float(exp.start_time)),
                                                               "stopTime": _num(float(exp.stop_time))})
        osp = _annotation(de, OSP_ANNOTATION)
        algorithm = ET.SubElement(osp, _q("osp:Algorithm"))
        ET.SubElement(algorithm, _q("osp:FixedStepAlgorithm"), {"baseStepSize": _num(host_step(system))})
    return root


def _variable_type(system: System, ref: str) -> str:
    inst, var = ref.split(".", 1)
    md = model_description(resolve_fmu(system.instance(inst).fmu))
    return next(v.type for v in md.modelVariables if v.name == var)


def _value_table(parent: ET.Element, table: dict, boolean: bool) -> None:
    """``table`` as SSP 1.0 writes it: ssc:BooleanMappingTransformation or ssc:IntegerMappingTransformation."""
    def text(x) -> str:
        return ("true" if x else "false") if boolean else str(int(x))

    el = ET.SubElement(parent, _q(f"ssc:{'Boolean' if boolean else 'Integer'}MappingTransformation"))
    for k, v in table.items():
        ET.SubElement(el, _q("ssc:MapEntry"), {"source": text(k), "target": text(v)})


def _annotation(parent: ET.Element, kind: str) -> ET.Element:
    anns = parent.find(_q("ssd:Annotations"))
    if anns is None:
        anns = ET.SubElement(parent, _q("ssd:Annotations"))
    return ET.SubElement(anns, _q("ssc:Annotation"), {"type": kind})


# --------------------------------------------------------------------------------------------------------
# CLI
# --------------------------------------------------------------------------------------------------------
def register(subparsers) -> None:
    p = subparsers.add_parser("export", help="write a system as an SSP 1.0 archive (FMUs included), as one "
                                             "co-simulation FMU (.fmu) or as OSP's OspSystemStructure.xml "
                                             "(--format osp)",
                              description="Write a system as an SSP 1.0 archive (OUT.ssp: its FMUs, their "
                                          "connections and parameter values) for other FMI/SSP tools, or as one "
                                          "co-simulation FMU of the whole drive (OUT.fmu: its FMUs inside, run by "
                                          "the drive's own master and step in each fmi2DoStep) for tools that "
                                          "import single FMUs.")
    p.add_argument("system", help="system module name in systems/, a .ssp/.ssd file or an OspSystemStructure.xml")
    p.add_argument("out", type=Path, help="output file: .ssp (SSP archive) or .fmu (one FMU of the drive); with "
                                          "--format osp a folder")
    p.add_argument("--format", choices=("ssp", "fmu", "osp"), default=None,
                   help="what to write: ssp, fmu, or osp (OSP's OspSystemStructure.xml with an "
                        "OspModelDescription per FMU and the FMUs, into the folder OUT: harness.osp.write); "
                        "default: from OUT's suffix")
    p.add_argument("--algorithm", choices=("fixedStep", "ecco"), default="fixedStep",
                   help="--format osp: the OSP algorithm the file declares (ecco: libcosim's energy-conservation "
                        "step control over the drive's power bonds); default fixedStep")
    p.add_argument("--fmi-version", type=int, choices=(2, 3), default=2,
                   help="FMI version of a drive FMU (.fmu): 2 (pythonfmu) or 3 (pythonfmu3); default 2")
    p.add_argument("--output", action="append", default=None, metavar="Instance.variable",
                   help="an output the drive FMU offers (repeatable; default: the signals of the drive's chart "
                        "and accuracy requirements)")
    p.set_defaults(func=_run_export)


def _run_export(args) -> int:
    from harness.run import load

    suffix = Path(args.out).suffix.lower()
    if args.format == "osp":
        from harness.osp.write import export_osp

        if args.output:
            raise SystemDescriptionError(f"--output applies to a drive FMU (.fmu), not to --format osp")
        print(f"wrote {export_osp(load(args.system), args.out, algorithm=args.algorithm)}")
        return 0
    if args.format is not None and suffix != f".{args.format}":
        raise SystemDescriptionError(f"--format {args.format}: {args.out} must end in .{args.format}")
    if suffix == ".fmu":
        from harness.export.drive_fmu import export_fmu

        out = export_fmu(load(args.system), args.out, outputs=args.output, fmi_version=args.fmi_version)
    elif suffix == ".ssp":
        if args.output:
            raise SystemDescriptionError(f"--output applies to a drive FMU (.fmu), not to {args.out}")
        out = export_ssp(load(args.system), args.out)
    else:
        raise SystemDescriptionError(f"{args.out}: the export writes an .ssp (SSP archive) or an .fmu (one FMU of the "
                           f"drive); got {suffix or 'no suffix'}")
    print(f"wrote {out}")
    return 0
