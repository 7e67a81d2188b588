"""The system model: instances of FMUs, connections, power bonds and the default experiment (pure data).

A system module ``systems/<name>.py`` defines ``SYSTEM = System(...)``.  :meth:`System.validate` checks it
against the FMUs' model descriptions before anything runs: unknown instances or variables, an input
connected twice, causality mismatches (the source must be an output, the target an input), unit mismatches
(an error unless the connection declares ``unit_conversion=True``: its factor/offset convert the units) and
unknown parameters are errors naming the offending variable; an unconnected input is a warning (it keeps
its start value).

Power bonds (:class:`Bond`) pair a motion connection with the effort connection back: ``Bond("a.flange",
"b.drive")`` expands to ``a.flange.phi -> b.drive.phi``, ``a.flange.w -> b.drive.w`` and ``b.drive.tau ->
a.flange.tau`` (``.s``/``.v``/``.f`` for translational ports).  The motion-output side is ``motion_out``.
"""
from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

from harness.errors import SystemDescriptionError
from harness.fmi.cache import model_description  # noqa: F401 (the one modelDescription cache, re-exported)
from harness.specs import AccuracySpec, ChartSpec, PrecisionSpec, QuantitySpec, Scenario, Scene, StabilitySpec

ROOT = Path(__file__).resolve().parents[1]
FMU_DIR_ENV = "PRESSDRIVE_FMU_DIR"

_ROT = ("phi", "w", "tau")
_TRA = ("s", "v", "f")


class SystemWarning(UserWarning):
    """A system that runs but may not be what was meant (e.g. an unconnected input)."""


def _split(ref: str, what: str) -> tuple[str, str]:
    inst, dot, var = str(ref).partition(".")
    if not dot or not inst or not var:
        raise SystemDescriptionError(f"{what} {ref!r} must be written 'Instance.variable'")
    return inst, var


@dataclass
class Instance:
    """One FMU instance: ``fmu`` is a path to a .fmu or a bare model name (``"FourBar"``, see
    :func:`resolve_fmu`); ``parameters`` maps parameter names to values; ``step`` [s], when given, its own
    communication step, a whole multiple of the run's step (each FMU at its own rate:
    :mod:`harness.master.multirate`); None: the run's step."""
    name: str
    fmu: str | Path
    parameters: dict = field(default_factory=dict)
    step: float | None = None


@dataclass
class Connection:
    """``target = factor * source + offset`` (``"Instance.variable"`` strings).  Connected variables must
    have the same unit unless ``unit_conversion`` is True (then factor/offset convert between the units).

    ``mapping``: on an Integer, Enumeration or Boolean connection, the table ``{source value: target value}``
    the value passes through (SSP 1.0's ``ssc:IntegerMappingTransformation`` and
    ``ssc:BooleanMappingTransformation``); a source value the table has no entry for ends the run with an
    error naming the connection and the value (the table does not say what it becomes)."""
    source: str
    target: str
    factor: float = 1.0
    offset: float = 0.0
    unit_conversion: bool = False
    mapping: dict | None = None


@dataclass
class Bond:
    """A power bond between port ``motion_out`` (its motion variables are outputs) and port ``motion_in``
    (``"Instance.port"``).  ``translational``: None detects the port kind from the FMU (System.all_connections)."""
    motion_out: str
    motion_in: str
    translational: bool | None = None

    def names(self, translational: bool | None = None) -> tuple[str, str, str]:
        tr = self.translational if self.translational is not None else bool(translational)
        return _TRA if tr else _ROT

    def connections(self, translational: bool | None = None) -> list[Connection]:
        """The three connections of the bond: position and velocity forward, effort back."""
        p, v, e = self.names(translational)
        a, b = self.motion_out, self.motion_in
        return [Connection(f"{a}.{p}", f"{b}.{p}"), Connection(f"{a}.{v}", f"{b}.{v}"),
                Connection(f"{b}.{e}", f"{a}.{e}")]

    @property
    def label(self) -> str:
        return f"{self.motion_out}->{self.motion_in}"


def bond(a: str, b: str, translational: bool | None = None) -> Bond:
    """Power bond from motion-output port ``a`` to motion-input port ``b`` (``"Instance.port"``)."""
    return Bond(a, b, translational)


