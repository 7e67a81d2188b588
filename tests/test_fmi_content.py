"""FMI content other people bring (issue 33): what was wrong, and what is new.

* FMI 1.0 String values (the ViProMa identity FMU from libcosim's test data, and tests/fmi1_string/identity.c,
  an FMI 1.0 co-simulation FMU written for this test, compiled with the system C compiler): a String passes
  through a chain of two connections unchanged (it used to arrive as "b'hello'", then as "b\"b'hello'\"").
* FMI 3.0 co-simulation (harness/fmi/fmu3.py): the Modelica Reference-FMUs 3.0, built from the pinned sources
  in tests/reference_fmus with cmake (-DFMI_VERSION=3), each alone under every master agrees with
  fmpy.simulate_fmu (the same FMU, fmpy's own FMI 3.0 calls) exactly, and a system of them with Float64,
  Float32, Int32 and Boolean connections gives under every master exactly what the same system of their FMI 2.0
  builds gives (same C models, other FMI version).  Clocks and arrays are refused in one line naming them.
* Model Exchange (harness/fmi/me.py): the Reference-FMUs BouncingBall (state events), VanDerPol, Dahlquist,
  Stair (time events), Feedthrough and Resource through their FMI 2.0 and 3.0 ME interfaces, each alone, agree with
  fmpy.simulate_fmu(fmi_type="ModelExchange") at the same relative tolerance (the same CVODE); in a system with
  co-simulation FMUs and a discrete input (set in event mode) they run under every master, rollback included;
  an SSD component with implementation="ModelExchange" runs as ME (it used to run as co-simulation).
* pythonfmu3 (tests/pythonfmu3/pythonslave.py, pythonfmu3's own test slave): an Fmi3Slave FMU runs through
  its FMI 3.0 library under every master and agrees with fmpy; it used to be taken for a pythonfmu (FMI 2.0)
  FMU by the in-process path.
"""
from __future__ import annotations

import shutil
import subprocess
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness.errors import FMUError
from harness.model import Connection, Experiment, Instance, System
from build_cache import BuildError, cached, compiler, run
from reference_builds import quiet, reference_fmus, reference_system

HERE = Path(__file__).resolve().parent
MASTERS = ("jacobi", "jacobi-sampled", "gauss-seidel", "iterative")
REFERENCE = ("BouncingBall", "Dahlquist", "Feedthrough", "Resource", "Stair", "VanDerPol")


