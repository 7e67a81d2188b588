"""Content this project did not shape: a ring of plain pythonfmu FMUs (issue 16).

The FMUs are built from tests/foreign/plain_lag.py with ``pythonfmu build`` exactly as a new user would: no
ModelStructure post-processing (their outputs declare no ``dependencies``, so FMI 2.0's default makes the
ring look like an algebraic loop) and no FMU-state support.  The Jacobi and Gauss-Seidel masters must step it
(outputs taken as sampled after the step, one warning naming the FMUs), ``jacobi-sampled`` must agree with
libcosim and Ecos (the same algorithm) to 1e-9, and ``iterative`` must run it without rollback (each step
once, loops at communication points solved), saying so once.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from harness import simulate
from harness.errors import SystemError_
from harness.master import AssumptionWarning
from harness.model import Connection, Experiment, Instance, System
from harness.ssp import export_ssp
from benchmarks import peers
from foreign_builds import build_plain, plain_fmu, plain_lag

HERE = Path(__file__).parent
N_RING = 6
STOP, STEP = 2.0, 0.01


@pytest.fixture(scope="session")
def plain_lag_fmu() -> Path:
    return plain_lag()


def ring(fmu: Path, n: int = N_RING) -> System:
    """n lags in a ring, each driven by the previous one's output; different initial values and gains."""
    insts = [Instance(f"lag{i}", str(fmu), {"y0": float(i + 1), "k": -0.5 + 0.1 * i, "tau": 0.5 + 0.2 * i})
             for i in range(n)]
    conns = [Connection(f"lag{(i - 1) % n}.y", f"lag{i}.u") for i in range(n)]
    return System("plain_ring", insts, conns, experiment=Experiment(stop_time=STOP, step=STEP))


def expected_sampled(system: System, n_steps: int) -> np.ndarray:
    """The ring stepped by hand with the sampled Jacobi algorithm (inputs at t_k = outputs sampled at t_k)."""
    p = [inst.parameters for inst in system.instances]
    y = np.array([q["y0"] for q in p])
    k, tau = np.array([q["k"] for q in p]), np.array([q["tau"] for q in p])
    rows = [y.copy()]
    for _ in range(n_steps):
        u = np.roll(y, 1)
        y = y + STEP * (k * u - y) / tau
        rows.append(y.copy())
    return np.array(rows)


def run(system, master, **kw):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        df = simulate(system, master=master, **kw)
    return df, [w for w in caught if issubclass(w.category, AssumptionWarning)]


@pytest.mark.parametrize("master", ["jacobi-sampled", "jacobi", "gauss-seidel"])
def test_ring_of_plain_pythonfmu_fmus_runs(plain_lag_fmu, master):
    system = ring(plain_lag_fmu)
    df, notes = run(system, master)
    assert len(df) == round(STOP / STEP) + 1
    assert len(notes) == 1, [str(w.message) for w in notes]
    text = str(notes[0].message)
    assert "\n" not in text and "declare no output dependencies" in text
    for i in range(N_RING):
        assert f"lag{i} (PlainLag)" in text
    cols = [f"lag{i}.y" for i in range(N_RING)]
    assert np.isfinite(df[cols].to_numpy()).all()
    np.testing.assert_array_equal(df[cols].iloc[0].to_numpy(), np.arange(1.0, N_RING + 1))
    if master in ("jacobi-sampled", "jacobi"):
        # no declared feed-through: the refresh of jacobi changes nothing; both are the sampled algorithm
        np.testing.assert_allclose(df[cols].to_numpy(), expected_sampled(system, len(df) - 1),
                                   rtol=1e-12, atol=1e-14)
    else:
        # Gauss-Seidel: lag0 uses lag5's sample at t, every later lag its predecessor's sample at t+h
        ref = expected_sampled(system, len(df) - 1)
        assert np.abs(df[cols].to_numpy() - ref).max() > 1e-6


def test_iterative_without_state_support_steps_once_and_says_so(plain_lag_fmu):
    """No canGetAndSetFMUstate: iterative cannot repeat a step, so it takes each step once on the held inputs
    and still solves loops at communication points (none declared here): the result is jacobi's, and one
    warning names every FMU that cannot roll back."""
    system = ring(plain_lag_fmu)
    df, notes = run(system, "iterative")
    ref, _ = run(system, "jacobi")
    assert df.attrs["complete"], df.attrs.get("error")
    cols = [f"lag{i}.y" for i in range(N_RING)]
    np.testing.assert_allclose(df[cols].to_numpy(), ref[cols].to_numpy(), rtol=1e-13, atol=1e-15)
    rollback = [str(w.message) for w in notes if "cannot roll back" in str(w.message)]
    assert len(rollback) == 1 and "\n" not in rollback[0]
    assert all(f"lag{i} (PlainLag)" in rollback[0] for i in range(N_RING))