@dataclass
class Refusal:
    """A combination of parameter values a system refuses at load: ``when`` maps ``"Instance.param"`` to the
    value each takes in it (a parameter the system and the run leave unset counts with its FMU's start
    value); ``why`` says what the run would compute, ``instead`` what to set instead."""
    when: dict
    why: str
    instead: str


@dataclass
class Experiment:
    stop_time: float
    step: float
    master: str = "jacobi"
    extrapolation: int = 0
    step_control: str | None = None
    tolerance: float | None = None
    start_time: float = 0.0     # an SSP's DefaultExperiment may start later (harness.ssp)
    # options of the variable-step control (harness.master.stepcontrol.StepOptions' fields by name, e.g. an OSP
    # EccoConfiguration's: harness.osp); None: the controller's defaults
    step_options: dict | None = None
    # instance -> its own step as a whole multiple of this experiment's step (harness.master.multirate): taken by
    # a run with this experiment's master and step; a run with another step or master steps every FMU at its step
    rates: dict | None = None


@dataclass
class System:
    """A drive as data: its FMU instances, connections and power bonds, default experiment, and what may be
    asked of it (scenes, precision, stability, accuracy, chart, quantities, free inputs, scenarios).
    ``harness.load`` gives one; ``systems/<name>.py`` declares one as ``SYSTEM``."""

    name: str
    instances: list[Instance]
    connections: list[Connection] = field(default_factory=list)
    bonds: list[Bond] = field(default_factory=list)
    experiment: Experiment | None = None
    description: str = ""
    scenes: list[Scene] = field(default_factory=list)
    default_scene: str | None = None   # the scene asked when none is named (harness.studies.scenes.find_scene)
    precision: PrecisionSpec | None = None    # the work-precision study's quantity and grid (harness.specs)
    stability: StabilitySpec | None = None    # the stability map's coupling parameter (harness.specs)
    accuracy: AccuracySpec | None = None      # the accuracy it must meet, in engineering terms (harness.specs)
    chart: ChartSpec | None = None    # the run chart's signals, shaded zones and crank angle (harness.reporting.charts)
    quantities: QuantitySpec | None = None   # the engineering quantities printed after a run (harness.reporting.quantities)
    # inputs left unconnected on purpose, "Instance.input" -> why its start value is right; any other
    # unconnected input is warned about (validate), so a forgotten connection is never silent
    free_inputs: dict[str, str] = field(default_factory=dict)
    scenarios: list[Scenario] = field(default_factory=list)  # its transients (harness.scenarios)
    # combinations of parameter values that give no answer (e.g. a level that diverges with another's),
    # refused in one line by validate (harness.model.Refusal)
    refused: tuple = ()

    def instance(self, name: str) -> Instance:
        """The instance called ``name``; an unknown name is refused in one line listing the instances."""
        for inst in self.instances:
            if inst.name == name:
                return inst
        raise SystemDescriptionError(f"system {self.name}: unknown instance {name!r} "
                                     f"(instances: {', '.join(i.name for i in self.instances)})")

    def on_fmus(self, folder: str | Path) -> "System":
        """The same system with each instance's FMU, named by its model (the catalog's), taken from ``folder``
        (``<folder>/<model>.fmu``: a build of another FMI version or kind); an instance that names an .fmu file
        keeps it."""
        return replace(self, instances=[
            Instance(i.name, i.fmu if str(i.fmu).endswith(".fmu") else Path(folder) / f"{i.fmu}.fmu",
                     dict(i.parameters), i.step) for i in self.instances])

    def bond_is_translational(self, b: Bond, model_descriptions: dict | None) -> bool:
        """Whether bond ``b`` is translational (ports ``.s/.v/.f``) rather than rotational (``.phi/.w/.tau``):
        as the bond declares, else from the variables of its motion side's FMU (``model_descriptions`` by
        instance name, or read from the FMU file)."""
        if b.translational is not None:
            return b.translational
        inst, port = _split(b.motion_out, "bond port")
        if model_descriptions is not None and inst in model_descriptions:
            md = model_descriptions[inst]
        else:
            md = model_description(resolve_fmu(self.instance(inst).fmu))
        names = {v.name for v in md.modelVariables}
        return f"{port}.s" in names and f"{port}.phi" not in names

    def all_connections(self, model_descriptions: dict | None = None) -> list[Connection]:
        """Explicit connections plus the expanded power bonds (bond kinds detected from the FMUs)."""
        out = list(self.connections)
        for b in self.bonds:
            out.extend(b.connections(self.bond_is_translational(b, model_descriptions)))
        return out

    def validate(self, model_descriptions: dict, parameters: dict | None = None) -> list[str]:
        """Check the system against the FMUs (``model_descriptions``: instance name -> fmpy model
        description).  Raises :class:`SystemDescriptionError` on the first error; returns the warnings (also issued
        as :class:`SystemWarning`).  ``parameters``: extra ``{"Instance.param": value}`` to check."""
        names = [i.name for i in self.instances]
        seen = set()
        for n in names:
            if n in seen:
                raise SystemDescriptionError(f"system {self.name}: instance name {n!r} is used twice")
            if "." in n or not n:
                raise SystemDescriptionError(f"system {self.name}: instance name {n!r} must be non-empty without '.'")
            seen.add(n)
        variables = {i: {v.name: v for v in model_descriptions[i].modelVariables} for i in names}
        lookup = _lookup(variables, model_descriptions)

        for inst in self.instances:
            for p, value in inst.parameters.items():
                _check_parameter(lookup(f"{inst.name}.{p}", "parameter"), f"{inst.name}.{p}", value)
        self._check_values(lookup, parameters)
        for b in self.bonds:
            for port in (b.motion_out, b.motion_in):
                _split(port, "bond port")
        targets: dict[str, str] = {}
        for c in self.all_connections(model_descriptions):
            src = lookup(c.source, "connection source")
            dst = lookup(c.target, "connection target")
            where = f"connection {c.source} -> {c.target}"
            if src.causality != "output":
                raise SystemDescriptionError(f"{where}: causality mismatch: source {c.source} is {src.causality}, "
                                             f"not an output")
            if dst.causality != "input":
                raise SystemDescriptionError(f"{where}: causality mismatch: target {c.target} is {dst.causality}, "
                                             f"not an input")
            # Integer and Enumeration values are both integers (FMI 2.0 passes both through fmi2SetInteger;
            # OMSimulator connects them)
            if src.type != dst.type and {src.type, dst.type} != {"Integer", "Enumeration"}:
                raise SystemDescriptionError(f"{where}: type mismatch: {c.source} is {src.type} but {c.target} is "
                                             f"{dst.type} (connected variables must have the same type)")
            if src.type != "Real" and (c.factor != 1 or c.offset != 0):
                raise SystemDescriptionError(f"{where}: factor = {c.factor!r}, offset = {c.offset!r}: a linear "
                                             f"transformation applies to Real variables only, not to {src.type} "
                                             f"(allowed: factor 1, offset 0)")
            if c.mapping is not None:
                _check_mapping(c.mapping, src.type, where)
            if c.target in targets:
                raise SystemDescriptionError(f"input {c.target} is connected twice: from {targets[c.target]} and "
                                             f"from {c.source}")
            targets[c.target] = c.source
            for attr in ("factor", "offset"):
                value = getattr(c, attr)
                if not isinstance(value, (int, float)) or value != value or value in (float("inf"), float("-inf")):
                    raise SystemDescriptionError(f"{where}: {attr} = {value!r} must be a finite number")
            su, du = _unit(src), _unit(dst)
            if su and du and su != du and not c.unit_conversion:
                raise SystemDescriptionError(f"{where}: unit mismatch: {c.source} is in {su} but {c.target} is in {du} "
                                             f"(declare unit_conversion=True with the converting factor/offset)")
        for ref, why in self.free_inputs.items():
            v = lookup(ref, "free input")
            if v.causality != "input":
                raise SystemDescriptionError(f"system {self.name}: free_inputs names {ref}, which is {v.causality}, "
                                             f"not an "
                                             f"input")
            if ref in targets:
                raise SystemDescriptionError(f"system {self.name}: free_inputs names {ref}, but it is connected from "
                                             f"{targets[ref]}: remove it from free_inputs or the connection")
            if not isinstance(why, str) or not why.strip():
                raise SystemDescriptionError(f"system {self.name}: free_inputs[{ref!r}] = {why!r}: say why its start "
                                             f"value "
                                             f"is right (a non-empty text)")
        # an input given a value (a binding, an SSP connector value, --set) holds that value on purpose
        given = {f"{i.name}.{p}" for i in self.instances for p in i.parameters} | set(parameters or {})
        warns = []
        for inst in names:
            for v in variables[inst].values():
                ref = f"{inst}.{v.name}"
                if v.causality == "input" and ref not in targets and ref not in self.free_inputs and ref not in given:
                    start = v.start
                    if v.type == "Real" and start is not None:
                        start = float(start)
                    warns.append(f"input {ref} is not connected: it keeps its start value {start} (connect it, or "
                                 f"declare it in the system's free_inputs with the reason)")
        for w in warns:
            warnings.warn(w, SystemWarning, stacklevel=3)
        return warns


    def values_check(self, model_descriptions: dict):
        """A function of ``{"Instance.param": value}`` raising :class:`SystemDescriptionError` where :meth:`validate`
        would for those values (each a parameter of its FMU, of its type; no refused combination), for checking many
        sets of values against one system already validated (a batch of variants, harness.run.batch)."""
        variables = {i.name: {v.name: v for v in model_descriptions[i.name].modelVariables} for i in self.instances}
        lookup = _lookup(variables, model_descriptions)
        return lambda parameters: self._check_values(lookup, parameters)

    def _check_values(self, lookup, parameters: dict | None) -> None:
        for ref, value in (parameters or {}).items():
            _check_parameter(lookup(ref, "parameter"), ref, value)
        self._refuse(lookup, parameters)

    def _refuse(self, lookup, parameters: dict | None) -> None:
        """Raise SystemDescriptionError in one line when the parameter values (the system's, overridden by
        ``parameters``) make one of the system's :class:`Refusal` combinations."""
        values = {f"{i.name}.{p}": v for i in self.instances for p, v in i.parameters.items()}
        values.update(parameters or {})
        for r in self.refused:
            taken = {}
            for ref, want in r.when.items():
                have = values[ref] if ref in values else lookup(ref, "refused parameter").start
                try:
                    same = float(have) == float(want)
                except (TypeError, ValueError):
                    same = str(have) == str(want)
                if not same:
                    break
                taken[ref] = have
            else:
                given = " with ".join(f"{ref} = {v!r}" for ref, v in taken.items())
                raise SystemDescriptionError(f"system {self.name}: {given} is refused: {r.why}; use {r.instead}")


