"""The whole drive as one co-simulation FMU (``python -m harness export DRIVE X.fmu``, harness.export.drive_fmu).

* It validates with FMPy, offers the drive's parameters with its values as start values, units and descriptions,
  its free inputs and the signals of its engineering quantities, and says that no output depends on an input
  directly.
* FMPy's ``simulate_fmu`` at an importer step of 1 ms gives ``harness run`` of the drive (its own master and step
  inside) to 1e-9 of each column's range, and meets the drive's declared accuracy against the monolithic
  reference; OMSimulator (command line, a process without Python, and API), libcosim and Ecos run it at the same
  accuracy; beside another FMU in an SSP it runs in the harness and in OMSimulator.
* State get/set, load/free/load in one process, two instances side by side; bad input is one line naming the
  drive, the variable and the value; a member that cannot be packed is refused at export, naming it.

Host runs go in a subprocess each (benchmarks.host_accuracy.run_guarded); a host that is absent skips, saying why.
"""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from benchmarks import host_accuracy as ha
from harness import load
from harness.export.drive_fmu import export_fmu
from harness.errors import SystemError_
from harness.model import Connection, Experiment, Instance, System
from harness.run import simulate, system_names
from harness.ssp import export_ssp
from harness.studies.accuracy import accuracy_spec, check

ROOT = Path(__file__).resolve().parents[1]
TIMEOUT = 600.0
OMS_CLI = Path(sys.executable).parent / "OMSimulator"


@pytest.fixture(scope="module")
def bed_reference():
    """The bed drive's accuracy reference (computed once for every test that asks: tests/reference_cache.py)."""
    from reference_cache import shared

    system = load("bed_drive")
    spec = accuracy_spec(system)
    return shared("reference")(system, stop_time=spec.stop_time, step=spec.reference_step)


def _script(code: str, timeout: float = TIMEOUT) -> str:
    """Run ``code`` in a fresh Python (pythonfmu's wrapper keeps references into the interpreter that loaded it)."""
    code = textwrap.dedent(code) + "\nimport os as _os, sys as _sys\n_sys.stdout.flush(); _os._exit(0)\n"
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=timeout,
                       env={**os.environ, "PRESSDRIVE_NORMAL_EXIT": "1"})
    assert r.returncode == 0, f"exit {r.returncode}: {(r.stdout + r.stderr)[-1500:]}"
    return r.stdout


def _md(fmu: Path):
    from fmpy import read_model_description
    return read_model_description(str(fmu))


# ------------------------------------------------------------------------------------------ the FMU itself
def test_bed_drive_fmu_validates_and_declares_the_drive(drive_fmus):
    from fmpy.validation import validate_fmu

    fmu = drive_fmus("bed_drive")
    assert validate_fmu(str(fmu)) == []
    md = _md(fmu)
    system = load("bed_drive")
    v = {x.name: x for x in md.modelVariables}
    # every parameter value of the drive is a start value, with its unit and description
    for inst in system.instances:
        for p, value in inst.parameters.items():
            var = v[f"{inst.name}.{p}"]
            assert float(var.start) == pytest.approx(float(value), rel=1e-15), var.name
            if var.type == "Real":
                assert var.causality == "parameter" and var.variability == "fixed" and var.unit, var.name
            else:   # structural: read, never set
                assert var.causality == "calculatedParameter", var.name
            assert var.description.startswith(f"{inst.name}: ")
    assert v["bed.m_T"].unit == "kg" and v["cam.fidelity"].type == "Integer"
    # the outputs: every column the drive's accuracy reads, with units; no direct feed-through
    outputs = {x.name for x in md.modelVariables if x.causality == "output"}
    assert set(ha.columns_of(system)) <= outputs
    assert v["bed.bed.s"].unit == "m"
    assert all(u.dependencies == [] for u in md.outputs)
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canHandleVariableCommunicationStepSize
    assert md.defaultExperiment.stepSize == "0.0005" or float(md.defaultExperiment.stepSize) == 5e-4
    with zipfile.ZipFile(fmu) as z:
        names = set(z.namelist())
    assert {f"resources/members/{m}.fmu" for m in ("MotorBelt", "RackBed", "CamRocker")} <= names
    assert {"binaries/linux64/BedDrive.so", "binaries/linux64/BedDrive_pythonfmu.so",
            "resources/pressdrive_python.txt"} <= names


