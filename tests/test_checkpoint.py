"""Checkpoints of a whole run (harness/run/checkpoint.py, issue 60): written at a point, continued later, bit for bit.

* Continued from a checkpoint, a run is the uninterrupted one bit for bit: the rows, the counters, the
  engineering quantities; with the interface-Jacobian master (its Jacobians kept), ECCO step control (its error
  memory and next step), Gauss-Seidel with an instance at its own rate checkpointed amid that instance's step,
  a run the divergence watch stops after the checkpoint, and through the FMUs' own FMI libraries.
* On the command line: ``run --checkpoint --checkpoint-at``, then ``run --from-checkpoint``: the same CSV, byte
  for byte.
* A variant of a shared start-up: a tunable parameter that differs from the checkpoint's is set at its time,
  the same as that change made by an input signal at that time; a parameter fixed at initialization is
  refused, naming it; ``compare`` and ``sweep`` start their variants from the checkpoint.
* Refused in one line: another system, another toolkit version, another FMU build, other settings, a stop
  before the checkpoint, FMUs that cannot serialize their state (by name).
"""
from __future__ import annotations

import json
import subprocess
import sys
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness import RunOptions, load, simulate
from harness.errors import SystemDescriptionError

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def pair(fmu_dir):
    return load("two_inertia").on_fmus(fmu_dir)


def _same(a: pd.DataFrame, b: pd.DataFrame) -> None:
    assert a.equals(b) and np.array_equal(a.index.to_numpy(), b.index.to_numpy())
    for key in ("steps", "fmu_steps", "iterations", "halved_steps", "rejected", "complete", "error"):
        assert a.attrs[key] == b.attrs[key], key
    assert a.attrs["quantities"].rows == b.attrs["quantities"].rows


@pytest.mark.parametrize("case", [
    dict(),                                                      # the pair's own: jacobian master, extrapolation 1
    dict(master="jacobi", step_control="ecco", tolerance=1e-3),   # variable steps: the checkpoint between two
    dict(master="gauss-seidel", extrapolation=1, rates={"b": 3}),  # b at its own rate, amid its step at 0.1 s
    dict(master="jacobi", extrapolation=0, stop_time=1.0),       # diverges at 0.7 s, after the checkpoint
    dict(options=RunOptions(in_process=False)),                  # the FMUs' own libraries (fmi2SerializeFMUstate)
], ids=["jacobian", "ecco", "gauss-seidel-rates", "diverging", "fmi-libraries"])
def test_a_continued_run_is_the_uninterrupted_one_bit_for_bit(pair, tmp_path, case):
    case = dict(case)
    rates = case.pop("rates", {})
    system = replace(pair, instances=[replace(i, step=1e-3 * rates[i.name] if i.name in rates else None)
                                      for i in pair.instances])
    kw = dict(stop_time=case.pop("stop_time", 0.2), step=1e-3, **case)
    ckpt = tmp_path / "run.ckpt"
    whole = simulate(system, **kw)
    saving = simulate(system, checkpoint=(ckpt, 0.1), **kw)
    assert saving.attrs["checkpoint"]["time"] >= 0.1 and ckpt.is_file()
    _same(saving, whole)                      # writing a checkpoint changes nothing
    continued = simulate(system, from_checkpoint=ckpt, **kw)
    assert continued.attrs["resumed_from"]["time"] == saving.attrs["checkpoint"]["time"]
    _same(continued, whole)


def test_the_command_line_continues_to_the_same_file_byte_for_byte(tmp_path):
    def run(*args):
        p = subprocess.run([sys.executable, "-m", "harness", "run", "proof_press", "--stop-time", "0.04",
                            "--quiet-quantities", *map(str, args)], capture_output=True, text=True, cwd=ROOT)
        assert p.returncode == 0, p.stderr
        return p.stdout
    ckpt = tmp_path / "start.ckpt"
    said = run("--checkpoint", ckpt, "--checkpoint-at", 0.02, "--out", tmp_path / "whole.csv")
    assert f"checkpoint {ckpt} at t = 0.02 s" in said
    run("--from-checkpoint", ckpt, "--out", tmp_path / "continued.csv")
    assert (tmp_path / "whole.csv").read_bytes() == (tmp_path / "continued.csv").read_bytes()


# -- variants of a shared start-up ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def startup(fmu_dir, tmp_path_factory):
    """proof_press run to 0.05 s, checkpointed there."""
    system = load("proof_press").on_fmus(fmu_dir)
    path = tmp_path_factory.mktemp("startup") / "startup.ckpt"
    simulate(system, stop_time=0.05, checkpoint=path)
    return system, path


def test_a_variant_is_its_change_made_at_the_checkpoint(startup):
    system, path = startup
    variant = simulate(system, stop_time=0.1, from_checkpoint=path, start_values={"cylinder.T_coulomb": 5.0})
    # the same change as an input signal stepping the tunable parameter at 0.05 s (harness.signals)
    signal = pd.DataFrame({"time": [0.0, 0.05, 0.05, 0.1], "cylinder.T_coulomb": [2.0, 2.0, 5.0, 5.0]})
    assert variant.equals(simulate(system, stop_time=0.1, input=signal))
    assert not variant.equals(simulate(system, stop_time=0.1, from_checkpoint=path))