def _lookup(variables: dict, model_descriptions: dict):
    """``lookup(ref, what)``: the model variable ``Instance.variable`` names, or a one-line error naming what it is
    (``what``) and the nearest names."""
    def lookup(ref: str, what: str):
        inst, var = _split(ref, what)
        if inst not in variables:
            raise SystemDescriptionError(f"{what} {ref}: unknown instance {inst!r}{_did_you_mean(inst, variables)}")
        v = variables[inst].get(var)
        if v is None:
            # a parameter's name is closer to what --set means than an output's
            own = variables[inst].values()
            close = _did_you_mean(var, [x.name for x in own if x.causality == "parameter"]) or \
                _did_you_mean(var, [x.name for x in own])
            raise SystemDescriptionError(f"{what} {ref}: FMU {model_descriptions[inst].modelName} of instance "
                                         f"{inst} has no variable {var!r}{close}")
        return v
    return lookup


def _unit(v) -> str:
    if v.unit:
        return v.unit
    dt = getattr(v, "declaredType", None)
    return getattr(dt, "unit", None) or "" if dt is not None else ""


def _check_mapping(mapping, kind: str, where: str) -> None:
    """A connection's value table (:class:`Connection` ``mapping``) fits its variables' type: integers for
    Integer and Enumeration, booleans (or 0/1) for Boolean; none on Real or String."""
    if kind not in ("Integer", "Enumeration", "Boolean"):
        raise SystemDescriptionError(f"{where}: a value mapping applies to Integer, Enumeration and Boolean "
                                     f"connections, "
                                     f"not to {kind} (use factor/offset on a Real connection)")
    if not isinstance(mapping, dict) or not mapping:
        raise SystemDescriptionError(f"{where}: mapping = {mapping!r} must be a non-empty dict {{source value: target "
                                     f"value}}")
    for k, v in mapping.items():
        if not (_fits(k, kind) and _fits(v, kind)):
            allowed = "booleans" if kind == "Boolean" else "integers"
            raise SystemDescriptionError(f"{where}: mapping entry {k!r} -> {v!r}: {kind} connections map {allowed} to "
                                         f"{allowed}")


