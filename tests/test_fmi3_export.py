"""Issue 34: every component as an FMI 3.0 co-simulation FMU, built from the same declarations as FMI 2.0.

Checked against hosts nobody here wrote: fmpy's validation, and ``fmpy.simulate_fmu`` driving each FMI 3.0
FMU through the component's standard run (``fmus/docs/<name>/make_reference.py``, recorded as its
``reference.csv`` by ``fmus.reference.standard_run``), to 1e-9 of each output's range.

How the standard run is replayed: its script is run with ``standard_run`` and ``write_reference`` replaced by
a recorder, so the test gets the script's own model (its parameters become the FMU's start values), step,
number of steps and the input of every step ``u_k`` (asked in order, as ``standard_run`` does).  fmpy holds
``u_k`` over the step from ``t_k`` (its input table is sampled exactly at the grid points).  The reference row
``k`` is the output *after* the inputs of step ``k`` are set; fmpy samples after ``fmi3DoStep`` with the
previous inputs still set, so its ``step_finished`` callback sets ``u_{k+1}`` and takes that sample again
(outputs that depend on no input are unchanged by that, the others then follow ``u_{k+1}`` as in the row).
"""
from __future__ import annotations

import functools
import importlib
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

from fmus import build as build_fmus
from fmus import reference
from fmus.reference import standard_run

CATALOG = build_fmus.catalog()                       # model name -> declaration pd_<name>.py
TOLERANCE = 1e-9                                     # of the output's range over the standard run


def declaration_class(name: str) -> type:
    module = importlib.import_module(f"fmus.components.{CATALOG[name].stem}")
    return getattr(module, name)


def _md_root(fmu: Path) -> ET.Element:
    with zipfile.ZipFile(fmu) as z:
        return ET.fromstring(z.read("modelDescription.xml"))


# -- the build -------------------------------------------------------------------------------------------------
def test_every_component_is_built_as_fmi3_and_fmpy_validates_it(fmu3_dir):
    built = sorted(p.stem for p in fmu3_dir.glob("*.fmu"))
    assert built == sorted(CATALOG)
    for name in built:
        fmu = fmu3_dir / f"{name}.fmu"
        assert validate_fmu(str(fmu)) == [], name
        md = read_model_description(str(fmu))
        assert md.fmiVersion == "3.0" and md.coSimulation is not None and md.modelExchange is None
        cs = _md_root(fmu).find("CoSimulation").attrib
        assert (cs["canGetAndSetFMUState"], cs["canHandleVariableCommunicationStepSize"],
                cs["needsExecutionTool"]) == ("true", "true", "true"), name   # a Python (tests/test_handoff.py)
        with zipfile.ZipFile(fmu) as z:
            names = set(z.namelist())
            doc = build_fmus.DOCS / CATALOG[name].stem.removeprefix("pd_")
            # the per-FMU docs and the reference run, byte for byte
            for f in ("index.md", "reference.csv"):
                assert z.read(f"documentation/{f}") == (doc / f).read_bytes(), (name, f)
            assert f"binaries/x86_64-linux/{name}.so" in names
            # the bundled package is the FMI 3.0 one: its slave module, not FMI 2.0's (which imports pythonfmu)
            slaves = {n.rsplit("/", 1)[-1] for n in names if n.startswith("resources/fmus_") and "/slave" in n}
            assert slaves == {"slave_core.py", "slave3.py"}, (name, slaves)


