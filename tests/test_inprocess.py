"""The in-process path for pythonfmu FMUs (harness.fmi.inprocess) against the FMI path through the FMUs' C library.

* every press drive, with every master (and extrapolation 0 and 1): values, times, bond energies and the
  completion flag are bit-identical between the two paths;
* a run that fails (a bad parameter; a non-finite input) stops with the same one-line error on both paths;
* rollback through the in-process state is bit-exact (the iterative master and step doubling repeat steps);
* a pythonfmu FMU that is NOT the toolkit's (a plain Fmi2Slave built here) runs through FMI by default and,
  when asked, in-process with the same results (an FMU that is not a pythonfmu FMU is never run in-process:
  tests/test_c_fmu.py).
"""
from __future__ import annotations

import textwrap
import warnings

import numpy as np
import pytest

from harness import RunOptions, load, simulate
from harness.errors import FMUError
from harness.fmi import FMU, open_instance
from harness.fmi.inprocess import InProcessFMU, slave_class

SYSTEMS = ["feeder_gto52", "bed_drive", "spine_knife", "proof_press", "two_inertia"]
FMI = RunOptions(in_process=False)
INPROC = RunOptions(in_process=None)


@pytest.fixture(autouse=True)
def _built(fmu_dir, monkeypatch):
    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))


def _same(a, b) -> None:
    assert list(a.columns) == list(b.columns)
    assert np.array_equal(a.index.values, b.index.values)
    assert np.array_equal(a.values, b.values, equal_nan=True)
    assert a.attrs["complete"] == b.attrs["complete"] and a.attrs["error"] == b.attrs["error"]
    ea, eb = a.attrs["bonds"], b.attrs["bonds"]
    assert np.array_equal(ea.energy, eb.energy) and np.array_equal(ea.p_out, eb.p_out)