def test_fmpy_equals_harness_run_and_meets_the_declared_accuracy(drive_fmus, bed_reference):
    """The importer's step (1 ms) is two of the drive's (0.5 ms): at each communication point the FMU's outputs are
    the harness's own run's; against the monolithic reference they meet the drive's accuracy."""
    system = load("bed_drive")
    stop = accuracy_spec(system).stop_time
    columns = [x.name for x in _md(drive_fmus("bed_drive")).modelVariables if x.causality == "output"]
    run = ha.run_guarded("fmpy-fmu", drive_fmus("bed_drive"), stop, 1e-3, columns, "bed_drive", TIMEOUT)
    assert run.status == "complete", run.error
    fmu = run.result
    own = simulate(system, stop_time=stop, output=columns)
    assert np.allclose(fmu.index.to_numpy(), np.arange(len(fmu)) * 1e-3, rtol=0, atol=1e-12)
    own = own.loc[own.index.isin(np.round(fmu.index.to_numpy(), 12))]
    assert len(own) == len(fmu)
    for c in columns:
        scale = float(np.ptp(own[c].to_numpy())) or 1.0
        worst = float(np.max(np.abs(fmu[c].to_numpy() - own[c].to_numpy()))) / scale
        assert worst <= 1e-9, f"{c}: {worst:.3g} of its range off harness run"
    checks = check(system, fmu, bed_reference)
    assert checks and all(c.ok for c in checks), "; ".join(str(c) for c in checks)


def test_state_reload_and_two_instances_in_one_process(drive_fmus):
    fmu = drive_fmus("bed_drive")
    out = _script(f"""
        import shutil
        from fmpy import extract, read_model_description, simulate_fmu
        from fmpy.fmi2 import FMU2Slave
        path = {str(fmu)!r}
        md = read_model_description(path)
        vr = {{v.name: v.valueReference for v in md.modelVariables}}
        def make(name):
            d = extract(path)
            f = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,
                          instanceName=name)
            f.instantiate(); f.setupExperiment(startTime=0.0); f.enterInitializationMode(); f.exitInitializationMode()
            return f, d
        a, da = make("a"); b, db = make("b")
        s = [vr["bed.bed.s"], vr["flywheel.shaft_torque"]]
        t = 0.0
        for k in range(20):
            a.doStep(t, 1e-3); t += 1e-3
        state = a.getFMUstate()
        for k in range(20):
            a.doStep(t, 1e-3); t += 1e-3
        first = a.getReal(s)
        a.setFMUstate(state)
        t = 0.02
        for k in range(20):
            a.doStep(t, 1e-3); t += 1e-3
        again = a.getReal(s)
        t = 0.0
        for k in range(40):
            b.doStep(t, 1e-3); t += 1e-3
        other = b.getReal(s)
        a.freeFMUstate(state)
        for f, d in ((a, da), (b, db)):
            f.terminate(); f.freeInstance(); shutil.rmtree(d, ignore_errors=True)
        r1 = simulate_fmu(path, stop_time=0.04, step_size=1e-3)
        r2 = simulate_fmu(path, stop_time=0.04, step_size=1e-3)
        print(repr((first, again, other, float(r1["bed.bed.s"][-1]), float(r2["bed.bed.s"][-1]))))
    """)
    first, again, other, r1, r2 = eval(out.strip().splitlines()[-1])
    assert first == again == other          # restored state, and a second instance beside it: the same numbers
    assert r1 == r2 == first[0]             # loaded, freed (its folder deleted) and loaded again