@pytest.fixture(scope="session")
def identity1(tmp_path_factory) -> Path:
    """tests/fmi1_string as an FMI 1.0 co-simulation FMU (Identity1.fmu)."""
    src = HERE / "fmi1_string"
    out = tmp_path_factory.mktemp("fmi1_string")
    lib = out / "Identity1.so"
    r = subprocess.run([compiler(), "-shared", "-fPIC", "-O1", "-fvisibility=hidden", "-o", str(lib),
                        str(src / "identity.c")], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.fail(f"compiling tests/fmi1_string/identity.c failed: {r.stderr.strip()[-600:]}", pytrace=False)
    fmu = out / "Identity1.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.write(src / "modelDescription.xml", "modelDescription.xml")
        z.write(lib, "binaries/linux64/Identity1.so")
    return fmu


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_viproma_identity_fmu_passes_every_type_through_two_connections(master):
    """The issue's own case, on the FMU it names (libcosim's test data, tests/fmi1_identity): 'hello' through
    a -> b -> c arrives as 'hello' (Ecos: hello, hello; the master gave "b'hello'", then "b\"b'hello'\"");
    the Real, Integer and Boolean outputs pass unchanged too."""
    fmu = str(HERE / "fmi1_identity" / "identity.fmu")
    start = {"stringIn": "hello", "realIn": 2.5, "integerIn": -7, "booleanIn": True}
    system = System("identity", [Instance("a", fmu, start), Instance("b", fmu), Instance("c", fmu)],
                    [Connection(f"a.{k}Out", f"b.{k}In") for k in ("real", "integer", "boolean", "string")]
                    + [Connection(f"b.{k}Out", f"c.{k}In") for k in ("real", "integer", "boolean", "string")],
                    experiment=Experiment(stop_time=0.05, step=0.01))
    df = quiet(system, master=master, on_error="raise")
    assert df.attrs["complete"]
    for k, value in (("string", "hello"), ("real", 2.5), ("integer", -7), ("boolean", True)):
        assert list(df[f"a.{k}Out"]) == [value] * 6
        assert df[f"c.{k}Out"].iloc[-1] == value and df[f"b.{k}Out"].iloc[-1] == value


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_fmi1_string_passes_a_chain_of_two_connections_unchanged(identity1, master):
    system = System("strings", [Instance("a", str(identity1), {"u": "hello"}), Instance("b", str(identity1)),
                                Instance("c", str(identity1))],
                    [Connection("a.y", "b.u"), Connection("b.y", "c.u")],
                    experiment=Experiment(stop_time=0.03, step=0.01))
    df = quiet(system, master=master, on_error="raise")
    assert df.attrs["complete"]
    assert list(df["a.y"]) == ["hello"] * 4
    assert list(df["c.y"])[-1] == "hello"
    assert set(df["b.y"]) <= {"", "hello"} and set(df["c.y"]) <= {"", "hello"}


# ------------------------------------------------------------------------------------------------ FMI 3.0
@pytest.fixture(scope="session")
def reference3() -> dict[str, Path]:
    return reference_fmus(3)


@pytest.fixture(scope="session")
def reference2() -> dict[str, Path]:
    return reference_fmus(2)


def assert_agrees(df: pd.DataFrame, ref: pd.DataFrame, prefix: str, rtol: float, what: str) -> int:
    """Every column of fmpy's result ``ref`` equals ours (``prefix`` + name) to ``rtol`` of its magnitude."""
    assert len(df) == len(ref), what
    np.testing.assert_allclose(df.index.to_numpy(), ref.index.to_numpy(), rtol=1e-12, atol=1e-12)
    for col in ref.columns:
        ours = df[f"{prefix}{col}"]
        if ours.dtype == object:
            assert list(ours) == [v.decode() if isinstance(v, bytes) else v for v in ref[col]], f"{what}: {col}"
            continue
        a, b = ours.to_numpy(dtype=float), ref[col].to_numpy(dtype=float)
        err = np.abs(a - b).max() / max(np.abs(b).max(), 1.0)
        assert err <= rtol, f"{what}: {col} differs by {err:.3g}"
    return len(ref.columns)


@pytest.mark.parametrize("master", MASTERS)
@pytest.mark.parametrize("model", REFERENCE)
def test_reference_fmu_3_alone_matches_fmpy(reference3, model, master):
    from fmpy import simulate_fmu

    fmu = reference3[model]
    stop, step = 3.0, 0.01
    df = quiet(System(model, [Instance("m", str(fmu))], experiment=Experiment(stop_time=stop, step=step)),
               master=master, on_error="raise")
    assert df.attrs["complete"]
    ref = pd.DataFrame(simulate_fmu(str(fmu), stop_time=stop, step_size=step, output_interval=step,
                                    fmi_type="CoSimulation")).set_index("time")
    assert assert_agrees(df, ref, "m.", 1e-12, f"{model} under {master}") >= 1


@pytest.mark.parametrize("master", MASTERS)
def test_reference_system_3_equals_the_same_system_of_fmi2_builds(reference3, reference2, master):
    df3 = quiet(reference_system(reference3), master=master, on_error="raise")
    df2 = quiet(reference_system(reference2), master=master, on_error="raise")
    assert df3.attrs["complete"] and df2.attrs["complete"] and len(df3) == 301
    common = [c for c in df2.columns if c in df3.columns]
    assert len(common) >= 12
    for c in common:
        assert (df3[c].to_numpy() == df2[c].to_numpy()).all(), f"{master}: {c}"
    assert df3["stair.counter"].iloc[-1] > df3["stair.counter"].iloc[0]


def test_float32_connection_of_fmi3(reference3):
    fmus = reference3
    system = System("f32", [Instance("vdp", str(fmus["VanDerPol"])), Instance("ft", str(fmus["Feedthrough"])),
                            Instance("ft2", str(fmus["Feedthrough"]))],
                    [Connection("vdp.x0", "ft.Float32_continuous_input"),
                     Connection("ft.Float32_continuous_output", "ft2.Float32_continuous_input")],
                    experiment=Experiment(stop_time=0.5, step=0.01))
    df = quiet(system, master="gauss-seidel", on_error="raise")
    x0 = df["vdp.x0"].to_numpy()
    # Feedthrough copies its Float32 input to its output: x0 rounded to single precision (gauss-seidel: same point)
    np.testing.assert_array_equal(df["ft2.Float32_continuous_output"].to_numpy(), x0.astype(np.float32).astype(float))


@pytest.mark.parametrize("model,message", [
    ("Clocks", "Clocks.fmu is not a co-simulation FMU (FMI 3.0, scheduled execution only)"),
])
def test_fmi3_clocks_are_refused_in_one_line(reference3, model, message):
    with pytest.raises(FMUError) as info:
        quiet(System(model, [Instance("m", str(reference3[model]))], experiment=Experiment(stop_time=0.1, step=0.01)),
              on_error="raise")
    assert message in str(info.value) and "\n" not in str(info.value)


def test_fmi3_clock_variables_in_a_co_simulation_fmu_are_refused(reference3, tmp_path):
    """A co-simulation FMU that declares a Clock (made from Stair by adding one to its description)."""
    src = reference3["Stair"]
    fmu = tmp_path / "StairClock.fmu"
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(fmu, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                text = data.decode()
                assert text.count("</ModelVariables>") == 1
                data = text.replace("</ModelVariables>", '<Clock name="tick" valueReference="99" '
                                    'causality="input" intervalVariability="triggered"/></ModelVariables>').encode()
            zout.writestr(item, data)
    with pytest.raises(FMUError, match="declares Clock variables \\(tick\\): FMI 3.0 clocks are not supported"):
        quiet(System("c", [Instance("m", str(fmu))], experiment=Experiment(stop_time=0.1, step=0.01)),
              on_error="raise")


# ------------------------------------------------------------------------------------------------ pythonfmu3
def _pythonfmu3_build(script: str, model: str) -> Path:
    """tests/pythonfmu3/<script> built by ``python -m pythonfmu3 build`` (shared, tests/build_cache.py; pythonfmu3 is
    a dependency: a failed build fails)."""
    import sys
    from importlib import metadata

    def make(out: Path) -> None:
        run([sys.executable, "-m", "pythonfmu3", "build", "-f", HERE / "pythonfmu3" / script, "-d", out],
            f"pythonfmu3 build of {script}")
        if not (out / f"{model}.fmu").is_file():
            raise BuildError(f"pythonfmu3 build of {script} made no {model}.fmu")

    return cached(f"pythonfmu3-{model}", [HERE / "pythonfmu3" / script, metadata.version("pythonfmu3")],
                  make) / f"{model}.fmu"


@pytest.fixture(scope="session")
def pythonslave3() -> Path:
    return _pythonfmu3_build("pythonslave.py", "PythonSlave")


@pytest.fixture(scope="session")
def pythonslave3_me() -> Path:
    """pythonfmu3's Model Exchange test slave: Dahlquist's x' = -k x, x(0) = 1, k = 1."""
    return _pythonfmu3_build("pythonslaveMX.py", "Dahlquist")


def test_pythonfmu3_model_exchange_fmu_matches_fmpy_and_the_exact_solution(pythonslave3_me):
    from harness.fmi import ModelExchange3, open_instance

    inst = open_instance(pythonslave3_me, "probe")
    assert type(inst) is ModelExchange3
    inst.free()
    rtol, stop, step = 1e-6, 2.0, 0.05
    df = quiet(System("d", [Instance("m", str(pythonslave3_me))], experiment=Experiment(stop_time=stop, step=step)),
               tolerance=rtol, on_error="raise")
    assert assert_agrees(df, fmpy_me(pythonslave3_me, stop, step, rtol), "m.", 1e-12, "pythonfmu3 ME") == 1
    # independent of fmpy: the exact solution, to the solver's tolerance (measured 3.2e-6)
    assert np.abs(df["m.x"].to_numpy() - np.exp(-df.index.to_numpy())).max() <= 10 * rtol


def test_pythonfmu3_fmu_is_opened_as_fmi3_not_as_pythonfmu(pythonslave3):
    from harness.fmi import FMU3, open_instance

    with warnings.catch_warnings():
        warnings.simplefilter("error")   # no "runs through its FMI library" fallback warning either
        inst = open_instance(pythonslave3, "p")
    try:
        assert type(inst) is FMU3
    finally:
        inst.free()


@pytest.mark.parametrize("master", MASTERS)
def test_pythonfmu3_fmu_under_every_master_matches_fmpy(pythonslave3, master):
    from fmpy import simulate_fmu

    stop, step = 1.0, 0.1
    system = System("p", [Instance("a", str(pythonslave3)), Instance("b", str(pythonslave3), {"intParam": 7})],
                    [Connection("a.realOut", "b.realIn")], experiment=Experiment(stop_time=stop, step=step))
    df = quiet(system, master=master, on_error="raise")
    assert df.attrs["complete"]
    ref = pd.DataFrame(simulate_fmu(str(pythonslave3), stop_time=stop, step_size=step, output_interval=step)
                       ).set_index("time")
    assert assert_agrees(df, ref, "a.", 1e-12, master) == 2
    assert df["a.realOut"].iloc[-1] == pytest.approx(stop)


# ------------------------------------------------------------------------------------------------ Model Exchange
ME_MODELS = ("BouncingBall", "VanDerPol", "Dahlquist", "Stair", "Feedthrough", "Resource")


@pytest.fixture(scope="session")
def reference_me(reference2) -> dict[str, Path]:
    """The FMI 2.0 Reference-FMUs without their co-simulation interface: Model Exchange only."""
    from harness.fmi.cache import model_exchange_only

    return {m: model_exchange_only(reference2[m]) for m in ME_MODELS}


@pytest.fixture(scope="session")
def reference_me3(reference3) -> dict[str, Path]:
    """The same for the FMI 3.0 Reference-FMUs."""
    from harness.fmi.cache import model_exchange_only

    return {m: model_exchange_only(reference3[m]) for m in ME_MODELS}


@pytest.fixture(params=["2.0", "3.0"])
def me_and_cs(request) -> tuple[dict[str, Path], dict[str, Path]]:
    """(the Reference-FMUs as ME only, the same as co-simulation FMUs) of one FMI version."""
    if request.param == "2.0":
        return request.getfixturevalue("reference_me"), request.getfixturevalue("reference2")
    return request.getfixturevalue("reference_me3"), request.getfixturevalue("reference3")


@pytest.fixture
def me_fmus(me_and_cs) -> dict[str, Path]:
    return me_and_cs[0]


def fmpy_me(fmu: Path, stop: float, step: float, rtol: float) -> pd.DataFrame:
    from fmpy import simulate_fmu

    return pd.DataFrame(simulate_fmu(str(fmu), stop_time=stop, output_interval=step, fmi_type="ModelExchange",
                                     relative_tolerance=rtol, record_events=False)).set_index("time")


@pytest.mark.parametrize("rtol", [1e-6, 1e-8])
@pytest.mark.parametrize("model", ME_MODELS)
def test_model_exchange_fmu_alone_matches_fmpy(me_fmus, model, rtol):
    from harness.fmi import ModelExchange2, ModelExchange3, open_instance

    fmu = me_fmus[model]
    inst = open_instance(fmu, "probe")
    assert type(inst) is (ModelExchange3 if inst.md.fmiVersion.startswith("3") else ModelExchange2)
    inst.free()
    stop, step = 3.0, 0.01
    df = quiet(System(model, [Instance("m", str(fmu))], experiment=Experiment(stop_time=stop, step=step)),
               master="jacobi", tolerance=rtol, on_error="raise")
    assert df.attrs["complete"]
    # the same CVODE, settings and event handling: agreement to rounding (measured <= 5e-15), not to rtol
    assert assert_agrees(df, fmpy_me(fmu, stop, step, rtol), "m.", 1e-12, f"{model} ME") >= 1


def test_model_exchange_events_happen(me_fmus):
    """Independent of fmpy: the bouncing ball bounces (state events) and the stair counts (time events)."""
    df = quiet(System("ev", [Instance("bb", str(me_fmus["BouncingBall"])),
                             Instance("stair", str(me_fmus["Stair"]))],
                      experiment=Experiment(stop_time=3.0, step=0.01)), master="jacobi", on_error="raise")
    v = df["bb.v"].to_numpy()
    assert (np.diff(np.sign(v)) > 0).sum() >= 2          # the velocity turns upward at each bounce
    assert df["bb.h"].min() >= -1e-6                       # never far below the floor
    counter = df["stair.counter"]
    assert counter.iloc[0] == 1 and counter.iloc[-1] == 4  # one step a second (Stair/readme.md)
    assert counter.index[counter.to_numpy() == 2][0] == pytest.approx(1.0)


def mixed_system(me: dict, cs: dict) -> System:
    return System("mixed", [Instance("vdp", str(me["VanDerPol"])), Instance("ft", str(cs["Feedthrough"])),
                            Instance("ftm", str(me["Feedthrough"])), Instance("stair", str(me["Stair"])),
                            Instance("bb", str(me["BouncingBall"]))],
                  [Connection("vdp.x0", "ft.Float64_continuous_input"),
                   Connection("ft.Float64_continuous_output", "ftm.Float64_continuous_input"),
                   Connection("stair.counter", "ftm.Int32_input"),
                   Connection("bb.h", "ft.Float64_discrete_input"),
                   Connection("bb.v", "ftm.Float64_discrete_input")],
                  experiment=Experiment(stop_time=3.0, step=0.01))


@pytest.mark.parametrize("master", MASTERS)
def test_model_exchange_fmus_in_a_co_simulation_under_every_master(me_and_cs, master):
    rtol = 1e-6
    me_fmus, cs_fmus = me_and_cs
    df = quiet(mixed_system(me_fmus, cs_fmus), master=master, tolerance=rtol, on_error="raise")
    assert df.attrs["complete"] and len(df) == 301
    ref = fmpy_me(me_fmus["VanDerPol"], 3.0, 0.01, rtol)
    x0 = df["vdp.x0"].to_numpy()
    err = np.abs(x0 - ref["x0"].to_numpy()).max() / np.abs(ref["x0"].to_numpy()).max()
    if master == "iterative":
        # every rollback restarts CVODE at the step's start (its history is gone): each restart adds an error
        # of order rtol, 300 steps of them (measured 4.4e-4 of the amplitude at rtol = 1e-6)
        assert err <= 1e3 * rtol
    else:
        assert err <= 1e-12, f"{master}: {err:.3g}"
    counter = df["stair.counter"].to_numpy()
    assert counter[-1] == 4                       # the time events survive the iterative master's rollbacks
    # the discrete signals (Stair's counter into the ME Feedthrough's Int32 input, set in event mode) are
    # exactly what the same system of co-simulation FMUs gives under the same master
    cs = quiet(mixed_system(cs_fmus, cs_fmus), master=master, on_error="raise")
    for col in ("stair.counter", "ftm.Int32_output", "ftm.Boolean_output"):
        assert (df[col].to_numpy() == cs[col].to_numpy()).all(), f"{master}: {col}"
    assert (df["ftm.Int32_output"].to_numpy() != 1).any()
    # a Real input of discrete variability (set in event mode too): the ball's speed, of this point or the last
    out, v = df["ftm.Float64_discrete_output"].to_numpy(), df["bb.v"].to_numpy()
    assert ((out[1:] == v[1:]) | (out[1:] == v[:-1])).all() and (out != 0).any()


def test_ssd_component_with_implementation_model_exchange_runs_as_me(reference2, tmp_path):
    from harness.ssp import load_ssp

    fmu = reference2["VanDerPol"]
    shutil.copy(fmu, tmp_path / "VanDerPol.fmu")
    for impl in ("ModelExchange", "CoSimulation"):
        (tmp_path / f"{impl}.ssd").write_text(
            '<?xml version="1.0" encoding="UTF-8"?>\n<ssd:SystemStructureDescription version="1.0" name="v"'
            ' xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"><ssd:System name="v">'
            f'<ssd:Elements><ssd:Component name="vdp" type="application/x-fmu-sharedlibrary" '
            f'source="VanDerPol.fmu" implementation="{impl}"/></ssd:Elements></ssd:System>'
            '<ssd:DefaultExperiment startTime="0" stopTime="3"/></ssd:SystemStructureDescription>')
    runs = {impl: quiet(load_ssp(tmp_path / f"{impl}.ssd"), step=0.01, tolerance=1e-6, on_error="raise")
            for impl in ("ModelExchange", "CoSimulation")}
    me = fmpy_me(tmp_path / "VanDerPol.fmu", 3.0, 0.01, 1e-6)
    np.testing.assert_allclose(runs["ModelExchange"]["vdp.x0"].to_numpy(), me["x0"].to_numpy(), rtol=0, atol=1e-12)
    # the co-simulation interface (forward Euler inside the FMU) gives another result: the choice is honoured
    assert np.abs(runs["CoSimulation"]["vdp.x0"].to_numpy() - me["x0"].to_numpy()).max() > 1e-6


# ------------------------------------------------------------------------------------------------ SSV units
def test_ssv_gravity_in_cm_per_s2_reaches_bouncing_ball_in_m_per_s2(reference2, tmp_path):
    """The issue's case: g = -981 cm/s2 in an .ssv for the Reference BouncingBall's g, declared (through its
    type Acceleration) in m/s2; applied raw it was -981 m/s2."""
    from harness.ssp import load_ssp

    shutil.copy(reference2["BouncingBall"], tmp_path / "BouncingBall.fmu")
    (tmp_path / "g.ssv").write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n<ssv:ParameterSet version="1.0" name="g"'
        ' xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"'
        ' xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"><ssv:Parameters>'
        '<ssv:Parameter name="g"><ssv:Real value="-981" unit="cm/s2"/></ssv:Parameter></ssv:Parameters>'
        '<ssv:Units><ssc:Unit name="cm/s2"><ssc:BaseUnit m="1" s="-2" factor="0.01"/></ssc:Unit></ssv:Units>'
        '</ssv:ParameterSet>')
    (tmp_path / "bb.ssd").write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n<ssd:SystemStructureDescription version="1.0" name="bb"'
        ' xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"><ssd:System name="bb"><ssd:Elements>'
        '<ssd:Component name="ball" type="application/x-fmu-sharedlibrary" source="BouncingBall.fmu">'
        '<ssd:ParameterBindings><ssd:ParameterBinding source="g.ssv"/></ssd:ParameterBindings></ssd:Component>'
        '</ssd:Elements></ssd:System><ssd:DefaultExperiment startTime="0" stopTime="2"/>'
        '</ssd:SystemStructureDescription>')
    s = load_ssp(tmp_path / "bb.ssd")
    assert s.instance("ball").parameters["g"] == pytest.approx(-9.81, rel=1e-15)
    df = quiet(s, step=0.01, on_error="raise")
    ref = quiet(System("bb", [Instance("ball", str(tmp_path / "BouncingBall.fmu"), {"g": -9.81})]),
                stop_time=2.0, step=0.01, on_error="raise")
    np.testing.assert_allclose(df.to_numpy(), ref.to_numpy(), rtol=1e-12, atol=1e-12)