def _fits(value, kind: str) -> bool:
    if kind == "Boolean":
        return isinstance(value, (bool, int)) and value in (0, 1)
    return isinstance(value, int) and not isinstance(value, bool)


def _check_parameter(v, ref: str, value) -> None:
    if v.causality not in ("parameter", "input") or v.variability == "constant":
        raise SystemDescriptionError(f"parameter {ref}: the variable has causality {v.causality} and variability "
                                     f"{v.variability}; only parameters (and inputs) can be set")
    if v.type == "Real":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SystemDescriptionError(f"parameter {ref} = {value!r} must be a number")
    elif v.type in ("Integer", "Enumeration"):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or int(value) != value:
            raise SystemDescriptionError(f"parameter {ref} = {value!r} must be an integer")
    elif v.type == "Boolean":
        if not isinstance(value, (bool, int)) or value not in (0, 1):
            raise SystemDescriptionError(f"parameter {ref} = {value!r} must be a Boolean (allowed: true/false, 1/0)")
    elif v.type == "String":
        if not isinstance(value, str):
            raise SystemDescriptionError(f"parameter {ref} = {value!r} must be a string")


def host_step(system: "System") -> float:
    """The step an SSP or OSP export declares to other hosts (its OSP step): the drive's ``sampled_host_step`` where it
    declares one below its experiment's step -- libcosim, Ecos and FMPy read outputs right after each step and
    hold them, and need a smaller step than the harness's own master to meet the drive's accuracy --
    else the experiment's step.  The harness's own step goes in the ``pd:Experiment`` annotation."""
    step = float(system.experiment.step)
    accuracy = getattr(system, "accuracy", None)
    sampled = getattr(accuracy, "sampled_host_step", None)
    return min(step, float(sampled)) if sampled else step