def test_a_step_that_is_not_a_multiple_ends_with_a_shorter_sub_step(drive_fmus):
    """0.7 ms importer steps are sub-steps 0.5 + 0.2 ms: they still follow the drive to its accuracy's order."""
    out = _script(f"""
        from fmpy import simulate_fmu
        r = simulate_fmu({str(drive_fmus("bed_drive"))!r}, stop_time=0.07, step_size=7e-4)
        print(repr((float(r["time"][-1]), float(r["bed.bed.s"][-1]))))
    """)
    t, s = eval(out.strip().splitlines()[-1])
    own = simulate(load("bed_drive"), stop_time=0.07, output=["bed.bed.s"])
    assert t == pytest.approx(0.07)
    assert s == pytest.approx(float(own["bed.bed.s"].iloc[-1]), abs=1e-6)


def test_bad_input_is_one_line_naming_drive_variable_and_value(drive_fmus):
    """A non-finite input and a step below the master's time resolution (1 ns): the call fails with one line
    through the host's logger (pythonfmu forwards it with FMI logging on; the input's call returns fmi2Fatal, the
    status pythonfmu gives a Python exception, the refused step fmi2Discard: see the test below)."""
    fmu = drive_fmus("feeder_gto52")
    md = _md(fmu)
    inputs = [x.name for x in md.modelVariables if x.causality == "input"]
    # the drive's declared free inputs: the motor's supply and brake (a host drives its transients), the take-off
    assert inputs == ["motor.supply", "motor.brake", "flywheel.aux.tau"]
    out = _script(f"""
        from fmpy import simulate_fmu
        for kwargs in (dict(start_values={{"flywheel.aux.tau": float("nan")}}), dict(step_size=1e-10, stop_time=2e-10)):
            print("--")
            try:
                simulate_fmu({str(fmu)!r}, stop_time=kwargs.pop("stop_time", 0.01),
                             step_size=kwargs.pop("step_size", 1e-3), debug_logging=True, **kwargs)
                print("ran")
            except Exception as e:
                print("raised")
    """)
    parts = out.split("--\n")[1:]
    assert len(parts) == 2 and all(p.strip().endswith("raised") for p in parts), out[-2000:]
    errors = [[line for line in p.splitlines() if line.startswith("[ERROR] drive feeder_gto52")] for p in parts]
    assert len(errors[0]) == 1 and "input flywheel.aux.tau = nan N.m is outside its range" in errors[0][0], parts[0]
    assert len(errors[1]) == 1 and "communication step 2e-10 s is below the smallest" in errors[1][0], parts[1]


def test_a_member_without_binaries_is_refused_at_export_naming_it(fmu_dir, tmp_path):
    stripped = tmp_path / "RackBed.fmu"
    with zipfile.ZipFile(fmu_dir / "RackBed.fmu") as zin, zipfile.ZipFile(stripped, "w") as zout:
        for n in zin.namelist():
            if not n.startswith("binaries/"):
                zout.writestr(zin.getinfo(n), zin.read(n))
    system = load("bed_drive").on_fmus(fmu_dir)
    system.instances = [Instance(i.name, stripped if i.name == "bed" else i.fmu, i.parameters)
                        for i in system.instances]
    with pytest.raises(SystemError_, match=r"member bed \(RackBed.fmu\) cannot be packed .* no binary for linux64"):
        export_fmu(system, tmp_path / "x.fmu")
    assert not (tmp_path / "x.fmu").exists()


def test_cli_export_dispatches_on_the_suffix(fmu_dir, tmp_path):
    env = {**os.environ, "PRESSDRIVE_FMU_DIR": str(fmu_dir)}
    r = subprocess.run([sys.executable, "-m", "harness", "export", "two_inertia", str(tmp_path / "t.txt")],
                       cwd=ROOT, capture_output=True, text=True, env=env)
    assert r.returncode != 0 and ".ssp (SSP archive) or an .fmu" in r.stderr
    r = subprocess.run([sys.executable, "-m", "harness", "export", "two_inertia", str(tmp_path / "t.fmu"),
                        "--fmi-version", "3", "--output", "a.flange.w"], cwd=ROOT, capture_output=True, text=True,
                       env=env)
    assert r.returncode == 0, r.stderr
    md = _md(tmp_path / "t.fmu")
    assert md.coSimulation.modelIdentifier == "TwoInertia" and md.fmiVersion == "3.0"
    assert [v.name for v in md.modelVariables if v.causality == "output"] == ["a.flange.w"]


