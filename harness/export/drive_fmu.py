"""The whole drive as one co-simulation FMU: ``python -m harness export DRIVE FILE.fmu`` and :func:`export_fmu`.

The FMU (FMI 2.0 with pythonfmu, or FMI 3.0 with pythonfmu3: ``fmi_version``) carries the drive's member FMUs
(FMI 2.0 in both) and runs the drive's declared master, input extrapolation and step inside each ``doStep`` (the
slave: :mod:`harness.export.drive_slave`, :mod:`harness.export.drive_slave3`).  It is built from
the same declarations as the component FMUs (``fmus/build.py``):

* its code is the slave plus the harness modules it imports, under names unique to this build
  (``harness_<hash>``, like the component FMUs' ``fmus_<hash>``), so two versions load side by side;
* ``resources/members/<Model>.fmu``: the member FMUs, run in the host's Python by the in-process path;
* the host loader goes in front of pythonfmu's wrapper (``fmus.build.add_loader``), so hosts without Python
  (OMSimulator's command line) load it as they load the component FMUs;
* its interface: every member parameter as ``Instance.parameter`` with the drive's value as start value, unit
  and description (Real ones settable before initialisation, ``fixed``; the Integer ones, fidelities, laws,
  tooth counts and other structural choices, as ``calculatedParameter`` the importer reads but cannot change),
  the drive's ``free_inputs`` as inputs and, as outputs, the signals of the drive's engineering quantities
  (:func:`default_outputs`).

A drive whose member cannot run inside the FMU is refused at export, naming it.
"""
from __future__ import annotations

import ast
import contextlib
import hashlib
import io
import json
import os
import re
import shutil
import sys
import tempfile
import zipfile
from pathlib import Path

from harness.errors import SystemDescriptionError
from harness.master.clock import NS
from harness.model import System, model_description, resolve_fmu

HERE = Path(__file__).resolve().parent      # harness/export
HARNESS = HERE.parent                          # harness/: the bundled package's root
PLATFORM = "linux64"
_COLUMN = re.compile(r"""(?:r\[|rise_times\()\s*["']([^"']+)["']""")


def model_class_name(system: System) -> str:
    """The FMU's model name (its modelIdentifier): the drive's name in CamelCase, ``bed_drive`` -> ``BedDrive``."""
    name = "".join(p[:1].upper() + p[1:] for p in re.split(r"[^0-9A-Za-z]+", system.name) if p)
    return name if name[:1].isalpha() else f"Drive{name}"


def default_outputs(system: System, mds: dict) -> list[str]:
    """The outputs a drive FMU offers by default: the columns of the drive's run chart and accuracy requirements
    and its crank angle (the signals of its engineering quantities), else the motion and effort of every power
    bond; only member outputs (in the order first named)."""
    wanted: list[str] = []
    if system.chart is not None:
        for panel in system.chart.panels:
            wanted += list(panel.columns)
        if system.chart.crank_angle:
            wanted.append(system.chart.crank_angle)
    if system.accuracy is not None:
        for r in system.accuracy.requirements:
            wanted += _COLUMN.findall(r.quantity) + _COLUMN.findall(r.where or "")
    if not wanted:
        for c in system.all_connections(mds):
            wanted.append(c.source)
    out = []
    for ref in wanted:
        inst, _, var = ref.partition(".")
        v = next((x for x in mds[inst].modelVariables if x.name == var), None) if inst in mds else None
        if v is not None and v.causality == "output" and v.type == "Real" and ref not in out:
            out.append(ref)
    return out