def test_step_control_with_rollback_names_the_fmu(plain_lag_fmu):
    """Step doubling repeats steps: on FMUs without state support it still refuses, naming the instance."""
    with pytest.raises(SystemError_) as e:
        run(ring(plain_lag_fmu), "jacobi", step_control="richardson", tolerance=1e-6)
    msg = str(e.value)
    assert "\n" not in msg and "lag0" in msg and "canGetAndSetFMUstate" in msg


@pytest.fixture(scope="module")
def ring_ssp(plain_lag_fmu, tmp_path_factory) -> Path:
    return export_ssp(ring(plain_lag_fmu), tmp_path_factory.mktemp("ring_ssp") / "plain_ring.ssp")


@pytest.mark.parametrize("tool", ["libcosim", "ecos"])
def test_ring_agrees_with_peer_tools(ring_ssp, tool):
    avail = peers.available()
    if avail.get(tool) is not None:
        pytest.skip(f"{tool} not available: {avail[tool]}")
    cols = [f"lag{i}.y" for i in range(N_RING)]
    ref, _ = run(ring_ssp, "jacobi-sampled")
    if tool == "libcosim":
        df = peers.run_ssp_libcosim(ring_ssp, STOP, STEP, cols)
    else:
        df = peers.run_ssp_ecos(ring_ssp, STOP, STEP, cols, parameter_set="default")
    assert len(df) == len(ref)
    np.testing.assert_allclose(df.index.to_numpy(), ref.index.to_numpy(), rtol=1e-12, atol=1e-15)
    diff = np.abs(df[cols].to_numpy() - ref[cols].to_numpy())
    err = diff.max() / np.abs(ref[cols].to_numpy()).max()
    assert err <= 1e-9, f"{tool}: ring differs from jacobi-sampled by {err:.3g}"


# ----------------------------------------------------------------------------- Integer, Boolean, String variables
@pytest.fixture(scope="module")
def typed_system() -> System:
    stairs, tally = plain_fmu("plain_stairs.py", "Stairs"), plain_fmu("plain_tally.py", "Tally")
    return System("typed", [Instance("st", str(stairs), {"every": 2}),
                            Instance("ta", str(tally), {"bonus": 0.5, "label": "counted"})],
                  [Connection("st.n", "ta.n"), Connection("st.odd", "ta.odd")],
                  experiment=Experiment(stop_time=1.0, step=0.1))