@pytest.mark.parametrize("fmi_version", [2, 3])
@pytest.mark.parametrize("name", system_names())
def test_every_drive_exports_validates_and_equals_harness_run(drive_fmus, name, fmi_version):
    """In both FMI versions (FMI 3.0: pythonfmu3, its members still the FMI 2.0 FMUs, run by the same master)."""
    from fmpy.validation import validate_fmu

    system = load(name)
    fmu = drive_fmus(name, fmi_version)
    assert validate_fmu(str(fmu)) == []
    assert _md(fmu).fmiVersion.startswith(str(fmi_version))
    step = system.experiment.step
    stop = 40 * step
    importer = 2 * step
    columns = [x.name for x in _md(fmu).modelVariables if x.causality == "output"]
    run = ha.run_guarded("fmpy-fmu", fmu, stop, importer, columns, name, TIMEOUT)
    assert run.status == "complete", run.error
    rises = [c for c in columns if c.endswith(".rise_time")]      # an event counter's instant on the drive's step
    own = simulate(system, stop_time=stop, output=[c for c in columns if c not in rises])
    for c in rises:     # the drive's own point of the counter's last rise, its start time before the first
        count = own[c.removesuffix(".rise_time")].to_numpy()
        t = own.index.to_numpy()
        rose = np.concatenate([[False], count[1:] > count[:-1]])
        own[c] = [t[:k + 1][rose[:k + 1]][-1] if rose[:k + 1].any() else 0.0 for k in range(len(t))]
    own = own.iloc[::2]
    assert len(own) == len(run.result)
    for c in columns:
        scale = float(np.ptp(own[c].to_numpy())) or 1.0
        worst = float(np.max(np.abs(run.result[c].to_numpy() - own[c].to_numpy()))) / scale
        assert worst <= 1e-9, f"{name}: {c} {worst:.3g} of its range off harness run"


# ------------------------------------------------------------------------------------------ other hosts
def _wrapped(fmu: Path, out: Path) -> Path:
    """The drive FMU as the one component ``drive`` of an SSP (how libcosim, Ecos and OMSimulator's API take it)."""
    system = System(f"{fmu.stem}_fmu", [Instance("drive", fmu)], experiment=Experiment(stop_time=1.0, step=1e-3))
    return export_ssp(system, out)


@pytest.mark.interop
@pytest.mark.parametrize("host", ["libcosim", "ecos", "omsimulator"])
def test_peer_hosts_run_the_drive_fmu_at_the_declared_accuracy(drive_fmus, bed_reference, tmp_path, host):
    reason = ha.unavailable(host)
    if reason:
        pytest.skip(reason)
    system = load("bed_drive")
    stop = accuracy_spec(system).stop_time
    fmu = drive_fmus("bed_drive")
    ssp = _wrapped(fmu, tmp_path / "bed_drive_fmu.ssp")
    columns = ha.columns_of(system)
    run = ha.run_guarded(host, ssp, stop, 1e-3, [f"drive.{c}" for c in columns], f"{fmu.stem}_fmu", TIMEOUT)
    assert run.status == "complete", run.error
    result = run.result.rename(columns=lambda c: c.removeprefix("drive."))
    checks = check(system, result, bed_reference)
    assert checks and all(c.ok for c in checks), "; ".join(str(c) for c in checks)


@pytest.mark.interop
@pytest.mark.parametrize("fmi_version", [2, 3])
def test_omsimulator_command_line_runs_the_drive_fmu_without_python(drive_fmus, bed_reference, tmp_path,
                                                                    fmi_version):
    if not OMS_CLI.is_file():
        pytest.skip("OMSimulator's command-line tool is not installed in this environment (install it with "
                    "../shared/tools/omsimulator/install where that folder exists)")
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("PYTHON", "PRESSDRIVE_", "VIRTUAL_ENV", "LD_PRELOAD"))}
    system = load("bed_drive")
    stop = accuracy_spec(system).stop_time
    fmu = drive_fmus("bed_drive", fmi_version)
    r = subprocess.run([str(OMS_CLI), str(fmu), f"--stopTime={stop}", "--stepSize=1e-3", "--resultFile=bd.csv"],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=TIMEOUT)
    text = r.stdout + r.stderr
    assert r.returncode == 0 and "error" not in text.lower(), text[-800:]
    raw = pd.read_csv(tmp_path / "bd.csv", skipinitialspace=True)
    raw.columns = [c.strip().strip('"') for c in raw.columns]
    result = raw.groupby("time").last()
    assert len(result) == round(stop / 1e-3) + 1
    checks = check(system, result, bed_reference)
    assert checks and all(c.ok for c in checks), "; ".join(str(c) for c in checks)


