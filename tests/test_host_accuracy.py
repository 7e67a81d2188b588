"""Every shipped drive with a declared accuracy, exported as SSP, run in each FMI host with the host's own
algorithm at the step the SSP declares, judged against the monolithic reference by the drive's own accuracy
(``harness.studies.accuracy.check``; issue 35).  The runner is ``benchmarks/host_accuracy.py``; the measured
table is in docs/howto/export.md ("Accuracy in other hosts").

* The step the SSP declares to other hosts (its OSP annotation, :func:`harness.ssp.host_step`) is the drive's
  ``AccuracySpec.sampled_host_step`` (or its experiment's step, where that is smaller): checked here to be the
  largest step of the ladder at which the sampled Jacobi of libcosim, Ecos and FMPy (the harness's
  ``jacobi-sampled`` with hold) meets the accuracy.
* The SSP binds each connected input to its source's value at the start, for hosts that set no input before
  initialization (FMPy's simulate_ssp: the bed 0.205 m off without them).
* Each host at that step must meet the accuracy; a host that misses is a finding, an ``xfail`` (strict: it
  fails the day the host meets it) whose reason is what was measured.  Before the base slave's
  outputs-after-a-step fix, libcosim and Ecos had the bed 14.5 mm off at 0.1 ms.
* The base slave's part of that fix, FMU by FMU: an output read right after ``fmi2DoStep`` is the one the
  model gives at the positions it advanced its motion inputs to.

A host that is not installed skips, saying why.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks import host_accuracy as ha
from harness import load
from harness.ssp import export_ssp, host_step, load_ssp
from harness.studies.accuracy import accuracy_spec, check
from harness.studies.reference import reference
from harness.studies.trial import trial

pytestmark = pytest.mark.interop

PEER_HOSTS = ("libcosim", "ecos", "fmpy-ssp", "omsimulator")
LADDER = (5e-4, 2e-4, 1e-4, 5e-5)   # s: the steps searched (AccuracySpec.sampled_host_step)
# A complete run of either drive over its accuracy span takes at most ~65 s in any host here (OMSimulator,
# bed_drive, 1 s at 0.05 ms); a run still going after this is hung.
TIMEOUT = 150.0

DRIVES = ha.drives()   # every shipped drive that declares its accuracy

# Measured at the declared step (python -m benchmarks.host_accuracy), where a host misses
MISSES = {
    ("bed_drive", "fmpy-ssp"): "bed 3.0 mm off at 0.1 ms (peak shaft torque 31 times the reference's) where "
                               "libcosim and Ecos meet with the same algorithm: FMPy's simulate_ssp hands every "
                               "input 0.0 in its first step (it starts each connector at 0.0 and reads no output "
                               "before stepping), so the motor sees its pulley at angle 0 for 0.1 ms: an impulse "
                               "no SSP or FMU content can prevent.  FMPy's own loop with the outputs after "
                               "initialisation passed to the first step equals libcosim (2.7 um at 0.3 s).  Its "
                               "other cause, no input set before initialisation (0.205 m), the export's bound "
                               "start values remove",
    ("trimmer_conveyor", "fmpy-ssp"): "peak drive-shaft torque 1.5 % off at 0.5 ms (mean moment 0.0067 %) where "
                                      "libcosim and Ecos, the same algorithm, have 0.63 %; at the 0.2 ms the SSP "
                                      "declared before the drive's experiment took 0.5 ms (its rates, issue 60) it "
                                      "met (0.34 %)",
    ("spine_knife", "fmpy-ssp"): "peak knife-shaft twist 16 % off at 0.05 ms (knife 15.7 um, torque 0.002 %) where "
                                 "libcosim and Ecos meet with the same algorithm: FMPy's simulate_ssp hands every "
                                 "input 0.0 in its first step, and the kick rings in the flywheels' belt mode into "
                                 "the second plunge; FMPy's own loop with the outputs after initialisation passed "
                                 "to the first step meets (twist 0.004 %)",
}


def _case(name: str, host: str):
    reason = MISSES.get((name, host))
    marks = [pytest.mark.xfail(reason=f"measured: {reason}", strict=True)] if reason else []
    return pytest.param(name, host, marks=marks, id=f"{name}-{host}")



@pytest.fixture(scope="module")
def exported(fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("host_accuracy")
    return {name: export_ssp(load(name).on_fmus(fmu_dir), out / f"{name}.ssp") for name in DRIVES}


@pytest.fixture(scope="module")
def references():
    cache = {}

    def get(name):
        if name not in cache:
            system = load(name)
            spec = accuracy_spec(system)
            cache[name] = reference(system, stop_time=spec.stop_time, step=spec.reference_step)
        return cache[name]
    return get


@pytest.mark.parametrize("name", DRIVES)
def test_the_declared_host_step_is_the_largest_at_which_the_sampled_jacobi_meets_the_accuracy(references, name):
    system = load(name)
    spec = accuracy_spec(system)
    h = spec.sampled_host_step
    assert h in LADDER
    larger = [s for s in LADDER if s > h and abs(spec.stop_time / s - round(spec.stop_time / s)) < 1e-9]
    if not larger:   # the ladder's largest: nothing above it to try
        assert h == max(s for s in LADDER if abs(spec.stop_time / s - round(spec.stop_time / s)) < 1e-9)

    def meets(step):
        t = trial(system, stop_time=spec.stop_time, step=step, master="jacobi-sampled", extrapolation=0)
        return t.result is not None and all(c.ok for c in check(system, t.result, references(name)))
    assert meets(h)
    if larger:
        assert not meets(min(larger))


@pytest.mark.parametrize("name", DRIVES)
def test_the_ssp_declares_the_host_step_and_keeps_the_harness_step(exported, name):
    system = load(name)
    declared = min(accuracy_spec(system).sampled_host_step, system.experiment.step)   # never above the harness's
    assert ha.declared_step(exported[name]) == host_step(system) == declared
    assert load_ssp(exported[name]).experiment == system.experiment      # the harness's own, round trip


@pytest.mark.parametrize("name,host", [_case(n, h) for n in DRIVES for h in PEER_HOSTS])
def test_exported_drive_meets_its_accuracy_in_host_at_the_declared_step(exported, references, name, host):
    reason = ha.unavailable(host)
    if reason:
        pytest.skip(reason)
    system = load(name)
    spec = accuracy_spec(system)
    step = ha.declared_step(exported[name])
    run = ha.run_guarded(host, exported[name], spec.stop_time, step, ha.columns_of(system), name, TIMEOUT)
    verdict = ha.judge(system, run, references(name))
    assert verdict.meets, ha.describe(verdict)


# ------------------------------------------------------------ inputs start where the harness initialises them
def _bound(ssp: Path) -> dict[str, float]:
    """'Instance.variable' -> value of every number the exported SSD binds to a component."""
    import zipfile
    from xml.etree import ElementTree as ET

    from harness.ssp import NS

    with zipfile.ZipFile(ssp) as z:
        root = ET.fromstring(z.read("SystemStructure.ssd"))
    out = {}
    for comp in root.iter(f"{{{NS['ssd']}}}Component"):
        for p in comp.iter(f"{{{NS['ssv']}}}Parameter"):
            for value in p:
                if value.tag in (f"{{{NS['ssv']}}}Real", f"{{{NS['ssv']}}}Integer"):
                    out[f"{comp.get('name')}.{p.get('name')}"] = float(value.get("value"))
    return out


@pytest.mark.parametrize("name", DRIVES)
def test_every_connected_input_is_bound_to_its_sources_value_at_the_start(fmu_dir, exported, name):
    """A host need not set inputs before initialization (FMPy's simulate_ssp sets none): an FMU that takes a
    state from an input (the motor's rotor angle from its pulley's) would start from the input's default, 0.
    The export binds each connected input to its source output's value at the start as the harness's own run
    has it (its first row), through the connection's transformation."""
    from harness.run import simulate

    system = load(name).on_fmus(fmu_dir)
    connections = system.all_connections()
    step = system.experiment.step
    first = simulate(system, stop_time=step, step=step, output=sorted({c.source for c in connections})).iloc[0]
    bound = _bound(exported[name])
    for c in connections:
        inst, var = c.target.split(".", 1)
        if var.startswith(f"{inst}."):   # OMSimulator would read it as a path from the system and die: not bound
            assert c.target not in bound
            continue
        assert c.target in bound, f"{c.target}: no start value bound"
        assert bound[c.target] == pytest.approx(c.factor * float(first[c.source]) + c.offset, rel=1e-12, abs=1e-12)


def test_fmpy_runs_the_exported_bed_drive_from_its_bound_start_values(exported, references):
    """Without the bound start values FMPy's simulate_ssp started the four-bar, cam and motor from inputs 0 and
    had the bed 0.19 m off through the printing zone at 0.3 s; with them 2.6 mm on the drive before its seed-004
    switch, 3.0 mm after (what is left: its first step's inputs 0.0, the bed drive's strict xfail above)."""
    reason = ha.unavailable("fmpy-ssp")
    if reason:
        pytest.skip(reason)
    system = load("bed_drive")
    run = ha.run_guarded("fmpy-ssp", exported["bed_drive"], 0.3, 1e-4, ha.columns_of(system), "bed_drive", TIMEOUT)
    assert run.status == "complete", run.error
    bed = check(system, run.result, references("bed_drive"))[0]
    assert bed.name == "bed position in the printing zone"
    assert bed.error < 0.01, f"bed {bed.error:.3g} m off at 0.3 s"


# ------------------------------------------------------------------- outputs read right after a step (the fix)
def _advancing_models() -> dict[str, list[tuple[str, str]]]:
    """Model -> (position, velocity) inputs of the motion-input ports whose position it advances over a step
    (``advances_position``: every toolkit FMU but the textbook SpringInertia, which holds its inputs)."""
    from harness.studies.reference import component_classes

    out = {}
    for name, cls in component_classes().items():
        pairs = [(f"{p.name}.s", f"{p.name}.v") if p.translational else (f"{p.name}.phi", f"{p.name}.w")
                 for p in cls.ports if p.motion == "in"]
        if pairs and cls.advances_position:
            out[name] = pairs
    return out


ADVANCING = _advancing_models()


@pytest.mark.parametrize("model", sorted(ADVANCING))
def test_outputs_read_right_after_a_step_see_the_positions_the_step_advanced(fmu_dir, model):
    """libcosim, Ecos and FMPy's simulate_ssp read outputs after fmi2DoStep before setting new inputs.  The
    model advanced each motion input's position over the step with its velocity, so an output read then must
    be the one it gives with the position set to that advanced value (what a refreshing master sets)."""
    from fmpy.fmi2 import FMU2Slave
    from harness.fmi.fmu import extracted

    fmu = Path(fmu_dir) / f"{model}.fmu"
    md, unzip_dir = extracted(fmu)
    pairs = ADVANCING[model]
    refs = {v.name: v.valueReference for v in md.modelVariables}
    outputs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    slave = FMU2Slave(guid=md.guid, unzipDirectory=str(unzip_dir), modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName=f"{model}_after_step")
    slave.instantiate(loggingOn=False)
    slave.setupExperiment(startTime=0.0)
    start = {pos: 0.1 for pos, _ in pairs} | {vel: 0.5 for _, vel in pairs}
    slave.setReal([refs[n] for n in start], list(start.values()))
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    h = 1e-3
    slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=h)
    out_refs = [refs[n] for n in outputs]
    sampled = np.array(slave.getReal(out_refs))
    slave.setReal([refs[pos] for pos, _ in pairs], [0.1 + 0.5 * h for _ in pairs])
    refreshed = np.array(slave.getReal(out_refs))
    slave.terminate()
    slave.fmi2FreeInstance(slave.component)
    scale = np.maximum(np.abs(refreshed), 1.0)
    worst = int(np.argmax(np.abs(sampled - refreshed) / scale))
    assert np.allclose(sampled, refreshed, rtol=1e-12, atol=1e-12), (
        f"{model}.{outputs[worst]}: {sampled[worst]!r} right after the step, {refreshed[worst]!r} with the advanced "
        f"position set")


def test_the_fmus_checked_above_are_the_drives_components():
    assert {"FourBar", "CamRocker", "JamesDifferential", "RackBed", "MotorBelt", "TorqueLoad"} <= set(ADVANCING)
    assert "SpringInertia" not in ADVANCING


# ---------------------------------------------------------------------------------------- the runner itself
def test_the_columns_judged_are_the_ones_the_requirements_read():
    assert ha.columns_of(load("bed_drive")) == ["bed.bed.s", "bed.bed.v", "flywheel.shaft_torque"]
    assert ha.columns_of(load("feeder_gto52")) == ["feeder.impact_count", "feeder.pin_force"]


def test_a_run_that_does_not_return_is_marked_hung_and_judged_as_meeting_nothing(exported, references):
    system = load("bed_drive")
    run = ha.run_guarded("harness:jacobi", exported["bed_drive"], 1.0, 1e-5, ha.columns_of(system), "bed_drive",
                         timeout=3.0)
    assert run.status == "hung" and run.result is None and "3 s" in run.error
    assert not ha.judge(system, run, references("bed_drive")).meets


def test_a_host_the_tool_does_not_know_is_named():
    assert "unknown host" in ha.unavailable("nonesuch")
    assert ha.unavailable("harness:jacobi") is None