def test_an_fmu_error_inside_the_solver_is_raised_with_its_own_message(reference_me, monkeypatch):
    """CVODE calls the FMU from C callbacks; an FMI failure there stops the run with the FMU's error (through
    fmpy's solver as is, ctypes prints it to stderr and the run ends with CVODE's "the right-hand side
    routine failed in an unrecoverable manner", which does not say what failed)."""
    from harness.errors import FMUError
    from harness.fmi import me

    original = me.ModelExchange2._fmi_vectors

    def failing(self):
        get_x, set_x, get_dx, get_z, get_nominals = original(self)

        def get_dx_failing(pointer, n):
            if self._t > 0.5:
                raise FMUError(self.name, "fmi2GetDerivatives", self._t, 3, "injected failure")
            get_dx(pointer, n)
        return get_x, set_x, get_dx_failing, get_z, get_nominals

    monkeypatch.setattr(me.ModelExchange2, "_fmi_vectors", failing)
    df = quiet(System("v", [Instance("m", str(reference_me["VanDerPol"]))],
                      experiment=Experiment(stop_time=2.0, step=0.1)))
    assert not df.attrs["complete"]
    assert "injected failure" in df.attrs["error"] and "fmi2GetDerivatives" in df.attrs["error"]
    assert df.index[-1] <= 0.6