@pytest.mark.interop
def test_the_drive_fmu_beside_another_fmu_in_an_ssp(drive_fmus, fmu_dir, tmp_path):
    """A torque load (TorqueLoad) follows the drive's crank (its angle and speed into the load's flange): the
    harness and OMSimulator run the SSP alike."""
    fmu = drive_fmus("bed_drive")
    system = System("press_and_load", [Instance("drive", fmu), Instance("load", fmu_dir / "TorqueLoad.fmu", {"d": 2.0})],
                    connections=[Connection("drive.flywheel.crank.phi", "load.flange.phi"),
                                 Connection("drive.flywheel.crank.w", "load.flange.w")],
                    experiment=Experiment(stop_time=0.1, step=1e-3))
    ssp = export_ssp(system, tmp_path / "press_and_load.ssp")
    columns = ["drive.flywheel.crank.w", "drive.bed.bed.s", "load.flange.tau"]
    own = ha.run_guarded("harness:jacobi", ssp, 0.1, 1e-3, columns, "press_and_load", TIMEOUT)
    assert own.status == "complete", own.error
    alone = simulate(load("bed_drive"), stop_time=0.1, output=["bed.bed.s"])
    assert own.result["drive.bed.bed.s"].iloc[-1] == pytest.approx(alone["bed.bed.s"].iloc[-1], abs=1e-12)
    assert np.ptp(own.result["load.flange.tau"].to_numpy()) > 0      # the load sees the crank move
    reason = ha.unavailable("omsimulator")
    if reason:
        pytest.skip(reason)
    oms = ha.run_guarded("omsimulator", ssp, 0.1, 1e-3, columns, "press_and_load", TIMEOUT)
    assert oms.status == "complete", oms.error
    for c in columns:
        scale = float(np.ptp(own.result[c].to_numpy())) or 1.0
        worst = float(np.max(np.abs(oms.result[c].to_numpy() - own.result[c].to_numpy()))) / scale
        assert worst <= 1e-9, f"{c}: OMSimulator {worst:.3g} of its range off the harness"


# ------------------------------------------------------------------ FMPy's simulate_ssp without a parameter set
def test_exported_ssp_carries_each_instances_values_in_its_fmu(fmu_dir, tmp_path):
    """Each instance's FMU in the exported SSP is a copy that starts from the instance's values by itself
    (harness.ssp.start_values): FMPy's simulate_ssp, given no parameter set, no longer runs the FMUs' defaults
    (before: the crank at -1.75e4 rad/s by 1 ms).  What is left is its first step, which hands every input 0.0."""
    from fmpy.validation import validate_fmu

    system = load("bed_drive").on_fmus(fmu_dir)
    ssp = export_ssp(system, tmp_path / "bed_drive.ssp")
    with zipfile.ZipFile(ssp) as z:
        names = [n for n in z.namelist() if n.endswith(".fmu")]
        assert sorted(names) == sorted(f"resources/{Path(i.fmu).stem}_{i.name}.fmu" for i in system.instances)
        z.extract("resources/MotorBelt_motor.fmu", tmp_path)
    copy = tmp_path / "resources" / "MotorBelt_motor.fmu"
    assert validate_fmu(str(copy)) == []
    starts = {v.name: v.start for v in _md(copy).modelVariables}
    for p, value in system.instance("motor").parameters.items():
        assert float(starts[p]) == pytest.approx(float(value), rel=1e-15), p
    # the harness reads the same system back and runs it as before
    back = simulate(ssp, stop_time=0.01)
    own = simulate(system, stop_time=0.01)
    assert np.allclose(back["bed.bed.s"].to_numpy(), own["bed.bed.s"].to_numpy(), rtol=0, atol=1e-15)
    out = _script(f"""
        from fmpy.ssp.simulation import simulate_ssp
        r = simulate_ssp({str(ssp)!r}, stop_time=1e-3, step_size=1e-4)
        print(repr((float(r["flywheel.crank.w"][0]), float(r["flywheel.crank.w"][-1]), float(r["bed.bed.s"][-1]))))
    """)
    w0, w_end, s_end = eval(out.strip().splitlines()[-1])
    assert w0 == pytest.approx(2 * np.pi)           # the drive's 60 rpm, not the FMU's default
    assert abs(w_end) < 100.0                        # before: -1.75e4 rad/s by 1 ms