def _packable(name: str, path: Path) -> None:
    """Refuse a member the drive FMU cannot run: no binary for this platform, or not FMI 2.0 co-simulation."""
    md = model_description(path)
    with zipfile.ZipFile(path) as z:
        names = z.namelist()
    if md.fmiVersion != "2.0" or md.coSimulation is None:
        raise SystemDescriptionError(f"member {name} ({path.name}) cannot be packed into a drive FMU: it is FMI "
                                     f"{md.fmiVersion} {'co-simulation' if md.coSimulation else 'model exchange'}; "
                                     f"a drive FMU runs FMI 2.0 co-simulation members")
    if not any(n.startswith(f"binaries/{PLATFORM}/") and n.endswith(".so") for n in names):
        raise SystemDescriptionError(f"member {name} ({path.name}) cannot be packed into a drive FMU: it has no binary "
                                     f"for {PLATFORM} (binaries/{PLATFORM}/*.so)")


def _rates(system: System) -> dict:
    """Each instance's own rate inside the drive FMU (harness.master.multirate): its own step, or its experiment's
    rate, as a multiple of the drive's step."""
    from harness.master.multirate import rates_of

    step_ns = int(round(system.experiment.step * NS))
    return {**(system.experiment.rates or {}), **rates_of(system.instances, step_ns, f"system {system.name}")}


def drive_spec(system: System, outputs: list[str] | None = None) -> tuple[dict, dict[str, Path]]:
    """The drive as data for the slave (:class:`harness.export.drive_slave.DriveSlave` ``spec``) and the member FMU
    files by instance."""
    from fmus.units import BASE_UNITS

    if system.experiment is None:
        raise SystemDescriptionError(f"system {system.name} has no default experiment: a drive FMU runs its declared "
                                     f"master and step")
    exp = system.experiment
    if exp.step_control not in (None, "none"):
        raise SystemDescriptionError(f"system {system.name}: step control {exp.step_control!r} cannot run inside a "
                                     f"drive "
                                     f"FMU (fixed-step masters only)")
    paths = {i.name: resolve_fmu(i.fmu) for i in system.instances}
    for name, p in paths.items():
        _packable(name, p)
    mds = {n: model_description(p) for n, p in paths.items()}
    system.validate(mds)
    for c in system.connections:
        if c.mapping is not None:
            raise SystemDescriptionError(f"system {system.name}: connection {c.source} -> {c.target} maps values; a "
                                         f"drive "
                                         f"FMU takes Real connections only")
    parameters, inputs, units = [], [], set()

    def unit_of(v) -> str:
        return v.unit or (getattr(v.declaredType, "unit", None) if v.declaredType is not None else None) or ""

    for inst in system.instances:
        for v in mds[inst.name].modelVariables:
            if v.causality != "parameter":
                continue
            if v.type not in ("Real", "Integer"):
                raise SystemDescriptionError(f"member {inst.name}: parameter {v.name} is {v.type}; a drive FMU offers "
                                             f"Real "
                                             f"and Integer parameters")
            value = inst.parameters.get(v.name, v.start)
            value = int(value) if v.type == "Integer" else float(value)
            u = unit_of(v) if v.type == "Real" else ""
            units.add(u)
            parameters.append({"name": f"{inst.name}.{v.name}", "type": v.type, "start": value, "unit": u,
                               "description": f"{inst.name}: {v.description or v.name}"})
    for ref, why in system.free_inputs.items():
        inst, var = ref.split(".", 1)
        v = next(x for x in mds[inst].modelVariables if x.name == var)
        u = unit_of(v)
        units.add(u)
        value = system.instance(inst).parameters.get(var, v.start)
        inputs.append({"name": ref, "start": float(value or 0.0), "unit": u,
                       "description": f"{inst}: {v.description or var} (free input: {why})",
                       "min": None if v.min in (None, "") else float(v.min),
                       "max": None if v.max in (None, "") else float(v.max)})
    chosen = outputs or default_outputs(system, mds)
    outs = []
    for ref in chosen:
        inst, _, var = ref.partition(".")
        v = next((x for x in mds[inst].modelVariables if x.name == var), None) if inst in mds else None
        if v is None or v.causality != "output" or v.type != "Real":
            raise SystemDescriptionError(f"drive FMU output {ref}: not a Real output of a member of {system.name}")
        u = unit_of(v)
        units.add(u)
        outs.append({"name": ref, "unit": u, "description": f"{inst}: {v.description or var}"})
    # an event counter (an output named *_count: impacts, contact onsets) also offers the instant it last rose,
    # on the drive's own step, so a host sampling at its coarser step still reads the events' instants as
    # harness run does (qoi's rise_times reads <counter>.rise_time where a result carries it)
    for out in list(outs):
        if out["name"].endswith("_count"):
            outs.append({"name": f"{out['name']}.rise_time", "unit": "s", "rise_of": out["name"],
                         "description": f"the drive's communication point (its own step) at which {out['name']} "
                                        f"last rose; its start time before the first rise"})
            units.add("s")
    units.discard("")
    unknown = sorted(u for u in units if u not in BASE_UNITS)
    if unknown:
        raise SystemDescriptionError(f"system {system.name}: unit(s) {', '.join(unknown)} not in fmus.units.BASE_UNITS")
    spec = {
        "name": system.name,
        "description": (system.description or system.name).strip().splitlines()[0],
        "instances": [{"name": i.name, "fmu": paths[i.name].name,
                       "parameters": {k: v for k, v in i.parameters.items()}} for i in system.instances],
        "connections": [{"source": c.source, "target": c.target, "factor": float(c.factor),
                         "offset": float(c.offset), "unit_conversion": bool(c.unit_conversion)}
                        for c in system.connections],
        "bonds": [{"motion_out": b.motion_out, "motion_in": b.motion_in,
                   "translational": system.bond_is_translational(b, mds)} for b in system.bonds],
        "experiment": {"stop_time": float(exp.stop_time), "step": float(exp.step), "master": exp.master,
                       "extrapolation": int(exp.extrapolation), "rates": _rates(system)},
        "parameters": parameters, "inputs": inputs, "outputs": outs,
        "units": {u: BASE_UNITS[u] for u in sorted(units)},
        "rollback": all(bool(mds[n].coSimulation.canGetAndSetFMUstate) for n in mds),
    }
    return spec, paths


