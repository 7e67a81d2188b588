"""OSP's own files (harness/osp, issue 60): OspSystemStructure.xml in and out, compared with libcosim.

* OSP's demo ``dp-ship`` from its OspSystemStructure.xml: the same connections as its SSD form (groups matched
  in the order its OspModelDescriptions declare them), and every Real output the same as libcosim's at every
  communication point, with every FMU at the base step and with three of them at their own rates.
* OSP's ``tutorial-fmus``: units that differ across its group connections (mph, feet, kN), converted from the
  descriptions' unit definitions; the same values as libcosim running the harness's export of it (each
  conversion an OSP LinearTransformation function, as libcosim 0.11 converts no unit itself).
* A drive exported as OSP (``export --format osp``): its bonds as mechanical port groups, read back to the
  same system, and the same values in libcosim with two FMUs at their own rates.
* Refusals in one line: units of another dimension, groups of different sizes, an unknown group, a function
  the harness does not offer, a remote FMU, a step that is no multiple of the base step.
"""
from __future__ import annotations

import json
import shutil
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from benchmarks import peers
from harness import load, simulate
from harness.errors import SystemDescriptionError
from harness.osp import load_osp
from harness.osp.write import export_osp

OSP = Path(__file__).parent / "osp"
RATES = {"Observer": "0.08", "Reference Generator": "0.16", "Thrust Allocation": "0.12"}   # 2, 4, 3 base steps:
# the allocation (3) feeds the observer (2): libcosim passes its value at multiples of 6 only


def _libcosim_or_skip():
    reason = peers.available().get("libcosim")
    if reason is not None:
        pytest.skip(reason)
    from benchmarks.osp_peers import run_osp_libcosim

    return run_osp_libcosim


def _copy(tmp_path, case: str) -> Path:
    folder = tmp_path / case
    shutil.copytree(OSP / case, folder)
    return folder / "OspSystemStructure.xml"


