"""Every FMU of the toolkit runs unchanged in libcosim and Ecos and gives what a plain fmpy loop gives.

Same FMU, same constant inputs, same step: the tools can only differ through the time doubles they hand
``fmi2DoStep``.  libcosim counts integer nanoseconds (t_k = ns_k / 1e9, h_k = t_k+1 - t_k, off ``step`` by an
ulp now and then); Ecos accumulates t += h.  Against the exact grid (t_k = k h) they agree to ~1e-15
relative (only time-dependent FMUs, e.g. KnifeLoad, see the time difference at all); driven with the same
convention, fmpy reproduces each peer BIT FOR BIT (test_peer_is_bit_identical_with_its_time_convention).
Tolerance of the cross-tool check: 1e-12 of each column's largest magnitude.  A peer whose package does not
import is skipped with the import error.  Failing FMUs crash both peers (abort / segfault): those cases run
in a subprocess (benchmarks.peers.run_isolated).
"""
from __future__ import annotations

import faulthandler
import importlib
from functools import lru_cache

import numpy as np
import pytest

from fmus import build as build_fmus
from benchmarks import peers
from harness.errors import FMUError, SystemError_

pytestmark = pytest.mark.interop

SCRIPTS = [s.stem for s in build_fmus.component_scripts()]
STEP, N = 1e-3, 50
RTOL = 1e-12
# constant, non-zero inputs by unit (motion inputs cannot ramp as constants: phi and w are just held)
INPUT_BY_UNIT = {"rad": 0.3, "rad/s": 2.0, "N.m": 0.5, "N": 5.0, "m": 0.01, "m/s": 0.1, "1": 0.7}
AVAILABLE = peers.available()


@pytest.fixture(autouse=True)
def no_hang():
    """A deadlock between a tool's worker thread and the GIL would hang forever: dump and exit instead."""
    faulthandler.dump_traceback_later(120, exit=True)
    yield
    faulthandler.cancel_dump_traceback_later()


def fmu_name(module: str) -> str:
    mod = importlib.import_module(f"fmus.components.{module}")
    cls = next(v for v in vars(mod).values()
               if isinstance(v, type) and v.__module__ == mod.__name__ and hasattr(v, "model"))
    return cls.__name__


def constant_inputs(md, angle: float) -> dict:
    reals = [v for v in md.modelVariables if v.causality == "input" and v.type == "Real"]
    by_unit = {**INPUT_BY_UNIT, "rad": angle}
    return {v.name: by_unit.get(v.unit, 0.5) * (1.0 + 0.1 * k) for k, v in enumerate(reals)}


@lru_cache(maxsize=None)
def case(path: str) -> tuple[dict, dict, list[str]]:
    """(parameters, constant inputs, variables to record) for one FMU, chosen generically.

    Record every Real output and local.  Default parameters and inputs by unit; angles are tried at a few
    points of a revolution until some recorded variable is non-zero (e.g. KnifeLoad only cuts over
    [pi/2, pi]).  If none is (a load whose every term defaults to 0, e.g. TorqueLoad), the Real parameters
    that default to 0 are set to 0.5 so the comparison is not of zeros with zeros."""
    md, _ = peers._variables(path)
    record = [v.name for v in md.modelVariables if v.type == "Real" and v.causality in ("output", "local")]
    for angle in (0.3, 2.0, 4.0):
        inputs = constant_inputs(md, angle)
        ref = peers.run_fmu_fmpy(path, N * STEP, STEP, {}, inputs, record)
        if np.abs(ref.values).max() > 0:
            return {}, inputs, record
    zero = {v.name: 0.5 for v in md.modelVariables
            if v.causality == "parameter" and v.type == "Real" and float(v.start or 0.0) == 0.0}
    return zero, constant_inputs(md, 0.3), record


@lru_cache(maxsize=None)
def reference(path: str):
    parameters, inputs, record = case(path)
    return peers.run_fmu_fmpy(path, N * STEP, STEP, parameters, inputs, record)


def run(peer: str, path: str, **kw):
    if AVAILABLE[peer] is not None:
        pytest.skip(AVAILABLE[peer])
    parameters, inputs, record = case(path)
    return getattr(peers, f"run_fmu_{peer}")(path, N * STEP, STEP, parameters, inputs, record, **kw)


def assert_same(result, ref, rtol: float = RTOL):
    assert list(result.columns) == list(ref.columns)
    assert len(result) == N + 1, f"{result.attrs.get('peer')} returned {len(result)} rows, expected {N + 1}"
    np.testing.assert_allclose(result.index.values, np.arange(N + 1) * STEP, rtol=0, atol=1e-9 * STEP)
    for col in ref.columns:
        scale = np.abs(ref[col].values).max()
        np.testing.assert_allclose(result[col].values, ref[col].values, rtol=0, atol=rtol * scale,
                                   err_msg=f"{result.attrs.get('peer')} differs from fmpy in {col}")


@pytest.fixture(params=SCRIPTS)
def fmu(request, fmu_dir) -> str:
    return str(fmu_dir / f"{fmu_name(request.param)}.fmu")


def test_reference_run_is_not_trivial(fmu):
    """The comparison means something only if the inputs reach the outputs: some recorded variable is not
    zero (purely kinematic components, e.g. CamRocker with a held crank angle, legitimately stay constant)."""
    ref = reference(fmu)
    assert np.isfinite(ref.values).all()
    assert np.abs(ref.values).max() > 0, f"{fmu}: every variable is 0 with {case(fmu)[:2]}"


@pytest.mark.parametrize("peer", ["libcosim", "ecos"])
def test_peer_matches_fmpy(fmu, peer):
    assert_same(run(peer, fmu), reference(fmu))