# -- FMU resolution ---------------------------------------------------------------------------------------------


def fmu_dir() -> Path:
    """Where bare model names resolve: $PRESSDRIVE_FMU_DIR or <repo>/build/fmus."""
    env = os.environ.get(FMU_DIR_ENV)
    return Path(env) if env else ROOT / "build" / "fmus"


def component_module(model: str) -> Path | None:
    """The fmus/components/pd_*.py file that declares FMU class ``model`` (from :func:`fmus.build.catalog`)."""
    from fmus.build import catalog

    return catalog().get(model)


def model_name(fmu: str | Path) -> str:
    """The model name of an instance's ``fmu``: a bare name as it is, an ``.fmu`` file's modelName."""
    p = Path(str(fmu))
    if p.suffix.lower() != ".fmu":
        return str(fmu)
    return model_description(p).modelName


def _sources_newer_than(fmu: Path, script: Path) -> bool:
    """Whether a source the FMU packs changed after it was built: its declaration, every part of the fmus
    package an FMU carries (``fmus.build.RUNTIME``: the slaves of both FMI versions, units, physics), the
    host loader and the build, which writes the FMU's module and names its bundled code."""
    from fmus.build import runtime_files

    t = fmu.stat().st_mtime
    sources = [script, ROOT / "fmus" / "build.py", *(ROOT / "fmus" / "loader").glob("*.c"), *runtime_files()]
    return any(s.stat().st_mtime > t for s in sources if s.exists())


def resolve_fmu(fmu: str | Path) -> Path:
    """Path of the FMU file of an instance.

    A path ending in ``.fmu`` must exist.  A bare model name (``"FourBar"``) resolves to
    ``<fmu_dir()>/<name>.fmu``; if that is missing or older than its sources, it is built with
    ``fmus.build.main(["--out", dir, "--only", module])`` (module found by scanning fmus/components).
    """
    s = str(fmu)
    if s.lower().endswith(".fmu") or os.sep in s or "/" in s:
        p = Path(s)
        if not p.is_file():
            raise SystemDescriptionError(f"FMU file {p} does not exist")
        return p
    script = component_module(s)
    out = fmu_dir()
    path = out / f"{s}.fmu"
    if script is None:
        if path.is_file():
            return path
        raise SystemDescriptionError(f"unknown FMU model {s!r}: no {path} and no class {s} in fmus/components/pd_*.py")
    if not path.is_file() or _sources_newer_than(path, script):
        from fmus.build import main as build_main

        if build_main(["--out", str(out), "--only", script.stem]) != 0 or not path.is_file():
            raise SystemDescriptionError(f"building FMU {s} from {script.name} failed (see stderr)")
    return path


def _did_you_mean(name: str, candidates) -> str:
    """`` (did you mean 'x'?)`` for the closest of ``candidates`` (difflib), or nothing."""
    import difflib

    close = difflib.get_close_matches(name, list(candidates), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""