def harness_modules(start: Path = HERE / "drive_slave.py") -> list[Path]:
    """The harness source files the slave needs: ``start`` and every harness module it imports, transitively
    (also imports inside functions), with the packages' ``__init__.py``."""
    root = HARNESS.parent
    seen: set[Path] = set()
    todo = [start]
    while todo:
        f = todo.pop()
        if f in seen:
            continue
        seen.add(f)
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            for n in names:
                if n.split(".")[0] != "harness":
                    continue
                parts = n.split(".")
                for k in range(1, len(parts) + 1):
                    base = root.joinpath(*parts[:k])
                    for cand in (base.with_suffix(".py"), base / "__init__.py"):
                        if cand == HARNESS / "__init__.py":
                            continue   # the package's lazy API (run, studies): the FMU gets an empty one
                        if cand.is_file() and cand not in seen:
                            todo.append(cand)
    return sorted(seen)


def _rename(text: str, package: str) -> str:
    return re.sub(r"^(\s*)(from|import)\s+harness(?=[.\s])", rf"\1\2 {package}", text, flags=re.M)


SLAVES = {2: ("drive_slave.py", "DriveSlave"), 3: ("drive_slave3.py", "DriveSlave3")}   # per FMI version


def stage(system: System, dest: Path, outputs: list[str] | None = None,
          fmi_version: int = 2) -> tuple[Path, list[Path], dict]:
    """The staged slave script, the project files (the private harness package and the members) and the spec."""
    spec, paths = drive_spec(system, outputs)
    slave_file, slave_class = SLAVES[fmi_version]
    files = harness_modules(HERE / slave_file)
    h = hashlib.sha1(json.dumps(spec, sort_keys=True).encode() + str(fmi_version).encode())
    for f in files:
        h.update(str(f.relative_to(HARNESS.parent)).encode())
        h.update(f.read_bytes())
    digest = h.hexdigest()[:12]
    package = f"harness_{digest}"
    for f in files:
        target = dest / package / f.relative_to(HARNESS)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(_rename(f.read_text(encoding="utf-8"), package), encoding="utf-8")
    (dest / package / "__init__.py").write_text('"""The harness modules a drive FMU runs (harness.export.drive_fmu)."""\n',
                                                encoding="utf-8")
    members = dest / "members"
    members.mkdir()
    for p in sorted(set(paths.values())):
        shutil.copy2(p, members / p.name)
    cls = model_class_name(system)
    modules = sorted(".".join((Path(package) / f.relative_to(HARNESS)).with_suffix("").parts).removesuffix(".__init__")
                     for f in files + [HARNESS / "__init__.py"])
    text = (f'"""Drive FMU {cls}: the drive {system.name} with the toolkit\'s master inside '
            f'(harness.export.drive_slave)."""\n'
            f"import json\n\nfrom {package}.export.{slave_file[:-3]} import {slave_class}\n"
            + ("from pythonfmu3 import Fmi3Slave  # noqa: F401 (pythonfmu3 finds the class by this word)\n"
               if fmi_version == 3 else "") +
            f"\nSPEC = {json.dumps(json.dumps(spec))}\n\n\n"
            f"class {cls}({slave_class}{', Fmi3Slave' if fmi_version == 3 else ''}):\n"
            f"    spec = json.loads(SPEC)\n\n\n"
            "# every module of the bundled package, imported now (harness.export.drive_fmu: stage)\n"
            + "".join(f"import {m}  # noqa: E402,F401\n" for m in modules))
    script = dest / f"{system.name}_fmu_{digest}.py"
    script.write_text(text, encoding="utf-8")
    return script, [dest / package, members], spec