def _me_run(fmu: Path, settings, stop: float, step: float, rtol: float) -> pd.DataFrame:
    """A ModelExchange2 instance stepped by hand (the settings are the wrapper's, not simulate()'s)."""
    from harness.fmi.me import ModelExchange2

    inst = ModelExchange2(fmu, "probe", settings=settings)
    names = [v.name for v in inst.md.modelVariables if v.causality == "output"]
    inst.setup(0.0, stop, rtol)
    inst.enter_initialization()
    inst.exit_initialization()
    rows = [[inst.get_value(n) for n in names]]
    n = round(stop / step)
    for k in range(n):
        inst.do_step(k * step, step)
        rows.append([inst.get_value(n) for n in names])
    inst.terminate()
    inst.free()
    return pd.DataFrame(rows, columns=names, index=np.arange(n + 1) * step, dtype=float)


@pytest.mark.parametrize("model", ["BouncingBall", "VanDerPol", "Dahlquist", "Stair"])
def test_scipy_fallback_solver_agrees_with_cvode(reference_me, model):
    """scipy's BDF (the fallback where FMPy ships no CVODE) against fmpy's CVODE run, both at rtol 1e-6: it
    restarts at every communication step (scipy keeps no history between calls), so it agrees to about
    rtol x steps (measured <= 6.1e-4 of the amplitude; the ball's speed 1.0e-3 at a sample just after a bounce,
    the bounce located 5e-5 s apart; BouncingBall up to 2 s, before its ever smaller bounces make the
    comparison one of event times)."""
    from harness.fmi.me import SolverSettings

    rtol, stop, step = 1e-6, 2.0, 0.01
    ours = _me_run(reference_me[model], SolverSettings(solver="scipy"), stop, step, rtol)
    ref = fmpy_me(reference_me[model], stop, step, rtol)
    for col in ours.columns:
        a, b = ours[col].to_numpy(), ref[col].to_numpy(dtype=float)
        err = np.abs(a - b).max() / max(np.abs(b).max(), 1.0)
        assert err <= 2e3 * rtol, f"{model}.{col}: {err:.3g}"
    if model == "BouncingBall":
        assert (np.diff(np.sign(ours["v"].to_numpy())) > 0).sum() >= 2      # it bounces


