"""Every study of every shipped drive runs from the command line (slow: each runs the drive many times).

The scenes (tests/test_scenes.py) and the precision studies (tests/test_precision.py) of every system run from
the command line there; here the accuracy study of every drive that declares an accuracy and the stability map
of every drive that declares one (and of the two-inertia benchmark).  The full default map of one drive runs in
tests/test_stability.py; here each map runs with ``--quick`` at one value of its coupling parameter (the
command, its runs, its table and its chart, not the whole grid: that would cost the suite tens of minutes), at
extrapolation order 1 (jacobi, gauss-seidel and jacobian: three rows)."""
from __future__ import annotations

import pandas as pd
import pytest

from harness import load
from harness.__main__ import main
from harness.run import system_names

ACCURACY = [n for n in system_names() if load(n).accuracy is not None]
STABILITY = [n for n in system_names() if load(n).stability is not None]


@pytest.fixture(autouse=True)
def _fmus(fmu_dir, monkeypatch):
    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))


def test_the_lists_hold_every_drive_that_declares_a_study():
    assert set(ACCURACY) == {"bed_drive", "feeder_gto52", "proof_press", "spine_knife", "trimmer_conveyor"}
    assert set(STABILITY) == {"bed_drive", "feeder_gto52", "proof_press", "spine_knife"}


@pytest.mark.slow
@pytest.mark.parametrize("name", ACCURACY)
def test_accuracy_study_of_every_drive(name, tmp_path, capsys, monkeypatch):
    """The ladder at the drive's default step and twice it, every default method: a row per run, each judged by
    every requirement, and the cheapest that meets the accuracy named (the default method meets it at its step).
    The drive's monolithic reference is the one the other tests use (computed once: tests/reference_cache.py)."""
    from reference_cache import sharing

    sharing(monkeypatch)
    system = load(name)
    h = system.experiment.step
    assert main(["study", "accuracy", name, "--steps", str(h), str(2 * h), "--out", str(tmp_path)]) == 0, \
        capsys.readouterr().err
    out = capsys.readouterr().out
    assert out.startswith(f"{name}: cheapest that meets its accuracy: "), out
    table = pd.read_csv(tmp_path / f"accuracy_{name}.csv")
    assert len(table) == 2 * 3 and table["meets"].any()
    for req in system.accuracy.requirements:
        assert req.name in table.columns


@pytest.mark.slow
@pytest.mark.parametrize("name", STABILITY)
def test_stability_map_of_every_drive(name, tmp_path, capsys):
    spec = load(name).stability
    value = spec.quick_values[0]
    assert main(["study", "stability", name, "--quick", "--values", repr(value), "--orders", "1",
                 "--out", str(tmp_path)]) == 0, capsys.readouterr().err
    stem = tmp_path / f"stability_{name}_{spec.sweep.replace('.', '_')}"
    table = pd.read_csv(stem.with_suffix(".csv"))
    assert list(table["master"]) == ["jacobi", "gauss-seidel", "jacobian"]
    assert set(table["status"]) <= {"bracketed", "stable to cap", "unstable at floor"}
    assert stem.with_suffix(".png").stat().st_size > 1000


@pytest.mark.slow
def test_stability_map_of_the_two_inertia_benchmark_measured(tmp_path, capsys):
    """Theory and bisection on runs (``--quick`` is theory only): the default study, the command docs/stability.md
    shows, run once, here (tests/test_docs.py: RUN_BY_TESTS), instead of one inertia ratio here (``--values 1``)
    and the whole study for the page."""
    assert main(["study", "stability", "two_inertia", "--out", str(tmp_path)]) == 0, capsys.readouterr().err
    table = pd.read_csv(tmp_path / "stability_two_inertia_inertia.csv")
    assert len(table) > 0 and (tmp_path / "stability_two_inertia_inertia.png").stat().st_size > 1000