def export_fmu(system: System, out: str | Path, outputs: list[str] | None = None, fmi_version: int = 2) -> Path:
    """Write ``system`` as one co-simulation FMU at ``out`` and return its path (module docstring); ``outputs``:
    ``Instance.variable`` outputs to offer (default :func:`default_outputs`).  ``harness.export_fmu`` also takes
    a system's name."""
    from fmus.build import add_loader, compile_loader

    if not isinstance(system, System):
        raise SystemDescriptionError(f"export_fmu: expected a System, got {type(system).__name__} (harness.export_fmu "
                                     f"takes a name)")
    out = Path(out)
    if out.suffix.lower() != ".fmu":
        raise SystemDescriptionError(f"{out}: a drive FMU must end in .fmu")
    if fmi_version not in SLAVES:
        raise SystemDescriptionError(f"drive FMU: FMI version {fmi_version!r} is not built (allowed: 2, 3)")
    if fmi_version == 3:
        from pythonfmu3.builder import FmuBuilder
    else:
        from pythonfmu.builder import FmuBuilder

    tmp = Path(tempfile.mkdtemp(prefix=f"pressdrive_drive_{system.name}_"))
    try:
        script, project, spec = stage(system, tmp / "src", outputs, fmi_version)
        state = {"canGetAndSetFMUState" if fmi_version == 3 else "canGetAndSetFMUstate": spec["rollback"]}
        with contextlib.redirect_stdout(io.StringIO()):
            fmu = Path(FmuBuilder.build_FMU(script, dest=tmp / "out", project_files=project,
                                            canHandleVariableCommunicationStepSize=True, needsExecutionTool=False,
                                            **state))
        if sys.platform.startswith("linux"):
            add_loader(fmu, compile_loader(tmp, fmi_version), fmi_version)
        out.parent.mkdir(parents=True, exist_ok=True)
        part = out.with_name(out.name + ".part")
        shutil.copyfile(fmu, part)
        os.replace(part, out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out