@pytest.mark.parametrize("name", sorted(CATALOG))
def test_fmi3_variables_units_and_structure_are_the_fmi2_ones(name, fmu3_dir, fmu_dir):
    """The same declaration gives the same variables (name, value reference, causality, variability, unit,
    start), Float64 where FMI 2.0 has Real and Int32 where it has Integer, every unit defined, and the same
    output dependencies and initial unknowns (FMI 3.0 writes them by value reference), plus FMI 3.0's
    independent variable ``time``."""
    md3 = read_model_description(str(fmu3_dir / f"{name}.fmu"))
    md2 = read_model_description(str(fmu_dir / f"{name}.fmu"))
    types = {"Real": "Float64", "Integer": "Int32"}

    def rows(md, kind):
        return [(v.name, v.valueReference, v.causality, v.variability, v.unit, v.start,
                 kind(v.type)) for v in md.modelVariables if v.causality != "independent"]

    assert rows(md3, str) == rows(md2, lambda t: types[t])
    time = [v for v in md3.modelVariables if v.causality == "independent"]
    assert [(v.name, v.type, v.unit) for v in time] == [("time", "Float64", "s")]
    units = {u.name for u in md3.unitDefinitions}
    for v in md3.modelVariables:
        if v.type == "Float64":
            assert v.unit in units, (name, v.name)

    def deps(unknowns):
        return {u.variable.name: sorted(d.name for d in u.dependencies) for u in unknowns}

    assert deps(md3.outputs) == deps(md2.outputs)
    assert deps(md3.initialUnknowns) == deps(md2.initialUnknowns)
    cls = declaration_class(name)
    for output, inputs in deps(md3.outputs).items():
        assert set(inputs) == set(cls.feedthrough.get(output, ())), output
    # the toolkit's annotation in FMI 3.0's place for annotations
    root = _md_root(fmu3_dir / f"{name}.fmu")
    slave = root.find("Annotations/Annotation[@type='org.pressdrive']/Slave")
    assert slave is not None and slave.get("class") == name
    advanced = [f"{p.name}.{'s' if p.translational else 'phi'}" for p in cls.ports
                if p.motion == "in" and cls.advances_position]
    assert slave.get("advancedPositions") == " ".join(advanced)


# -- the standard run through fmpy ----------------------------------------------------------------------------
class _Recorded(Exception):
    pass


def standard_run_setup(name: str):
    """(model, h, n, inputs u_0..u_n) of the component's standard run, taken from its own script."""
    script = importlib.import_module(f"fmus.docs.{CATALOG[name].stem.removeprefix('pd_')}.make_reference")
    seen = {}

    def record(model, inputs, h, n, x0=None):
        u = [tuple(float(v) for v in inputs(k, k * h)) for k in range(n + 1)]
        if x0 is not None and not np.array_equal(np.asarray(x0, dtype=float),
                                                 np.asarray(model.initial_state(u[0]), dtype=float)):
            pytest.fail(f"{name}: the standard run starts from a state an FMU cannot be given (not the "
                        f"initial state of its first inputs)")
        seen.update(model=model, h=h, n=n, u=u)
        raise _Recorded

    mp = pytest.MonkeyPatch()
    try:
        mp.setattr(script, "standard_run", record)
        mp.setattr(script, "write_reference", lambda *a, **k: None)
        with pytest.raises(_Recorded):
            script.main()
    finally:
        mp.undo()
    return seen["model"], seen["h"], seen["n"], seen["u"]


@functools.lru_cache(maxsize=None)
def simulate_standard_run(fmu: Path, name: str) -> np.ndarray:
    """fmpy.simulate_fmu of the FMU through the standard run (module docstring); rows (t, outputs...).  Run once
    per FMU and shared by the tests of this file (read only): three tests compare it with three references."""
    model, h, n, u = standard_run_setup(name)
    inputs = list(model.inputs)
    outputs = list(model.outputs)
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    start = {s.name: getattr(model.p, s.name) for s in type(model.p).specs()}
    signals = None
    if inputs:
        signals = np.array([(k * h, *u[k]) for k in range(n + 1)],
                           dtype=[("time", np.float64)] + [(i, np.float64) for i in inputs])
    step = {"k": 0}

    def resample_after_setting_the_next_inputs(time, recorder):
        step["k"] += 1
        k = step["k"]
        if inputs and k <= n:
            setter = recorder.fmu.setFloat64 if md.fmiVersion == "3.0" else recorder.fmu.setReal
            setter([vr[i] for i in inputs], list(u[k]))
            recorder.rows.pop()
            recorder.sample(time)
        return True

    res = simulate_fmu(str(fmu), start_time=0.0, stop_time=n * h, step_size=h, output_interval=h,
                       start_values=start, input=signals, output=outputs,
                       step_finished=resample_after_setting_the_next_inputs)
    rows = np.column_stack([res["time"]] + [res[o] for o in outputs])
    rows.flags.writeable = False
    return rows


