"""Scenes (issue 9): the coarsest adequate model, its cost, the cache and the CLI.

The fast tests use the two-inertia scene ``mean_speed`` shortened to 0.06 s: its full model (step 2.5e-5 s)
and the chosen one run in a few seconds.  The tolerance check re-runs the chosen configuration and evaluates
the quantity itself (not the value choose() reports).  "Cheaper" is asserted on a count (communication steps),
not on wall time: timed assertions fail on a loaded machine, and the measured speed-up is reported by the CLI
and by benchmarks/.
"""
from __future__ import annotations

import dataclasses
import warnings

import pandas as pd
import pytest

from harness import load, simulate
from harness.reporting import qoi
from harness.run import system_names
from harness.studies import scenes
from harness.__main__ import main


@pytest.fixture(autouse=True)
def _fmus(fmu_dir, monkeypatch):
    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))
    warnings.simplefilter("ignore")


def _cheap():
    system = load("two_inertia")
    scene = next(s for s in system.scenes if s.name == "mean_speed")
    return system, dataclasses.replace(scene, stop_time=0.06)


@pytest.fixture(scope="module")
def out_dir(tmp_path_factory):
    """Shared by the choose() test and the CLI test, so the CLI finds the full model in the cache."""
    return tmp_path_factory.mktemp("scenes")


def test_chosen_model_meets_tolerance_is_cheaper_and_a_repeat_uses_the_cache(out_dir, monkeypatch):
    tmp_path = out_dir / "cache"
    system, scene = _cheap()
    res = scenes.choose(system, scene, cache_dir=tmp_path)
    assert not res.cached_full
    # independent check of the tolerance: run the chosen configuration again and evaluate the quantity
    df = simulate(system, stop_time=scene.stop_time, step=res.chosen.step, master=res.chosen.master,
                  outputs=qoi.columns(scene.quantity))
    value = qoi.evaluate(scene.quantity, df)
    full_df = simulate(system, stop_time=scene.stop_time, step=scene.step, master=system.experiment.master,
                       outputs=qoi.columns(scene.quantity))
    full_value = qoi.evaluate(scene.quantity, full_df)
    assert abs(value - full_value) <= scene.tolerance * abs(full_value)
    # a coarser model was found: at least half the communication steps saved (every FMU is stepped once per
    # communication step by the non-iterative masters the scene search may choose)
    assert res.chosen.step >= 2.0 * scene.step, (res.chosen.step, scene.step)
    assert res.chosen.master != "iterative"
    assert res.speedup > 0.0 and res.full.wall_time > 0.0  # measured and reported, not asserted on

    # the repeat: no full-model run at all (the full model is the one with the scene's own step)
    calls = []
    real_run = scenes._run

    def spy(system_, scene_, fidelities, step, full_value_, master=None, runs=None):
        calls.append((step, master))
        return real_run(system_, scene_, fidelities, step, full_value_, master, runs)

    monkeypatch.setattr(scenes, "_run", spy)
    again = scenes.choose(system, scene, cache_dir=tmp_path)
    assert again.cached_full and again.full.value == res.full.value
    assert all(step != scene.step or master != system.experiment.master for step, master in calls), calls
    assert again.chosen.step == res.chosen.step and again.chosen.master == res.chosen.master