def test_without_fmpys_cvode_the_scipy_solver_is_taken_with_a_warning(reference_me, monkeypatch):
    import sys

    from harness.fmi import me

    monkeypatch.setitem(sys.modules, "fmpy.sundials", None)   # import fails, as on a platform without CVODE
    with pytest.warns(me.SolverFallback, match="FMPy's CVODE is not available here"):
        cls = me._solver_class("cvode")
    assert cls is me._ScipySolver
    with pytest.raises(ValueError, match="SolverSettings.solver = 'lsoda' is not admissible"):
        me.SolverSettings(solver="lsoda")


def test_fmi1_model_exchange_is_refused_in_one_line(tmp_path):
    """FMI 1.0 Model Exchange (a description without an Implementation element) is not integrated: refused
    before anything is loaded, naming the feature."""
    text = (HERE / "fmi1_string" / "modelDescription.xml").read_text()
    start, end = text.index("<Implementation>"), text.index("</Implementation>") + len("</Implementation>")
    fmu = tmp_path / "Identity1me.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.writestr("modelDescription.xml", text[:start] + text[end:])
    with pytest.raises(FMUError) as info:
        quiet(System("me1", [Instance("m", str(fmu))], experiment=Experiment(stop_time=0.1, step=0.01)),
              on_error="raise")
    assert "Model Exchange of FMI 1.0 is not supported (FMI 2.0 and 3.0 only)" in str(info.value)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_integer_to_enumeration_connection(reference2, master):
    """Stair's Integer counter into Feedthrough's Enumeration input (type Option: items 1 and 2) and back out to
    an Integer input (FMI 2.0 passes both through fmi2SetInteger; OMSimulator connects them; a type mismatch
    before).  When the counter reaches 3, not an item of Option, the FMU's own refusal ends the run."""
    def system(stop):
        return System("enum", [Instance("stair", str(reference2["Stair"])),
                               Instance("ft", str(reference2["Feedthrough"])),
                               Instance("ft2", str(reference2["Feedthrough"]))],
                      [Connection("stair.counter", "ft.Enumeration_input"),
                       Connection("ft.Enumeration_output", "ft2.Int32_input")],
                      experiment=Experiment(stop_time=stop, step=0.01))

    df = quiet(system(1.5), master=master, on_error="raise")
    counter, enum = df["stair.counter"].to_numpy(), df["ft.Enumeration_output"].to_numpy()
    assert counter[-1] == 2 and ((enum == counter).all() or (enum[1:] == counter[:-1]).all())
    assert set(df["ft2.Int32_output"]) <= {1, 2} and df["ft2.Int32_output"].iloc[-1] == 2
    df = quiet(system(3.0), master=master)
    assert not df.attrs["complete"] and "3 is not a legal value for Enumeration_input" in df.attrs["error"]


