"""Tier 2: every built FMU through fmpy: standard model description, rollback, parameter errors."""
from __future__ import annotations

import importlib
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu

from fmus import build as build_fmus
from input_ranges import declared_range, fold

SCRIPTS = [s.stem for s in build_fmus.component_scripts()]


def component_class(module: str):
    mod = importlib.import_module(f"fmus.components.{module}")
    return next(v for v in vars(mod).values()
                if isinstance(v, type) and v.__module__ == mod.__name__ and hasattr(v, "model"))


@pytest.fixture(params=SCRIPTS)
def fmu(request, fmu_dir) -> tuple[Path, type]:
    cls = component_class(request.param)
    return fmu_dir / f"{cls.__name__}.fmu", cls


def open_fmu(path: Path, name="inst"):
    md = read_model_description(str(path))
    unzipped = extract(str(path))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName=name)
    slave.instantiate(loggingOn=True)
    return md, slave


def test_every_component_is_built():
    assert len(SCRIPTS) >= 2


def test_model_description_is_standard_and_complete(fmu):
    path, cls = fmu
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    assert md.coSimulation.canGetAndSetFMUstate
    for v in md.modelVariables:
        if v.type == "Real":
            assert v.unit, f"{path.name}: Real {v.name} has no unit"
            assert v.unit in {u.name for u in md.unitDefinitions}
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    assert {u.variable.name for u in md.outputs} == {v.name for v in outputs}
    assert {u.variable.name for u in md.initialUnknowns} >= {v.name for v in outputs}
    # declared direct dependencies are exactly the feedthrough table; the rest depend on no input
    for unknown in md.outputs:
        declared = set(cls.feedthrough.get(unknown.variable.name, ()))
        assert {d.name for d in unknown.dependencies} == declared
    # the module name inside the FMU is unique (pd_<name>) so several FMUs share a process
    with zipfile.ZipFile(path) as z:
        assert z.read("resources/slavemodule.txt").decode().startswith("pd_")


def _drive_inputs(md, slave, k):
    inputs = [v for v in md.modelVariables if v.causality == "input" and v.type == "Real"]
    if inputs:
        slave.setReal([v.valueReference for v in inputs],
                      [fold(0.01 * (i + 1) * np.sin(0.3 * k + i), *declared_range(v)) for i, v in enumerate(inputs)])


def test_rollback_with_fmu_state_is_bit_exact(fmu):
    path, _ = fmu
    md, s = open_fmu(path)
    observed = [v.valueReference for v in md.modelVariables
                if v.type == "Real" and v.causality in ("output", "local")]
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    h = 1e-3
    for k in range(10):
        _drive_inputs(md, s, k)
        s.doStep(k * h, h)
    state = s.getFMUstate()

    def run_on():
        trace = []
        for k in range(10, 15):
            _drive_inputs(md, s, k)
            s.doStep(k * h, h)
            trace.append(s.getReal(observed))
        return np.array(trace)

    first = run_on()
    s.setFMUstate(state)
    second = run_on()
    s.freeFMUstate(state)
    s.terminate()
    s.freeInstance()
    assert np.array_equal(first, second)
    assert np.all(np.isfinite(first))


def test_a_non_physical_parameter_is_an_fmi_error_with_a_clear_log_line(fmu, capsys):
    path, cls = fmu
    spec = next(s for s in cls.model.Params.specs()
                if not s.is_integer and cls.model.Params.__dataclass_fields__[s.name].metadata.get("low") is not None)
    low = cls.model.Params.__dataclass_fields__[spec.name].metadata["low"]
    bad = low - 1.0
    md, s = open_fmu(path, name="badInstance")
    vr = next(v.valueReference for v in md.modelVariables if v.name == spec.name)
    s.setupExperiment(startTime=0.0)
    s.setReal([vr], [bad])
    with pytest.raises(Exception, match="fmi2(Enter|Exit)InitializationMode failed"):
        s.enterInitializationMode()
        s.exitInitializationMode()
    log = capsys.readouterr().out
    assert f"badInstance ({cls.__name__}): parameter {spec.name} = {bad!r}" in log


def test_many_instances_in_one_process(fmu_dir):
    """Several instances of every FMU alive together, freed, and created again (pythonfmu refcount bug): each
    instance steps from its own default start to the same outputs as its siblings of the same FMU, alive at the
    same time, and as the instances of the first round (no state shared or left behind)."""
    rounds = []
    for _round in range(2):
        alive, outputs = [], {}
        for module in SCRIPTS:
            cls = component_class(module)
            for k in range(3):
                md, s = open_fmu(fmu_dir / f"{cls.__name__}.fmu", name=f"{cls.__name__}{k}")
                s.setupExperiment(startTime=0.0)
                s.enterInitializationMode()
                s.exitInitializationMode()
                s.doStep(0.0, 1e-3)
                refs = [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
                outputs.setdefault(cls.__name__, []).append(s.getReal(refs))
                alive.append(s)
        for name, got in outputs.items():
            assert got[1] == got[0] and got[2] == got[0], name
        for s in alive:
            s.terminate()
            s.freeInstance()
        rounds.append(outputs)
    assert rounds[1] == rounds[0] and len(rounds[0]) == len(SCRIPTS)