@pytest.mark.parametrize("peer, convention", [("libcosim", "libcosim"), ("ecos", "accumulate")])
def test_peer_is_bit_identical_with_its_time_convention(fmu, peer, convention):
    """The peer reports exactly the communication points of its convention, and fmpy fed the same doubles
    reproduces it to the bit: any difference to the exact-grid reference comes from the time doubles."""
    result = run(peer, fmu)
    parameters, inputs, record = case(fmu)
    grid, _ = peers.communication_points(N, STEP, convention)
    np.testing.assert_array_equal(result.index.values, grid)
    again = peers.run_fmu_fmpy(fmu, N * STEP, STEP, parameters, inputs, record, convention=convention)
    np.testing.assert_array_equal(again.values, result.values)


# -- the helpers themselves --------------------------------------------------------------------------------------
@pytest.fixture
def inertia(fmu_dir) -> str:
    return str(fmu_dir / "Inertia.fmu")


def test_available_names_every_peer():
    assert set(AVAILABLE) == {"fmpy", "libcosim", "ecos", "cofmupy"}
    assert AVAILABLE["fmpy"] is None
    assert all(r is None or (isinstance(r, str) and "\n" not in r) for r in AVAILABLE.values())


def test_parameters_and_inputs_reach_the_fmu_in_every_tool(inertia):
    """Inertia with ground spring and damper off: phi = tau/(2J) t^2 exactly at the communication points
    (closed form; the model integrates a constant acceleration), in each tool."""
    J, tau = 0.5, 2.0
    t = np.arange(N + 1) * STEP
    for peer in ("fmpy", "libcosim", "ecos"):
        if AVAILABLE[peer] is not None:
            continue
        df = getattr(peers, f"run_fmu_{peer}")(inertia, N * STEP, STEP, {"J": J}, {"flange.tau": tau},
                                               ["flange.phi", "flange.w"], instance="fly")
        assert list(df.columns) == ["fly.flange.phi", "fly.flange.w"]
        np.testing.assert_allclose(df["fly.flange.w"].values, tau / J * df.index.values, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(df["fly.flange.phi"].values, 0.5 * tau / J * t ** 2, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("stop, step, match", [(0.05, 0.0, "step"), (0.05, -1e-3, "step"),
                                               (0.0505, 1e-3, "whole number of steps"),
                                               (float("nan"), 1e-3, "stop_time")])
def test_bad_time_grid_is_refused(inertia, stop, step, match):
    with pytest.raises(SystemError_, match=match):
        peers.run_fmu_fmpy(inertia, stop, step, {}, {}, ["flange.phi"])


def test_time_conventions_really_differ():
    """The conventions are different doubles (else the bit-exact test above could not tell them apart)."""
    exact, h_exact = peers.communication_points(N, STEP, "exact")
    lc, h_lc = peers.communication_points(N, STEP, "libcosim")
    acc, h_acc = peers.communication_points(N, STEP, "accumulate")
    np.testing.assert_array_equal(lc, [k * 1_000_000 / 1e9 for k in range(N + 1)])
    assert (h_lc != STEP).any() and (h_acc == STEP).all() and (h_exact == STEP).all()
    assert (acc != exact).any() and (lc != exact).any()
    np.testing.assert_allclose(acc, exact, rtol=0, atol=1e-15)
    with pytest.raises(SystemError_, match="time convention 'ecos'"):
        peers.communication_points(N, STEP, "ecos")


def test_libcosim_step_must_be_whole_nanoseconds():
    assert peers.step_nanoseconds(1e-3) == 1_000_000
    with pytest.raises(SystemError_, match="nanoseconds"):
        peers.step_nanoseconds(1.5e-10)


@pytest.mark.parametrize("parameters, inputs, outputs, match", [
    ({"nope": 1.0}, {}, ["flange.phi"], "no parameter 'nope'"),
    ({"flange.tau": 1.0}, {}, ["flange.phi"], "flange.tau has causality input, not parameter"),
    ({}, {"J": 1.0}, ["flange.phi"], "J has causality parameter, not input"),
    ({}, {"flange.tau": float("inf")}, ["flange.phi"], "flange.tau = inf is not a finite number"),
    ({}, {}, ["flange.x"], "no Real variable 'flange.x'"),
    ({}, {}, [], "no outputs"),
])
def test_bad_request_is_one_line_naming_the_variable(inertia, parameters, inputs, outputs, match):
    for peer in ("fmpy", "libcosim", "ecos"):
        if AVAILABLE[peer] is not None:
            continue
        with pytest.raises(SystemError_, match=match) as err:
            getattr(peers, f"run_fmu_{peer}")(inertia, N * STEP, STEP, parameters, inputs, outputs)
        assert "\n" not in str(err.value)


def test_time_check_catches_a_wrong_grid():
    peers._check_times("x", np.arange(5) * 0.1, 0.1)
    with pytest.raises(FMUError, match="row 3 is at t = 0.35"):
        peers._check_times("x", [0.0, 0.1, 0.2, 0.35], 0.1)


def test_fmu_error_is_reported_by_every_tool(inertia):
    """A parameter outside its bounds (J <= 0) makes the FMU fail in initialisation; every tool must raise.
    libcosim aborts its process on this and Ecos ignores the failed initialisation and segfaults in the
    first step (see benchmarks.peers.run_isolated), so those two run in a separate process."""
    for peer in ("fmpy", "ecos", "libcosim"):
        if AVAILABLE[peer] is not None:
            continue
        function = getattr(peers, f"run_fmu_{peer}")
        args = (inertia, N * STEP, STEP, {"J": -1.0}, {}, ["flange.phi"])
        with pytest.raises(FMUError) as err:
            peers.run_isolated(function, *args) if peer != "fmpy" else function(*args)
        assert "\n" not in str(err.value)