def _run(system, options, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(system, options=options, **kw)


@pytest.mark.parametrize("name", SYSTEMS)
@pytest.mark.parametrize("master", ["jacobi", "jacobi-sampled", "gauss-seidel", "iterative"])
def test_every_press_drive_is_bit_identical_to_the_fmi_path(name, master):
    system = load(name)
    h = system.experiment.step
    n = 20 if master == "iterative" else 120
    for order in (0, 1):
        kw = dict(stop_time=n * h, step=h, master=master, extrapolation=order)
        a, b = _run(system, FMI, **kw), _run(system, INPROC, **kw)
        assert len(a) > 10  # (bed_drive under jacobi-sampled blows up at this step: the same on both paths)
        _same(a, b)


def test_the_default_path_is_in_process_for_the_toolkit_fmus(fmu_dir):
    fmu = open_instance(fmu_dir / "Inertia.fmu", "a")
    assert isinstance(fmu, InProcessFMU) and fmu.path_kind == "in-process"
    fmi = open_instance(fmu_dir / "Inertia.fmu", "b", in_process=False)
    assert isinstance(fmi, FMU) and fmi.path_kind == "fmi"
    for f in (fmu, fmi):
        f.free()
    with pytest.raises(FMUError, match="in_process = 'yes' is not admissible"):
        open_instance(fmu_dir / "Inertia.fmu", "c", in_process="yes")


def test_step_doubling_rollback_is_bit_identical():
    kw = dict(stop_time=0.05, step=1e-3, master="jacobi", extrapolation=1, step_control="richardson",
              tolerance=1e-6)
    a, b = _run(load("two_inertia"), FMI, **kw), _run(load("two_inertia"), INPROC, **kw)
    assert a.attrs["steps"] == b.attrs["steps"] and a.attrs["rejected"] == b.attrs["rejected"]
    _same(a, b)


@pytest.mark.parametrize("parameters, expected", [
    ({"fourbar.crank_length": -0.1}, "parameter crank_length = -0.1 m is not admissible"),
    ({"bed.m_T": float("nan")}, "parameter m_T = nan kg is not admissible"),
])
def test_a_failing_run_has_the_same_error_on_both_paths(parameters, expected):
    system = load("bed_drive")
    runs = [_run(system, options, stop_time=0.01, parameters=parameters) for options in (FMI, INPROC)]
    _same(*runs)
    error = runs[0].attrs["error"]
    assert not runs[0].attrs["complete"] and expected in error and len(error.splitlines()) == 1


def test_a_non_finite_input_fails_the_same_way_on_both_paths():
    # a blow-up far beyond the float range: the first FMU fed with inf or nan names its input
    results = []
    for options in (FMI, INPROC):
        df = _run(load("two_inertia"), options, stop_time=0.2, step=1e-3,
                  parameters={"b.c": 1e300, "b.J": 1e-300})
        results.append(df)
    _same(*results)
    assert not results[0].attrs["complete"]


# -- a pythonfmu FMU that is not the toolkit's ------------------------------------------------------------------
FOREIGN = textwrap.dedent('''
    from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


    class ForeignDecay(Fmi2Slave):
        """dx/dt = -k*x + u (explicit Euler inside the step); y = x."""

        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.k = 2.0
            self.u = 0.0
            self.x = 1.0
            self.register_variable(Real("k", causality=Fmi2Causality.parameter,
                                        variability=Fmi2Variability.tunable))
            self.register_variable(Real("u", causality=Fmi2Causality.input))
            self.register_variable(Real("x", causality=Fmi2Causality.output))

        def do_step(self, current_time, step_size):
            self.x += step_size * (-self.k * self.x + self.u)
            return True
''')


@pytest.fixture(scope="module")
def foreign_fmu(tmp_path_factory):
    from pythonfmu import FmuBuilder

    work = tmp_path_factory.mktemp("foreign")
    script = work / "pd_test_foreign_decay.py"
    script.write_text(FOREIGN)
    return FmuBuilder.build_FMU(script, dest=work, needsExecutionTool="true", canGetAndSetFMUstate="true")


def test_a_foreign_pythonfmu_fmu_runs_in_process_by_default_and_through_fmi_on_request(foreign_fmu):
    from harness.fmi.fmu import extracted
    from harness.model import Connection, Experiment, Instance, System

    _, unzip_dir = extracted(foreign_fmu)
    assert slave_class(unzip_dir).__name__ == "ForeignDecay"
    default = open_instance(foreign_fmu, "probe")
    assert isinstance(default, InProcessFMU)
    default.free()
    fmi = open_instance(foreign_fmu, "probe", in_process=False)
    assert isinstance(fmi, FMU) and not isinstance(fmi, InProcessFMU)
    fmi.free()
    # without ModelStructure dependencies (pythonfmu writes none) every output depends on every input: the
    # ring is an algebraic loop for the importer, which only the iterative master takes
    ring = System(name="foreign", instances=[Instance("a", str(foreign_fmu), {"k": 3.0}),
                                             Instance("b", str(foreign_fmu))],
                  connections=[Connection("a.x", "b.u"), Connection("b.x", "a.u", factor=-0.5)],
                  experiment=Experiment(0.2, 1e-3, master="iterative"))
    single = System(name="single", instances=[Instance("a", str(foreign_fmu), {"k": 3.0, "u": 0.5})],
                    experiment=Experiment(0.2, 1e-3, master="jacobi"))
    runs = [_run(s, RunOptions(in_process=p)) for s in (ring, single) for p in (False, None)]
    _same(runs[0], runs[1])
    _same(runs[2], runs[3])
    assert runs[0].attrs["complete"] and runs[2].attrs["complete"]
    assert runs[0]["a.x"].iloc[-1] != runs[0]["a.x"].iloc[0]


def test_loading_an_fmu_first_does_not_break_later_builds(fmu_dir, tmp_path):
    """A pythonfmu FMU carries pythonfmu without its binaries and goes first on sys.path when loaded; a fresh
    process that loads one and then builds an FMU must still build it with binaries (the installed pythonfmu)."""
    import subprocess
    import sys
    import zipfile
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    code = (f"from harness.fmi import open_instance; open_instance({str(fmu_dir / 'Gain.fmu')!r}, 'g');"
            f"from fmus.build import main; raise SystemExit(main(['--out', {str(tmp_path)!r}, '--only', 'pd_gain']))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=str(root), timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    with zipfile.ZipFile(tmp_path / "Gain.fmu") as z:
        assert any(n.startswith("binaries/linux64/") and n.endswith(".so") for n in z.namelist())