def test_cli_runs_and_writes_table_and_chart(out_dir, monkeypatch, capsys):
    tmp_path = out_dir
    system, scene = _cheap()
    monkeypatch.setattr(system, "scenes", [scene])
    assert main(["scene", "two_inertia", "mean_speed", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "chosen fidelities" in out and "speed-up" in out
    assert (tmp_path / "scene_two_inertia_mean_speed.png").stat().st_size > 1000
    assert (tmp_path / "scene_two_inertia_mean_speed.csv").read_text().count("\n") >= 3


def test_all_scenes_share_their_runs_and_answer_as_each_alone(monkeypatch, tmp_path, capsys):
    """``scene SYSTEM --all``: the two-inertia scenes (shortened to 0.06 s, the same stop time) answered together
    make each distinct run once (their full model, its check at half the step and the searches' common steps
    among them), and each scene's answer (full model, chosen configuration, every candidate's quantity) is the
    one it gets answered alone."""
    system = load("two_inertia")
    short = [dataclasses.replace(s, stop_time=0.06) for s in system.scenes]
    monkeypatch.setattr(system, "scenes", short)
    made = []
    real = scenes.trial

    def counted(system_, **options):
        made.append(options)
        return real(system_, **options)

    monkeypatch.setattr(scenes, "trial", counted)
    monkeypatch.setattr(scenes, "_timed", lambda system_, scene, c, runs: c.wall_time)  # timing: not asked here
    assert main(["scene", "two_inertia", "--all", "--out", str(tmp_path / "all")]) == 0
    out = capsys.readouterr().out
    assert [line.split(":")[0] for line in out.splitlines() if line.startswith("scene ")] == \
        [f"scene {s.name}" for s in short], out
    together = len(made)
    alone = []
    for scene in short:
        made.clear()
        alone.append(scenes.choose(system, scene, cache_dir=tmp_path / "alone"))
        assert (tmp_path / "all" / f"scene_two_inertia_{scene.name}.csv").is_file()
        table = pd.read_csv(tmp_path / "all" / f"scene_two_inertia_{scene.name}.csv")
        assert list(table["value"].fillna(-1.0)) == list(alone[-1].table()["value"].fillna(-1.0)), scene.name
        alone[-1] = len(made)
    assert together < sum(alone), (together, alone)     # runs the scenes have in common were made once
    assert main(["scene", "two_inertia", "mean_speed", "--all"]) == 2
    assert "name a scene or give --all, not both" in capsys.readouterr().err


def test_unknown_scene_is_one_line_naming_system_and_scenes(capsys):
    assert main(["scene", "two_inertia", "no_such_scene"]) == 1
    text = capsys.readouterr().err.strip()
    assert "\n" not in text and "two_inertia" in text and "no_such_scene" in text
    assert "mean_speed" in text and "peak_torque" in text


def test_the_default_scene_is_asked_when_none_is_named(monkeypatch):
    system = load("two_inertia")
    monkeypatch.setattr(system, "default_scene", "peak_torque")
    assert scenes.find_scene(system).name == "peak_torque"
    assert scenes.find_scene(system, "mean_speed").name == "mean_speed"
    monkeypatch.setattr(system, "default_scene", None)
    with pytest.raises(ValueError, match="two_inertia has no default scene: name one of mean_speed, peak_torque"):
        scenes.find_scene(system)


@pytest.mark.parametrize("name", ["two_inertia", "feeder_gto52", "spine_knife", "proof_press", "bed_drive"])
def test_every_system_names_a_default_scene_of_its_own(name):
    system = load(name)
    assert system.default_scene in {s.name for s in system.scenes}
    assert scenes.find_scene(system).name == system.default_scene


@pytest.mark.slow
# bed_drive_clutch's scenes are bed_drive's, on the same drive while its clutch is closed: answered there
@pytest.mark.parametrize("name", [n for n in system_names() if n != "bed_drive_clutch"])
def test_every_scene_of_a_system_and_two_choose_different_models(name, tmp_path, monkeypatch, capsys):
    """Every scene of every shipped system, from the command line: its full model runs with a method that runs it
    and agrees with half its step (said in the output), the chosen model meets the tolerance, and two scenes of
    a system choose different models.

    That premise holds for two_inertia too, whose components have no fidelity levels: its questions need
    different steps.  Measured with the ``jacobian`` master (the system's since it became its default): the
    mean speed stays within its 5 % up to 6.4 ms, the peak spring torque within its 1 % up to 3.2 ms only
    (gauss-seidel: 1.6 and 0.8 ms).  Both scenes chose the same 1.6 ms ``jacobian`` run because the search was
    wrong in two ways, not the scenes nor this premise: it stopped doubling at 64 times the scenes' 25 us step
    (1.6 ms, below both limits), and it called the largest step the cheapest, which held while its masters took
    one FMU step per communication step, but ``jacobian`` takes two or more.  The search now counts FMU steps and
    doubles up to 1024 times the step.

    The scenes are answered together (``--all``), so the runs they have in common (the full model and its check
    at half the step, the dearest runs of a search, when their stop times agree) are made once
    (test_all_scenes_share_their_runs_and_answer_as_each_alone checks that this gives each scene's answer alone).
    The command runs the full model and the chosen model a second time only to time them side by side for the
    speed-up it prints (that path is the default suite's, in
    test_chosen_model_meets_tolerance_is_cheaper_and_a_repeat_uses_the_cache); here the search's own wall times
    stand for them."""
    chosen, seen = [], []
    real = scenes.choose

    def keep(*args, **kwargs):
        res = real(*args, **kwargs)
        seen.append(res)
        return res

    monkeypatch.setattr(scenes, "choose", keep)
    monkeypatch.setattr(scenes, "_timed", lambda system_, scene, c, runs: c.wall_time)
    system = load(name)
    assert main(["scene", name, "--all", "--out", str(tmp_path)]) == 0, capsys.readouterr().err
    blocks = capsys.readouterr().out.split("\nscene ")
    assert len(blocks) == len(seen) == len(system.scenes), blocks
    for scene, res, out in zip(system.scenes, seen, blocks):
        assert res.scene.name == scene.name and scene.name in out.splitlines()[0], out
        assert f"full model: {res.full.master} at {res.full.step * 1e3:g} ms, agrees with its run at" in out, out
        bound = scene.tolerance * (abs(res.full.value) if scene.relative else 1.0)
        assert res.chosen.ok and res.chosen.error <= bound, (scene.name, res.chosen)
        assert (tmp_path / f"scene_{name}_{scene.name}.png").stat().st_size > 1000
        chosen.append((tuple(sorted(res.chosen.fidelities.items())), res.chosen.step, res.chosen.master))
    assert len(set(chosen)) >= 2, chosen


def _fake_runs(behaviour):
    """A stand-in for scenes._run: ``behaviour[master](step)`` is the quantity (None: the run stops), so the
    full model's choice of method is tested without running FMUs."""
    def run(system, scene, fidelities, step, full_value, master=None, runs=None):
        value = behaviour[master](step)
        if value is None:
            return scenes.Candidate(dict(fidelities), step, None, None, 0.01, False, f"{master} diverged", master, 10)
        err = 0.0 if full_value is None else abs(value - full_value)
        ok = full_value is None or err <= scenes._bound(scene, full_value)
        return scenes.Candidate(dict(fidelities), step, value, err, 0.01, ok, "", master, int(1 / step))
    return run


def _jacobi_system(monkeypatch):
    system, scene = _cheap()
    monkeypatch.setattr(system, "experiment", dataclasses.replace(system.experiment, master="jacobi"))
    return system, scene


def test_the_full_model_runs_with_the_first_method_that_runs_it_and_agrees_with_half_its_step(monkeypatch, tmp_path):
    """The system's master stops, gauss-seidel runs but its quantity moves with the step by more than a tenth of
    the tolerance: both refused, with their reasons; jacobian's is the full model, checked at half the step."""
    system, scene = _jacobi_system(monkeypatch)
    monkeypatch.setattr(scenes, "_run", _fake_runs({"jacobi": lambda h: None,
                                                    "gauss-seidel": lambda h: 1.0 + 1e3 * h,
                                                    "jacobian": lambda h: 1.0 + 1e-3 * h}))
    res = scenes.choose(system, scene, cache_dir=tmp_path)
    assert res.full.master == "jacobian" and res.full.step == scene.step and res.candidates[0] is res.full
    roles = [(c.master, c.step, c.role) for c in res.candidates if c.role != "search"]
    assert roles == [("jacobian", scene.step, "full model"), ("jacobi", scene.step, "full model refused"),
                     ("gauss-seidel", scene.step, "full model refused"),
                     ("gauss-seidel", scene.step / 2, "full model refused"),
                     ("jacobian", scene.step / 2, "full-model check")]
    text = res.full_model_text()
    assert text.startswith("full model: jacobian at 0.025 ms, agrees with its run at 0.0125 ms"), text
    assert "jacobi (jacobi diverged)" in text and "gauss-seidel (not accurate at 2.5e-05 s: differs" in text
    again = scenes.choose(system, scene, cache_dir=tmp_path)    # the cache keeps the choice and its reasons
    assert again.cached_full and again.full_model_text() == text


def test_no_method_for_the_full_model_stops_the_scene_in_one_line_and_keeps_its_runs(monkeypatch, tmp_path, capsys):
    system, scene = _jacobi_system(monkeypatch)
    monkeypatch.setattr(scenes, "_run", _fake_runs({"jacobi": lambda h: None, "gauss-seidel": lambda h: None,
                                                    "jacobian": lambda h: 1.0 + 1e3 * h}))
    monkeypatch.setattr(system, "scenes", [scene])
    assert main(["scene", "two_inertia", "mean_speed", "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith("error: scene mean_speed: no method runs the full model"), err
    assert "jacobi stopped: jacobi diverged" in err and "jacobian not accurate at 2.5e-05 s" in err
    kept = pd.read_csv(tmp_path / "scene_two_inertia_mean_speed.partial.csv")
    assert list(kept["master"]) == ["jacobi", "gauss-seidel", "jacobian", "jacobian"]
    assert not (tmp_path / "scene_two_inertia_mean_speed.csv").exists()


def test_the_cheapest_candidate_is_the_one_with_the_fewest_fmu_steps():
    """jacobian takes two or more FMU steps per communication step: a gauss-seidel run at half its step costs less."""
    a = scenes.Candidate({}, 1.6e-3, 1.0, 0.0, 0.1, True, "", "jacobian", 503)
    b = scenes.Candidate({}, 0.8e-3, 1.0, 0.0, 0.1, True, "", "gauss-seidel", 500)
    assert scenes._better(b, a) and not scenes._better(a, b)
    c = scenes.Candidate({}, 1.6e-3, 1.0, 0.0, 0.1, True, "", "gauss-seidel", 500)
    assert scenes._better(c, b)      # the same cost: the larger step