def expected_tally(n_steps: int, every: int = 2, bonus: float = 0.5):
    """Stairs' outputs after k steps are n_k = k // every, odd_k; Tally steps on the values sampled at t_k."""
    n = [k // every for k in range(n_steps + 1)]
    y = [0.0]
    for k in range(n_steps):
        y.append(y[-1] + n[k] + (bonus if n[k] % 2 else 0.0))
    return np.array(n), np.array(y)


@pytest.mark.parametrize("master", ["jacobi-sampled", "jacobi", "gauss-seidel"])
def test_integer_and_boolean_connections(typed_system, master):
    df, _ = run(typed_system, master)
    assert df["st.n"].dtype == np.int64 and df["ta.n_seen"].dtype == np.int64
    assert df["st.odd"].dtype == bool and df["ta.y"].dtype == np.float64
    n, y = expected_tally(len(df) - 1)
    np.testing.assert_array_equal(df["st.n"].to_numpy(), n)
    np.testing.assert_array_equal(df["st.odd"].to_numpy(), n % 2 == 1)
    np.testing.assert_array_equal(df["ta.n_seen"].to_numpy()[1:], n[:-1])  # the value held over each step
    np.testing.assert_allclose(df["ta.y"].to_numpy(), y, rtol=0, atol=1e-12)


def test_typed_parameters_set_and_checked(typed_system):
    df, _ = run(typed_system, "jacobi-sampled", parameters={"st.every": 3, "ta.bonus": 2.0, "ta.label": "x"})
    n, y = expected_tally(len(df) - 1, every=3, bonus=2.0)
    np.testing.assert_array_equal(df["st.n"].to_numpy(), n)
    np.testing.assert_allclose(df["ta.y"].to_numpy(), y, rtol=0, atol=1e-12)
    for bad, word in (({"st.every": 1.5}, "integer"), ({"ta.label": 3}, "string")):
        with pytest.raises(SystemError_, match=word):
            run(typed_system, "jacobi-sampled", parameters=bad)


def test_typed_connection_rules(typed_system):
    import dataclasses
    wrong = dataclasses.replace(typed_system, connections=[Connection("st.n", "ta.odd")])
    with pytest.raises(SystemError_, match="type mismatch: st.n is Integer but ta.odd is Boolean"):
        run(wrong, "jacobi")
    scaled = dataclasses.replace(typed_system, connections=[Connection("st.n", "ta.n", factor=2.0)])
    with pytest.raises(SystemError_, match="linear transformation applies to Real variables only"):
        run(scaled, "jacobi")


@pytest.mark.parametrize("tool", ["harness", "libcosim", "ecos"])
def test_typed_system_through_ssp(typed_system, tmp_path, tool):
    """The exported SSP (typed connectors, Integer/Real/String ParameterBindings) reloads to the same result and
    runs in libcosim and Ecos with the same Real output (the Integer/Boolean values pass the same way)."""
    ssp = export_ssp(typed_system, tmp_path / "typed.ssp")
    ref, _ = run(typed_system, "jacobi-sampled")
    if tool == "harness":
        again, _ = run(ssp, "jacobi-sampled")
        assert again.equals(ref)
        return
    avail = peers.available()
    if avail.get(tool) is not None:
        pytest.skip(f"{tool} not available: {avail[tool]}")
    if tool == "libcosim":
        df = peers.run_ssp_libcosim(ssp, 1.0, 0.1, ["ta.y"])
    else:
        df = peers.run_ssp_ecos(ssp, 1.0, 0.1, ["ta.y"], parameter_set="default")
    assert len(df) == len(ref)
    np.testing.assert_allclose(df["ta.y"].to_numpy(), ref["ta.y"].to_numpy(), rtol=1e-12, atol=1e-12)


# ----------------------------------------------------------------------------- the in-process path for plain FMUs
@pytest.mark.parametrize("master", ["jacobi-sampled", "jacobi", "gauss-seidel", "iterative"])
def test_plain_fmus_run_in_process_by_default_bit_identical_to_their_c_wrapper(plain_lag_fmu, typed_system, master):
    """By default a plain pythonfmu FMU's slave object is called in this process (no C round trip); the
    result is the same bit for bit as through its C wrapper (``in_process=False``, the CLI's --fmi-only)."""
    from harness import RunOptions
    from harness.fmi import open_instance
    from harness.fmi.inprocess import InProcessFMU

    inst = open_instance(plain_lag_fmu, "probe")
    assert isinstance(inst, InProcessFMU)
    inst.free()
    for system in (ring(plain_lag_fmu), typed_system):
        fast, _ = run(system, master)
        slow, _ = run(system, master, options=RunOptions(in_process=False))
        assert fast.attrs["complete"] and slow.attrs["complete"]
        assert list(fast.columns) == list(slow.columns)
        assert (fast.dtypes == slow.dtypes).all()
        assert fast.equals(slow), f"{system.name} {master}: in-process and FMI paths differ"


RAMP = '''
from pythonfmu import Fmi2Causality, Fmi2Slave, Real


class {cls}(Fmi2Slave):
    """y grows at a fixed rate; two such scripts share one file name."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.y = 0.0
        self.register_variable(Real("y", causality=Fmi2Causality.output))

    def do_step(self, current_time, step_size):
        self.y += {rate} * step_size
        return True
'''


def test_two_plain_fmus_built_from_scripts_of_one_file_name_run_in_one_system(tmp_path):
    """pythonfmu's C wrapper imports a script under its own file name, so in one process the first such
    module wins; the in-process path imports each FMU's script under a name of its own."""
    fmus = {}
    for cls, rate in (("RampUp", 2.0), ("RampDown", -1.0)):
        folder = tmp_path / cls
        folder.mkdir()
        (folder / "plain_ramp.py").write_text(RAMP.format(cls=cls, rate=rate))
        fmus[cls] = build_plain(folder / "plain_ramp.py", cls, folder)
    system = System("ramps", [Instance("up", str(fmus["RampUp"])), Instance("down", str(fmus["RampDown"]))], [],
                    experiment=Experiment(stop_time=1.0, step=0.25))
    df, _ = run(system, "jacobi")
    np.testing.assert_allclose(df["up.y"].to_numpy(), 2.0 * df.index.to_numpy(), rtol=0, atol=1e-15)
    np.testing.assert_allclose(df["down.y"].to_numpy(), -1.0 * df.index.to_numpy(), rtol=0, atol=1e-15)


def test_a_script_that_does_not_import_here_falls_back_to_fmi_in_one_line(plain_lag_fmu, monkeypatch):
    """If the script cannot be imported in this process the FMU runs through its C wrapper, with one warning
    naming the FMU and the reason; in_process=True makes it an error."""
    from harness.errors import FMUError
    from harness.fmi import FMU, InProcessFallback, inprocess, open_instance

    def broken(unzip_dir):
        raise ModuleNotFoundError("No module named 'hydraulics'")

    monkeypatch.setattr(inprocess, "slave_class", broken)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        inst = open_instance(plain_lag_fmu, "lag")
    notes = [str(w.message) for w in caught if issubclass(w.category, InProcessFallback)]
    assert len(notes) == 1 and "\n" not in notes[0], notes
    assert "PlainLag.fmu (lag)" in notes[0] and "hydraulics" in notes[0] and "FMI library" in notes[0]
    assert isinstance(inst, FMU)
    inst.setup(0.0)
    inst.enter_initialization()
    inst.exit_initialization()
    inst.do_step(0.0, 0.01)
    inst.free()
    with pytest.raises(FMUError, match="hydraulics"):
        open_instance(plain_lag_fmu, "lag", in_process=True)


def test_cli_fmi_only_gives_the_same_csv(ring_ssp, tmp_path):
    from harness.__main__ import main

    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["run", str(ring_ssp), "--master", "jacobi-sampled", "--out", str(a)]) == 0
    assert main(["run", str(ring_ssp), "--master", "jacobi-sampled", "--fmi-only", "--out", str(b)]) == 0
    assert a.read_text() == b.read_text()