def test_a_bare_fmu_runs_alone_like_fmpy(reference2, reference3):
    """harness.simulate("x.fmu") (and the CLI's run x.fmu): one instance, the FMU's DefaultExperiment."""
    from fmpy import simulate_fmu

    from harness import load

    for fmus in (reference2, reference3):
        fmu = fmus["BouncingBall"]
        s = load(fmu)
        assert [i.name for i in s.instances] == ["BouncingBall"]
        assert (s.experiment.start_time, s.experiment.stop_time, s.experiment.step) == (0.0, 3.0, 0.01)
        df = quiet(str(fmu), master="jacobi-sampled", on_error="raise")
        ref = pd.DataFrame(simulate_fmu(str(fmu), output_interval=0.01, fmi_type="CoSimulation")).set_index("time")
        assert assert_agrees(df, ref, "BouncingBall.", 1e-12, str(fmu)) >= 2   # h, v (FMI 3.0: h_ft too)


@pytest.mark.parametrize("version,annotation", [
    ("2.0", '<VendorAnnotations><Tool name="org.pressdrive"><Slave module="m" class="C" '
            'advancedPositions="crank.phi"/></Tool></VendorAnnotations>'),
    ("3.0", '<Annotations><Annotation type="org.pressdrive"><Slave module="m" class="C" '
            'advancedPositions="crank.phi"/></Annotation></Annotations>'),
])
def test_the_toolkit_annotation_is_read_in_fmi2_and_fmi3_places(tmp_path, version, annotation):
    """The toolkit's FMUs name the motion inputs they advance themselves; the master must not extrapolate
    those.  FMI 3.0 moved vendor annotations to Annotations/Annotation (issue 34's FMI 3.0 FMUs: without it
    the feeder differed by 1.1e11 from its FMI 2.0 run, measured there)."""
    from harness.fmi.fmu import advanced_positions, toolkit_annotation

    (tmp_path / "modelDescription.xml").write_text(
        f'<?xml version="1.0" encoding="UTF-8"?>\n<fmiModelDescription fmiVersion="{version}" modelName="x" '
        f'instantiationToken="t" guid="t">{annotation}</fmiModelDescription>')
    assert toolkit_annotation(tmp_path).get("class") == "C"
    assert advanced_positions(tmp_path) == {"crank.phi"}