@functools.lru_cache(maxsize=None)
def csv_digits(name: str) -> int:
    """The significant digits the component's reference.csv is written with (its script's format)."""
    return reference.digits(reference.fresh(CATALOG[name].stem.removeprefix("pd_"))[2])


def reference_rows(name: str) -> tuple[list[str], np.ndarray]:
    path = build_fmus.DOCS / CATALOG[name].stem.removeprefix("pd_") / "reference.csv"
    header = path.read_text(encoding="utf-8").splitlines()[0].split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def deviation(run: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Largest deviation of each column from the reference, as a share of the reference column's range
    (its largest magnitude where it is constant)."""
    span = np.ptp(ref, axis=0)
    scale = np.where(span > 0, span, np.maximum(np.max(np.abs(ref), axis=0), 1e-300))
    return np.max(np.abs(run - ref), axis=0) / scale


@functools.lru_cache(maxsize=None)
def fresh_standard_run(name: str) -> np.ndarray:
    """The standard run of the pure model (fmus.reference.standard_run, no FMU): what reference.csv holds, at
    full precision, for the model as it is now (computed once per component, read only)."""
    model, h, n, u = standard_run_setup(name)
    rows = np.array(standard_run(model, lambda k, t: u[k], h, n), dtype=float)
    rows.flags.writeable = False
    return rows


@pytest.mark.parametrize("name", sorted(CATALOG))
def test_fmpy_simulates_the_fmi3_fmu_through_its_standard_run(name, fmu3_dir):
    """Every output against the standard run of the pure model (the reference.csv's run, unrounded)."""
    run = simulate_standard_run(fmu3_dir / f"{name}.fmu", name)
    ref = fresh_standard_run(name)
    assert run.shape == ref.shape and np.all(np.isfinite(run))
    dev = deviation(run, ref)
    worst = int(np.argmax(dev))
    columns = ["time", *standard_run_setup(name)[0].outputs]
    assert dev[worst] <= TOLERANCE, f"{name}: {columns[worst]} off by {dev[worst]:.3g} of its range"


@pytest.mark.parametrize("name", sorted(CATALOG))
def test_fmpy_simulates_the_fmi3_fmu_through_the_standard_run_of_its_reference_csv(name, fmu3_dir):
    """Every column of the packed reference.csv, to 1e-9 of its range plus one unit in the last digit the file
    writes (its rounding).  A reference the model no longer reproduces fails here and in
    tests/test_reference_csv.py: a physics change is committed with references rewritten by
    ``python -m fmus.reference --write``, deliberately."""
    header, ref = reference_rows(name)
    model, *_ = standard_run_setup(name)
    assert header == ["time", *model.outputs], "reference.csv lacks outputs: python -m fmus.reference --write"
    run = simulate_standard_run(fmu3_dir / f"{name}.fmu", name)
    assert run.shape == ref.shape, (run.shape, ref.shape)
    assert np.all(np.isfinite(run))
    span = np.ptp(ref, axis=0)
    scale = np.where(span > 0, span, np.maximum(np.max(np.abs(ref), axis=0), 1e-300))
    rounding = 10.0 ** (1 - csv_digits(name))
    excess = (np.abs(run - ref) - rounding * np.abs(ref)) / scale
    worst = np.unravel_index(int(np.argmax(excess)), excess.shape)
    assert excess[worst] <= TOLERANCE, (f"{name}: {header[worst[1]]} at t = {ref[worst[0], 0]:g} off by "
                                        f"{excess[worst]:.3g} of its range beyond the file's rounding")


@pytest.mark.parametrize("name", sorted(CATALOG))
def test_the_fmi3_run_is_the_fmi2_run_bit_for_bit(name, fmu3_dir, fmu_dir):
    """Same code, same floats: the FMI 3.0 FMU under fmpy gives exactly the FMI 2.0 FMU's numbers (the 1e-9 of
    the reference check is the CSV's rounding, not a difference between the versions)."""
    assert np.array_equal(simulate_standard_run(fmu3_dir / f"{name}.fmu", name),
                          simulate_standard_run(fmu_dir / f"{name}.fmu", name))


def test_a_run_that_starts_later_is_the_fmi2_run(fmu3_dir, fmu_dir):
    """pythonfmu3 0.3.4 does not pass fmi3EnterInitializationMode's startTime to the slave (fmus/slave3.py): a run
    from t = 0.5 s under fmpy still equals the FMI 2.0 FMU's, every output of all 14 (the outputs at the first
    point do not depend on the time itself; each step gets its time from fmi3DoStep)."""
    for name in sorted(CATALOG):
        kw = dict(start_time=0.5, stop_time=0.52, step_size=1e-3, output_interval=1e-3)
        a = simulate_fmu(str(fmu_dir / f"{name}.fmu"), **kw)
        b = simulate_fmu(str(fmu3_dir / f"{name}.fmu"), **kw)
        assert a.dtype.names == b.dtype.names and len(a) == len(b) == 21, name
        for column in a.dtype.names:
            assert np.array_equal(a[column], b[column]), (name, column)


# -- terminals ------------------------------------------------------------------------------------------------
def test_terminals_are_schema_valid_and_are_the_power_bonds(fmu3_dir):
    """terminalsAndIcons.xml against FMI 3.0's schema (fmpy ships it; its validate_fmu does not read terminals):
    one terminal per declared port, members phi/w/tau (s/v/f) naming the FMU's variables, motion members of one
    causality and the effort of the other, so a motion-out terminal plugs into a motion-in one member by member."""
    from lxml import etree

    schema = etree.XMLSchema(file=str(Path(validate_fmu.__code__.co_filename).parent / "schema" / "fmi3"
                                      / "fmi3TerminalsAndIcons.xsd"))
    for name in sorted(CATALOG):
        fmu = fmu3_dir / f"{name}.fmu"
        ports = declaration_class(name).ports
        with zipfile.ZipFile(fmu) as z:
            if not ports:
                assert "terminalsAndIcons/terminalsAndIcons.xml" not in z.namelist(), name
                continue
            doc = etree.fromstring(z.read("terminalsAndIcons/terminalsAndIcons.xml"))
        assert schema.validate(doc), (name, str(schema.error_log))
        variables = {v.name: v for v in read_model_description(str(fmu)).modelVariables}
        terminals = doc.findall("Terminals/Terminal")
        assert [t.get("name") for t in terminals] == [p.name for p in ports], name
        for port, terminal in zip(ports, terminals):
            members = [(m.get("memberName"), m.get("variableName"), m.get("variableKind"))
                       for m in terminal.findall("TerminalMemberVariable")]
            x, v, e = ("s", "v", "f") if port.translational else ("phi", "w", "tau")
            flow = "outflow" if port.motion == "in" else "inflow"
            assert members == [(x, f"{port.name}.{x}", "signal"), (v, f"{port.name}.{v}", "signal"),
                               (e, f"{port.name}.{e}", flow)], (name, members)
            causality = [variables[m[1]].causality for m in members]
            motion = "input" if port.motion == "in" else "output"
            assert causality == [motion, motion, "output" if motion == "input" else "input"], (name, causality)
            assert terminal.get("matchingRule") == "plug"
            assert terminal.get("terminalKind").endswith("TranslationalFlange" if port.translational
                                                         else "RotationalFlange")


# -- the drives from FMI 3.0 FMUs, under the toolkit's master ----------------------------------------------------
SYSTEMS = ("two_inertia", "feeder_gto52", "bed_drive", "spine_knife", "proof_press")



MASTERS = ("jacobi", "jacobi-sampled", "gauss-seidel", "iterative", "jacobian")


@pytest.mark.parametrize("master", MASTERS)
@pytest.mark.parametrize("name", SYSTEMS)
def test_every_drive_from_its_fmi3_fmus_runs_as_from_its_fmi2_fmus(name, master, fmu3_dir, fmu_dir):
    """Each shipped drive over 50 steps of its own experiment under every master of the toolkit (the iterative
    and jacobian masters save and restore FMU states): the FMI 3.0 FMUs give the FMI 2.0 FMUs' results bit for
    bit (the master reads the toolkit's annotation in FMI 3.0's place too: without it, it extrapolated the
    positions those FMUs advance themselves, and the feeder differed by 1.1e11 and the bed drive by 3.7 of a
    column's range, measured)."""
    import warnings

    from harness import load, simulate

    stop = 50 * load(name).experiment.step
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = simulate(load(name).on_fmus(fmu_dir), stop_time=stop, master=master)
        b = simulate(load(name).on_fmus(fmu3_dir), stop_time=stop, master=master)
    # the same run, to the same end: bed_drive under jacobi-sampled stops incomplete at 16 ms with either version
    assert a.attrs.get("complete", True) == b.attrs.get("complete", True) and len(a) == len(b)
    assert list(a.columns) == list(b.columns)
    assert np.array_equal(a.to_numpy(), b.to_numpy(), equal_nan=True)


def test_the_master_knows_which_positions_an_fmi3_fmu_advances(fmu3_dir):
    from harness.fmi.fmu import advanced_positions

    assert advanced_positions(Path(extract(str(fmu3_dir / "FourBar.fmu")))) == {"crank.phi"}


# -- behaviour over FMI 3.0 calls -------------------------------------------------------------------------------
def _open3(fmu: Path, instance: str = "inst"):
    md = read_model_description(str(fmu))
    slave = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(fmu)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=instance)
    slave.instantiate(loggingOn=True)
    return md, slave


def test_rollback_with_fmu_state_is_bit_exact_in_fmi3(fmu3_dir):
    md, s = _open3(fmu3_dir / "FourBar.fmu")
    vr = {v.name: v.valueReference for v in md.modelVariables}
    observed = [v.valueReference for v in md.modelVariables
                if v.type == "Float64" and v.causality in ("output", "local")]
    s.setInt32([vr["fidelity"]], [2])
    s.enterInitializationMode()
    s.exitInitializationMode()
    h = 1e-3

    def step(k):
        s.setFloat64([vr["crank.phi"], vr["crank.w"], vr["rocker.tau"]], [0.3 + 15.0 * k * h, 15.0, -0.5])
        s.doStep(k * h, h)

    for k in range(10):
        step(k)
    state = s.getFMUState()

    def run_on():
        trace = []
        for k in range(10, 20):
            step(k)
            trace.append(s.getFloat64(observed))
        return np.array(trace)

    first = run_on()
    s.setFMUState(state)
    second = run_on()
    s.freeFMUState(state)
    s.terminate()
    s.freeInstance()
    assert np.array_equal(first, second) and np.all(np.isfinite(first))


def test_a_non_physical_parameter_is_refused_with_the_fmi2_line(fmu3_dir, capsys):
    md, s = _open3(fmu3_dir / "Inertia.fmu", instance="badInstance")
    vr = next(v.valueReference for v in md.modelVariables if v.name == "J")
    s.setFloat64([vr], [-1.0])
    with pytest.raises(Exception, match="fmi3(Enter|Exit)InitializationMode failed"):
        s.enterInitializationMode()
        s.exitInitializationMode()
    assert "badInstance (Inertia): parameter J = -1.0" in capsys.readouterr().out


def test_many_fmi3_instances_in_one_process(fmu3_dir):
    """Three instances of every FMI 3.0 FMU alive together, stepped, freed, and created again."""
    for _round in range(2):
        alive = []
        for name in sorted(CATALOG):
            for k in range(3):
                md, s = _open3(fmu3_dir / f"{name}.fmu", instance=f"{name}{k}")
                s.enterInitializationMode()
                s.exitInitializationMode()
                s.doStep(0.0, 1e-3)
                outputs = [v.valueReference for v in md.modelVariables if v.causality == "output"]
                assert np.all(np.isfinite(s.getFloat64(outputs))), name
                alive.append(s)
        for s in alive:
            s.terminate()
            s.freeInstance()


def test_a_missing_exporter_is_one_line_and_builds_nothing(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "pythonfmu3", None)     # import pythonfmu3 now raises ImportError
    assert build_fmus.main(["--fmi-version", "3", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "built with pythonfmu3, which does not import here" in err[0]
    assert "pip install pythonfmu3" in err[0] and not list(tmp_path.iterdir())


def test_an_unknown_fmi_version_is_refused_in_one_line():
    with pytest.raises(ValueError, match=r"FMI version 4 is not built here \(allowed: 2, 3\)"):
        build_fmus.runtime(4)
    with pytest.raises(SystemExit):
        build_fmus.main(["--fmi-version", "4"])