def test_an_output_outside_its_declared_range_stops_the_run_in_one_line(plain_lag_fmu):
    """A foreign FMU's output beyond the ``max`` its model description declares is a wrong result: the run
    stops, naming the instance, variable, value and declared range (pythonfmu cannot declare one, so the
    cached model description is given one here)."""
    from harness.fmi.cache import model_description

    var = next(v for v in model_description(plain_lag_fmu).modelVariables if v.name == "y")
    old = var.max
    var.max = "3.5"
    try:
        df, _ = run(ring(plain_lag_fmu), "jacobi", on_error="return")
    finally:
        var.max = old
    assert not df.attrs["complete"]
    err = df.attrs["error"]
    assert "\n" not in err and "instance lag3: output y = 4.0 is outside the range [-inf, 3.5]" in err
    assert "PlainLag" in err


def test_an_fmu_without_outputs_records_its_states():
    """Issue 33: an FMU with no outputs gave an empty result; its continuous local variables (its states, as a
    plain model declares them) are recorded instead."""
    fmu = plain_fmu("plain_decay.py", "PlainDecay")
    s = System("decay", [Instance("d", str(fmu))], experiment=Experiment(stop_time=0.5, step=0.05))
    df, _ = run(s, "jacobi")
    assert list(df.columns) == ["d.x"]
    np.testing.assert_allclose(df["d.x"].to_numpy(), (1 - 0.05 / 0.5) ** np.arange(11), rtol=1e-12)


def test_an_fmu_with_nothing_to_record_says_what_to_ask_for():
    fmu = plain_fmu("plain_quiet.py", "PlainQuiet")
    s = System("quiet", [Instance("q", str(fmu))], experiment=Experiment(stop_time=0.5, step=0.05))
    with pytest.raises(SystemError_) as e:
        run(s, "jacobi")
    msg = str(e.value)
    assert "\n" not in msg and "instance q (PlainQuiet) has no outputs" in msg and "output=[...]" in msg
    assert "q.gain" in msg
    df, _ = run(s, "jacobi", output=["q.gain"])        # asked for: recorded
    assert (df["q.gain"] == 2.0).all()