def test_a_parameter_fixed_at_initialization_is_refused_by_name(startup):
    system, path = startup
    with pytest.raises(SystemDescriptionError) as e:
        simulate(system, stop_time=0.1, from_checkpoint=path, start_values={"press.J_cyl": 3.0})
    msg = str(e.value)
    assert "\n" not in msg and "press.J_cyl = 3.0" in msg and "its FMU fixes it at initialization" in msg


def test_compare_and_sweep_start_every_variant_from_the_checkpoint(startup, tmp_path):
    from harness.studies.compare import compare
    from harness.studies.sweep import parse_spec, run_sweep

    system, path = startup
    c = compare(system, ["as declared: ", "heavier cut: cylinder.T_coulomb=5"], stop_time=0.1, from_checkpoint=path)
    heavier = c.results["heavier cut"]
    assert heavier.attrs["resumed_from"]["time"] == 0.05
    assert heavier.loc[:0.05].equals(c.results["as declared"].loc[:0.05])
    spec = parse_spec({"grid": {"cylinder.T_coulomb": [2.0, 5.0]}, "stop_time": 0.1, "from_checkpoint": str(path),
                       "outputs": {"torque": 'peak(r["cylinder.flange.tau"])'}})
    swept = run_sweep(system, spec, workers=0, progress=False)
    assert list(swept["error"]) == ["", ""]
    assert swept["torque"].iloc[1] == pytest.approx(
        abs(heavier["cylinder.flange.tau"]).max(), rel=0, abs=0)


# -- refusals --------------------------------------------------------------------------------------------------------
def _refused(system, **kw) -> str:
    with pytest.raises(SystemDescriptionError) as e:
        simulate(system, **kw)
    msg = str(e.value)
    assert "\n" not in msg
    return msg


def _edited(path: Path, tmp_path: Path, change) -> Path:
    out = tmp_path / f"edited-{path.name}"
    with zipfile.ZipFile(path) as z, zipfile.ZipFile(out, "w") as w:
        for item in z.namelist():
            data = z.read(item)
            if item == "manifest.json":
                head = json.loads(data)
                change(head)
                data = json.dumps(head)
            w.writestr(item, data)
    return out


def test_a_checkpoint_of_another_run_is_refused(startup, pair, tmp_path):
    system, path = startup
    assert "is of system proof_press, not two_inertia" in _refused(pair, stop_time=0.1, from_checkpoint=path)
    other = replace(system, instances=[replace(i, step=4e-4 if i.name == "motor" else None)
                                       for i in system.instances])
    assert "other instances, connections or bonds" in _refused(other, stop_time=0.1, from_checkpoint=path)
    old = _edited(path, tmp_path, lambda h: h.update(toolkit="0.0.1+000000000000"))
    assert "written by toolkit 0.0.1+000000000000" in _refused(system, stop_time=0.1, from_checkpoint=old)
    build = _edited(path, tmp_path, lambda h: h["fmus"].update(motor="0" * 64))
    assert "the FMU of instance motor is another build" in _refused(system, stop_time=0.1, from_checkpoint=build)
    assert "step = 0.0002 s in the checkpoint, 0.0001 s in this run" in _refused(
        system, stop_time=0.1, step=1e-4, from_checkpoint=path)
    assert "is at t = 0.05 s: stop_time must be later" in _refused(system, stop_time=0.04, from_checkpoint=path)


def test_fmus_that_cannot_serialize_refuse_the_checkpoint_by_name(tmp_path):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        msg = _refused(ROOT / "tests" / "osp" / "dp-ship" / "OspSystemStructure.xml", stop_time=0.4,
                       checkpoint=tmp_path / "x.ckpt")
    assert "instances DP Controller (DPController.fmu), Observer (NLPobserver.fmu)" in msg
    assert "cannot serialize their state" in msg and not (tmp_path / "x.ckpt").exists()


def test_a_saved_state_round_trips_exactly():
    from fmus.slave3_me import ModelExchangeState
    from fmus.slave_core import state_from_bytes, state_to_bytes

    x = np.array([0.1, 1 / 3, -2.5e-310, np.pi])
    s = ModelExchangeState(x=x, u=[np.float64(0.7), 1e300], y=[0.2], time=0.30000000000000004, outputs_stale=False,
                           initialised=True, par={"J": 2.5, "n": 3}, model=object(), input_set=[True, False],
                           last_step=1e-4, pos_time={0: 0.1, 3: 0.2}, last_sides=(True, False))
    back = state_from_bytes(state_to_bytes(s))
    assert back.pop("x").tobytes() == x.tobytes()
    assert back == dict(u=[0.7, 1e300], y=[0.2], time=0.30000000000000004, outputs_stale=False, initialised=True,
                        par={"J": 2.5, "n": 3}, input_set=[True, False], last_step=1e-4, pos_time={0: 0.1, 3: 0.2},
                        last_sides=(True, False))