def test_a_drive_fmu_run_in_this_process_leaves_the_fmi_log_routing_working(drive_fmus, fmu_dir):
    """A drive FMU brings its own copy of the FMI layer, whose logger fmpy's one-per-process log proxy then held:
    a parameter the FMU refused afterwards lost its line ('fmi2EnterInitializationMode failed ... status fatal')."""
    import warnings

    from fmpy import simulate_fmu

    from harness import RunOptions, simulate

    simulate_fmu(str(drive_fmus("bed_drive")), stop_time=0.002, step_size=1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = simulate(load("bed_drive").on_fmus(fmu_dir), stop_time=0.01, start_values={"fourbar.crank_length": -0.1},
                      options=RunOptions(in_process=False, progress=None))
    assert "parameter crank_length = -0.1 m is not admissible" in df.attrs["error"], df.attrs["error"]


@pytest.mark.parametrize("fmi_version", [2, 3])
def test_a_refused_step_is_one_line_and_in_fmi3_not_fatal(drive_fmus, fmi_version):
    """An importer step below the master's 1 ns and a step from another time than the drive's: one line through
    the host's logger each.  FMI 3.0: fmi3Error, and the same instance then steps on from where it was to the
    result of a run that never saw the refused calls.  FMI 2.0: fmi2Fatal (pythonfmu's wrapper gives a Python
    exception fmi2Fatal and a False from do_step fmi2Discard, which FMPy's simulate_fmu ignores; fmi2Error is
    out of its reach), so only the first call is made."""
    fmu = drive_fmus("two_inertia", fmi_version)
    out = _script(f"""
        from fmpy import extract, read_model_description
        from fmpy.fmi1 import FMICallException
        from fmpy.fmi{fmi_version} import FMU{fmi_version}Slave
        path = {str(fmu)!r}
        md = read_model_description(path)
        slave = FMU{fmi_version}Slave(guid=md.guid if {fmi_version} == 2 else md.instantiationToken,
                                      unzipDirectory=extract(path),
                                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="d")
        slave.instantiate(loggingOn=True)       # FMPy's own logger prints the FMU's lines: [STATUS] message
        if {fmi_version} == 2:
            slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode(); slave.exitInitializationMode()
        statuses = []
        for t, h in ((0.0, 1e-10), (0.5, 1e-3))[:{fmi_version} - 1]:
            try:
                slave.doStep(t, h)
                statuses.append(0)
            except FMICallException as e:
                statuses.append(e.status)
        t, value = 0.0, None
        name = [v.name for v in md.modelVariables if v.causality == "output"][0]
        if {fmi_version} == 3:
            for _ in range(20):
                slave.doStep(t, 1e-3); t += 1e-3
            vr = {{v.name: v.valueReference for v in md.modelVariables}}
            value = float(slave.getFloat64([vr[name]])[0])
        print(repr((statuses, name, value)))
    """)
    statuses, name, value = eval(out.strip().splitlines()[-1])
    lines = [line for line in out.splitlines() if line.startswith("[ERROR] drive two_inertia")]
    if fmi_version == 2:
        assert statuses == [4] and len(lines) == 1, out              # fmi2Fatal
        assert "communication step 1e-10 s is below the smallest" in lines[0], lines
        return
    assert statuses == [3, 3], (statuses, lines)                      # fmi3Error (fmi3Fatal is 4)
    assert len(lines) == 2, out
    assert "communication step 1e-10 s is below the smallest" in lines[0], lines
    assert "doStep at t = 0.5 s, but the drive is at t = 0.0 s" in lines[1], lines
    own = simulate(load("two_inertia"), stop_time=0.02, step=None, output=[name])
    assert value == pytest.approx(float(own[name].iloc[-1]), rel=1e-9, abs=1e-12)


def test_a_hosts_coarse_step_reads_the_feeders_take_up_instants_on_the_drives_own_step(drive_fmus):
    """The feeder's FMU offers feeder.impact_count.rise_time beside the counter: FMPy at a 1 ms importer step
    reads every take-up instant in 0.2-0.6 s equal to harness run's at the drive's own 0.2 ms step (from its
    1 ms samples alone they are up to 1 ms late: the feeder missed its accuracy so)."""
    from harness.reporting import qoi

    fmu = drive_fmus("feeder_gto52")
    names = [v.name for v in _md(fmu).modelVariables]
    assert "feeder.impact_count.rise_time" in names
    out = _script(f"""
        import numpy as np
        from fmpy import simulate_fmu
        r = simulate_fmu({str(fmu)!r}, stop_time=0.6, step_size=1e-3,
                         output=["feeder.impact_count", "feeder.impact_count.rise_time"])
        print(repr([list(map(float, r[c])) for c in ("time", "feeder.impact_count", "feeder.impact_count.rise_time")]))
    """)
    t, count, rise = eval(out.strip().splitlines()[-1])
    host = pd.DataFrame({"feeder.impact_count": count, "feeder.impact_count.rise_time": rise},
                        index=pd.Index(t, name="time"))
    own = simulate(load("feeder_gto52"), stop_time=0.6, output=["feeder.impact_count"])
    expr = 'rise_times("feeder.impact_count", 0.2, 0.6)'
    expected = qoi.value(expr, own)
    assert len(expected) >= 4
    np.testing.assert_allclose(qoi.value(expr, host), expected, rtol=0, atol=1e-12)
    # read from the 1 ms samples alone, the instants are off by more than the drive's step
    sampled = qoi.value(expr, host.drop(columns="feeder.impact_count.rise_time"))
    assert np.max(np.abs(sampled - expected)) > 2e-4


@pytest.mark.parametrize("version", [2, 3])
def test_a_drive_fmu_exports_after_an_fmu_ran_in_the_same_process(fmu_dir, fmu3_dir, version, tmp_path):
    """An FMU of the toolkit run in this process through FMPy imports the copy of its exporter's package that it
    carries (Python only: no binaries, no headers); exporting a drive FMU afterwards in the same process builds with
    the installed exporter (fmus.build.installed_exporter) and leaves the running copy in place.  Before that, the
    export found the copy and wrote an FMU without binaries."""
    from test_hosts import _run_script

    component = (fmu_dir if version == 2 else fmu3_dir) / "Inertia.fmu"
    name = "pythonfmu3" if version == 3 else "pythonfmu"
    out = _run_script(f"""
        import sys, zipfile
        from fmpy import simulate_fmu
        simulate_fmu({str(component)!r}, stop_time=0.01, step_size=1e-3)
        print("carried", "/resources/" in sys.modules[{name!r}].__file__)
        from harness import export_fmu
        fmu = export_fmu("two_inertia", {str(tmp_path / "drive.fmu")!r}, fmi_version={version})
        print("binaries", sorted(n for n in zipfile.ZipFile(fmu).namelist() if n.startswith("binaries/")))
        print("still carried", "/resources/" in sys.modules[{name!r}].__file__)
    """)
    lines = dict(line.split(" ", 1) if not line.startswith("still") else ("still", line[14:])
                 for line in out.splitlines())
    assert lines["carried"] == "True", out               # the premise: the running FMU's copy is the one imported
    assert ".so" in lines["binaries"], out
    assert lines["still"] == "True", out