def _quiet_run(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(path, **kw)


def _fresh_run(path, **kw):
    """dp-ship's ThMPC and DPController keep state in their libraries' globals (both declare
    canBeInstantiatedOnlyOncePerProcess="false"): a second run in one process continues from the first (2954 N
    apart at 4.8 s).  libcosim loads each FMU from a fresh copy; here each run is in a fresh process."""
    from benchmarks.osp_peers import run_harness

    return peers.run_isolated(run_harness, path, **kw)


def _largest_difference(ref, df, cols) -> tuple[float, str]:
    """The largest |libcosim - harness| over every row, as a fraction of the column's largest magnitude."""
    assert len(ref) == len(df) and np.array_equal(ref.index.to_numpy(), df.index.to_numpy())
    a, b = ref[cols].to_numpy(), df[cols].to_numpy()
    err = np.abs(a - b).max(axis=0) / np.maximum(np.abs(b).max(axis=0), 1e-12)
    return float(err.max()), cols[int(np.argmax(err))]


# -- dp-ship ---------------------------------------------------------------------------------------------------
def test_dp_ship_structure_has_the_connections_of_its_ssd():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        osp = load(OSP / "dp-ship" / "OspSystemStructure.xml")
        ssd = load(OSP / "dp-ship" / "SystemStructure.ssd")
    assert [i.name for i in osp.instances] == [i.name for i in ssd.instances]
    assert sorted((c.source, c.target) for c in osp.connections) == sorted((c.source, c.target) for c in ssd.connections)
    assert osp.experiment.step == 0.04 and osp.experiment.master == "jacobi-sampled"


def _with_rates(path: Path) -> Path:
    text = path.read_text()
    for name, step in RATES.items():
        text = text.replace(f'<Simulator name="{name}" ', f'<Simulator name="{name}" stepSize="{step}" ')
    out = path.with_name("OspSystemStructure_rates.xml")
    out.write_text(text)
    return out


@pytest.mark.interop
def test_dp_ship_agrees_with_libcosim_at_one_rate_and_at_their_own(tmp_path):
    run_osp_libcosim = _libcosim_or_skip()
    one = _copy(tmp_path, "dp-ship")
    own = _with_rates(one)
    assert [i.step for i in load_osp(own).instances] == [None, 0.08, 0.16, 0.12, None]
    stop = 2.4   # a whole number of every step (0.04, 0.08, 0.12, 0.16 s)
    base = _fresh_run(one, stop_time=stop)
    rated = _fresh_run(own, stop_time=stop)
    cols = [c for c in base.columns if base[c].dtype == np.float64]
    # fewer FMU steps: 60 of each FMU at the base step; 30, 15, 20 of the three
    assert base.attrs["fmu_steps"] == 5 * 60 and rated.attrs["fmu_steps"] == 2 * 60 + 30 + 20 + 15
    for path, df in ((one, base), (own, rated)):
        ref = peers.run_isolated(run_osp_libcosim, path, stop, cols)
        err, col = _largest_difference(ref, df, cols)
        assert err <= 1e-9, f"{path.name}: {col} differs from libcosim by {err:.3g} of its range"
    differs, _ = _largest_difference(rated, base, cols)
    assert differs > 1e-3   # the rates changed the answer: the agreement above is not the single-rate one


# -- tutorial-fmus: units ----------------------------------------------------------------------------------------
def test_tutorial_units_convert_by_their_definitions():
    system = load(OSP / "tutorial-fmus" / "OspSystemStructure.xml")
    factor = {c.target: c.factor for c in system.connections}
    # value_target = factor * value_source: the ratio of the two units' factors to SI (OspModelDescriptions)
    assert factor["spring.dis_xx"] == pytest.approx(0.3048)    # feet -> metre (0.3048 m per foot)
    assert factor["damper.lv_0"] == pytest.approx(0.44704)     # mph -> m/s (0.44704 m/s per mph)
    assert factor["mass.in_f_u"] == pytest.approx(1e-3)        # its "kilo_newton" (factor 1e-3, as declared) -> N
    assert factor["mass.in_l_u"] == 1.0                        # newton -> newton
    assert all(c.unit_conversion and c.offset == 0 for c in system.connections)


@pytest.mark.interop
def test_tutorial_with_its_units_agrees_with_libcosim_on_the_export(tmp_path):
    run_osp_libcosim = _libcosim_or_skip()
    path = OSP / "tutorial-fmus" / "OspSystemStructure.xml"
    exported = export_osp(load(path), tmp_path / "export", stop_time=1.0)
    assert exported.read_text().count("<LinearTransformation ") == 6
    df = _quiet_run(path, stop_time=1.0)
    cols = [c for c in df.columns if df[c].dtype == np.float64]
    ref = peers.run_isolated(run_osp_libcosim, exported, 1.0, cols)
    err, col = _largest_difference(ref, df, cols)
    assert err <= 1e-9, f"{col} differs from libcosim by {err:.3g} of its range"


# -- a drive exported ------------------------------------------------------------------------------------------
def test_a_drive_exported_as_osp_reads_back_with_its_bonds(fmu_dir, tmp_path):
    system = load("proof_press").on_fmus(fmu_dir)
    out = export_osp(system, tmp_path / "pp")
    back = load(out)
    assert [(b.motion_out, b.motion_in) for b in back.bonds] == [(b.motion_out, b.motion_in) for b in system.bonds]
    assert sorted((c.source, c.target, c.factor, c.offset) for c in back.all_connections()) == \
        sorted((c.source, c.target, c.factor, c.offset) for c in system.all_connections())
    free = {ref.split(".", 1)[0] for ref in system.free_inputs}   # free inputs go with their start values
    for mine, read in zip(system.instances, back.instances):
        extra = {k: v for k, v in read.parameters.items() if k not in mine.parameters}
        assert {k: read.parameters[k] for k in mine.parameters} == mine.parameters
        assert {f"{mine.name}.{k}" for k in extra} <= set(system.free_inputs) and (bool(extra) == (mine.name in free))
    md = (tmp_path / "pp" / "MotorBelt_OspModelDescription.xml").read_text()
    assert '<AngularMechanicalPort name="pulley">' in md and '<Variable ref="pulley.tau" unit="N.m" />' in md
    assert back.experiment.step == 2e-4   # proof_press's sampled_host_step (harness.ssp.host_step)


@pytest.mark.interop
def test_a_drive_with_two_fmus_at_their_own_rates_agrees_with_libcosim(fmu_dir, tmp_path):
    run_osp_libcosim = _libcosim_or_skip()
    system = load("proof_press").on_fmus(fmu_dir)
    steps = {"motor": 4e-4, "cylinder": 6e-4}   # 2 and 3 base steps of 0.2 ms: libcosim's lcm rule at 6
    system = replace(system, instances=[replace(i, step=steps.get(i.name)) for i in system.instances])
    out = export_osp(system, tmp_path / "pp")
    assert 'stepSize="0.0006"' in out.read_text()
    df = _quiet_run(out, stop_time=0.06)
    assert df.attrs["rates"] == {"motor": 2, "cylinder": 3}
    cols = [c for c in df.columns if df[c].dtype == np.float64]
    ref = peers.run_isolated(run_osp_libcosim, out, 0.06, cols)
    err, col = _largest_difference(ref, df, cols)
    assert err <= 1e-9, f"{col} differs from libcosim by {err:.3g} of its range"


# -- refusals ------------------------------------------------------------------------------------------------------
def _refused(path) -> str:
    with pytest.raises(SystemDescriptionError) as e:
        load(path)
    msg = str(e.value)
    assert "\n" not in msg and str(path) in msg
    return msg


def test_units_of_another_dimension_are_refused(tmp_path):
    path = _copy(tmp_path, "tutorial-fmus")
    md = path.with_name("Damper_OspModelDescription.xml")
    md.write_text(md.read_text().replace('<BaseUnit m="1" s="-1"/>', '<BaseUnit kg="1" m="1" s="-2"/>'))
    msg = _refused(path)
    assert "mass.out_f_u is in miles_per_hour (m.s-1)" in msg and "damper.lv_0 in meter_per_second (kg.m.s-2)" in msg


def test_groups_of_different_sizes_and_unknown_groups_are_refused(tmp_path):
    path = _copy(tmp_path, "tutorial-fmus")
    md = path.with_name("Spring_OspModelDescription.xml")
    md.write_text(md.read_text().replace('<Variable ref="dis_yx" unit="meter"/>', ""))
    assert "group spring:linear_position (0 groups, 1 variables)" in _refused(path)
    shutil.copyfile(OSP / "tutorial-fmus" / md.name, md)
    path.write_text(path.read_text().replace('name="damper_connector"', 'name="no_such_group"'))
    assert "Mass_OspModelDescription.xml declares no variable group 'no_such_group'" in _refused(path)


def test_functions_and_sources_the_harness_does_not_offer_are_refused(tmp_path):
    path = _copy(tmp_path, "tutorial-fmus")
    text = path.read_text()
    path.write_text(text.replace("<Connections>", '<Functions><Sum name="total" inputCount="2"/></Functions>'
                                                  "<Connections>"))
    assert "OSP's Sum function is not offered by the harness" in _refused(path)
    path.write_text(text.replace('source="Mass.fmu"', 'source="proxyfmu://localhost?file=Mass.fmu"'))
    assert "scheme proxyfmu:// is not a local FMU file" in _refused(path)


def test_a_step_that_is_no_multiple_of_the_base_step_is_refused(tmp_path):
    path = _copy(tmp_path, "tutorial-fmus")
    path.write_text(path.read_text().replace('name="mass" source="Mass.fmu"', 'name="mass" source="Mass.fmu" '
                                                                                'stepSize="0.025"'))
    with pytest.raises(SystemDescriptionError) as e:
        _quiet_run(path, stop_time=0.1)
    msg = str(e.value)
    assert "\n" not in msg and "instance mass: step = 0.025 s is not a whole multiple of the base step 0.01 s" in msg


# -- libcosim's scenario files -----------------------------------------------------------------------------------
HAND = OSP / "hand_scenario.json"   # every action on an unconnected input, a connected input and an output; end


@pytest.mark.interop
@pytest.mark.parametrize("end", [True, pytest.param(False, marks=pytest.mark.slow)], ids=["with-end", "without-end"])
def test_a_scenario_file_runs_as_in_libcosim(tmp_path, end):
    """The allocation's Fxg is overridden by the event at 0.8 s: from the output read after the step from 0.8 s
    (0.84 s) until the scenario's cleanup, at its end (1.6 s) or, without one, one step after its last event
    (1.2 s), which removes it from the read after that step."""
    run_osp_libcosim = _libcosim_or_skip()
    path = _copy(tmp_path, "dp-ship")
    scenario = json.loads(HAND.read_text())
    if not end:
        del scenario["end"]
    file = tmp_path / "scenario.json"
    file.write_text(json.dumps(scenario))
    df = _fresh_run(path, scenario=file, stop_time=2.0)
    cols = [c for c in df.columns if df[c].dtype == np.float64]
    overridden = df.index[df["Thrust Allocation.Fxg"] == 1000.0]
    last = 1.6 if end else 1.24
    assert overridden.min() == pytest.approx(0.84) and overridden.max() == pytest.approx(last)
    assert len(overridden) == round((last - 0.84) / 0.04) + 1
    ref = peers.run_isolated(run_osp_libcosim, path, 2.0, cols, scenario=file)
    err, col = _largest_difference(ref, df, cols)
    assert err <= 1e-9, f"{col} differs from libcosim by {err:.3g} of its range"


def test_scenario_files_are_checked_against_the_system():
    from harness.run import simulate_scenario

    demo = OSP / "dp-ship" / "scenarios"
    with pytest.raises(SystemDescriptionError) as e:
        simulate_scenario(OSP / "dp-ship" / "OspSystemStructure.xml", demo / "faulty.json", stop_time=0.08)
    msg = str(e.value)   # OSP's own file with "a couple of errors": the first is named
    assert "\n" not in msg and "event 8: model Reference Generator (ReferenceGenerator) has no variable 'hello'" in msg
    from harness.osp.scenario import LibcosimScenario

    north = LibcosimScenario(demo / "move north.json")
    assert north.end == 700 and [(e.instance, e.variable, e.action) for e in north.events] == [
        ("Reference Generator", "x_wp", "override"), ("Reference Generator", "x_tp", "override")]


# -- the drives exported, in libcosim over their accuracy span ------------------------------------------------------
@pytest.mark.slow
@pytest.mark.interop
@pytest.mark.parametrize("name", ["bed_drive", "feeder_gto52", "proof_press", "spine_knife", "trimmer_conveyor"])
def test_each_drive_exported_as_osp_meets_its_accuracy_in_libcosim_and_agrees_with_the_harness(fmu_dir, tmp_path,
                                                                                                 name):
    """Measured (one run): agreement 9.8e-12 (trimmer) to 1.3e-9 (spine knife); libcosim's errors, e.g. the bed
    2.47 um of 10 um, the trimmer's peak torque 0.63 % of 1 %.  About 20 s a drive."""
    from benchmarks.osp_peers import run_harness
    from harness.studies.accuracy import accuracy_spec, check
    from harness.studies.reference import reference

    run_osp_libcosim = _libcosim_or_skip()
    system = load(name).on_fmus(fmu_dir)
    spec = accuracy_spec(system)
    out = export_osp(system, tmp_path / name)
    df = peers.run_isolated(run_harness, out, stop_time=spec.stop_time)
    cols = [c for c in df.columns if df[c].dtype == np.float64]
    ref = peers.run_isolated(run_osp_libcosim, out, spec.stop_time, cols)
    err, col = _largest_difference(ref, df, cols)
    assert err <= 1e-8, f"{col} differs from libcosim by {err:.3g} of its range"
    ref.attrs["complete"] = True
    checks = check(system, ref, reference(system, stop_time=spec.stop_time, step=spec.reference_step))
    assert all(c.ok for c in checks), "; ".join(f"{c.name} {c.error:.3g} of {c.tolerance:g}" for c in checks)


def test_ecco_is_read_as_the_harness_ecco_step_control(fmu_dir, tmp_path):
    out = export_osp(load("two_inertia").on_fmus(fmu_dir), tmp_path / "pair", algorithm="ecco")
    text = out.read_text()
    assert text.count('powerBond="a.flange-&gt;b.drive"') == 2 and "<EccoConfiguration>" in text
    exp = load(out).experiment
    assert exp.step_control == "ecco" and exp.master == "jacobi-sampled"
    # the EccoConfiguration written from the harness's ECCO defaults (harness.master.stepcontrol.Ecco) comes back
    assert exp.step_options == dict(safety=0.99, min_step=1e-6, max_step=0.1, min_factor=0.2, max_factor=1.5, kP=0.2,
                                    kI=0.15, rtol=1e-4, atol=1e-4)
    df = simulate(out, stop_time=0.05, master="jacobi", extrapolation=1)
    assert df.attrs["complete"] and df.attrs["step_control"] == "ecco"
