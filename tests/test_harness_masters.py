"""Masters on the two-inertia benchmark (exact solution by matrix exponential) and on algebraic loops."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from harness import bond_energy, simulate
from harness.errors import AlgebraicLoopError, SimulationError
from harness.master import MASTERS, IterationOptions, Jacobi
from harness.model import Connection, Instance, System, bond
from harness.run import RunOptions

JA, JB, C, W0 = 0.01, 0.02, 10.0, 1.0


def two_inertia(fmu_dir, c=C, d=0.0):
    return System("two_inertia_test", [
        Instance("a", fmu_dir / "Inertia.fmu", {"J": JA, "w0": W0}),
        Instance("b", fmu_dir / "SpringInertia.fmu", {"J": JB, "c": c, "d": d})],
        bonds=[bond("a.flange", "b.drive")])


def exact(t, c=C):
    """Monolithic solution [phi_a, w_a, phi_b, w_b] of the coupled pair (matrix exponential)."""
    a = np.array([[0, 1, 0, 0], [-c / JA, 0, c / JA, 0], [0, 0, 0, 1], [c / JB, 0, -c / JB, 0]])
    x0 = np.array([0.0, W0, 0.0, 0.0])
    return np.array([expm(a * ti) @ x0 for ti in np.atleast_1d(t)])


def global_error(df) -> float:
    t = df.index.values[::10]
    return float(np.max(np.abs(df["a.flange.w"].values[::10] - exact(t)[:, 1])))


def observed_order(system, steps, **kw) -> tuple[float, list[float]]:
    errs = [global_error(simulate(system, 0.5, h, outputs=["a.flange.w"], **kw)) for h in steps]
    return float(np.polyfit(np.log(steps), np.log(errs), 1)[0]), errs


STEPS = [2e-3, 1e-3, 5e-4]


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
@pytest.mark.parametrize("extrapolation,order", [(0, 1.0), (1, 2.0), (2, 2.0)])
def test_global_error_order(fmu_dir, master, extrapolation, order):
    p, errs = observed_order(two_inertia(fmu_dir), STEPS, master=master, extrapolation=extrapolation)
    assert abs(p - order) <= 0.3, (p, errs)


def test_midpoint_extrapolation_beats_hold_and_gauss_seidel_beats_jacobi(fmu_dir):
    s = two_inertia(fmu_dir)
    e = {(m, k): global_error(simulate(s, 0.5, 1e-3, master=m, extrapolation=k)) for m in ("jacobi", "gauss-seidel")
         for k in (0, 1)}
    assert e["jacobi", 1] < 0.1 * e["jacobi", 0]
    assert e["gauss-seidel", 0] < e["jacobi", 0]


def test_iterative_converges_to_the_monolithic_solution(fmu_dir):
    s = two_inertia(fmu_dir)
    opts = RunOptions(iteration=IterationOptions(method="anderson", tolerance=1e-12))
    p, errs = observed_order(s, [4e-3, 2e-3, 1e-3], master="iterative", extrapolation=1, options=opts)
    assert abs(p - 2.0) <= 0.3, (p, errs)
    assert errs[-1] < 1e-2 * W0
    # the three solvers find the same fixed point (independent iterations)
    runs = [simulate(s, 0.1, 2e-3, master="iterative", extrapolation=1,
                     options=RunOptions(iteration=IterationOptions(method=m, tolerance=1e-13)))
            for m in ("fixed-point", "anderson", "newton")]
    for df in runs[1:]:
        np.testing.assert_allclose(df.values, runs[0].values, rtol=0, atol=1e-9)
    assert runs[0].attrs["iterations"] > runs[2].attrs["iterations"] / 3  # it did iterate


def test_zero_order_hold_jacobi_blows_up_and_returns_a_partial_result(fmu_dir):
    s = two_inertia(fmu_dir, c=1e4)
    with pytest.warns(UserWarning, match="run stopped early"):
        df = simulate(s, 2.0, 5e-3, options=RunOptions(blowup=1e3))
    assert df.attrs["complete"] is False
    assert "exceeds the blow-up limit" in df.attrs["error"] and "instance" in df.attrs["error"]
    assert 0 < df.index[-1] < 2.0 and np.all(np.abs(df.values) <= 1e3)
    with pytest.raises(SimulationError) as info:
        simulate(s, 2.0, 5e-3, options=RunOptions(blowup=1e3), on_error="raise")
    assert info.value.partial is not None and info.value.partial.attrs["complete"] is False
    assert info.value.instance in ("a", "b") and info.value.time > 0


def test_rollback_is_bit_exact(fmu_dir, monkeypatch):
    """A master that takes every step twice (rollback in between) gives bit-identical results."""

    class Twice(Jacobi):
        name = "twice"

        def _step_impl(self, t, h, t_next):
            self.snapshot("twice")
            super()._step_impl(t, h, t_next)
            first = self.y.copy()
            self.restore("twice")
            super()._step_impl(t, h, t_next)
            assert np.array_equal(first, self.y)

    monkeypatch.setitem(MASTERS, "twice", Twice)
    s = two_inertia(fmu_dir)
    outs = ["a.flange.phi", "a.flange.w", "b.drive.tau", "b.phi", "b.w"]
    ref = simulate(s, 0.2, 1e-3, extrapolation=2, outputs=outs)
    twice = simulate(s, 0.2, 1e-3, master="twice", extrapolation=2, outputs=outs)
    assert np.array_equal(ref.values, twice.values)


def gain_ring(fmu_dir, k1=0.5, b1=1.0, k2=-0.8, b2=0.3):
    return System("ring", [Instance("g1", fmu_dir / "Gain.fmu", {"k": k1, "offset": b1}),
                           Instance("g2", fmu_dir / "Gain.fmu", {"k": k2, "offset": b2})],
                  connections=[Connection("g1.y", "g2.u"), Connection("g2.y", "g1.u")])


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_algebraic_loop_is_detected_and_reported(fmu_dir, master):
    with pytest.raises(AlgebraicLoopError, match=r"g1\.u -> g1\.y -> g2\.u -> g2\.y.*iterative") as info:
        simulate(gain_ring(fmu_dir), 1.0, 0.1, master=master)
    assert info.value.loops == [["g1.u", "g1.y", "g2.u", "g2.y"]]


@pytest.mark.parametrize("method", ["fixed-point", "anderson", "newton"])
def test_algebraic_loop_is_solved_by_iterative(fmu_dir, method):
    k1, b1, k2, b2 = 0.5, 1.0, -0.8, 0.3
    df = simulate(gain_ring(fmu_dir, k1, b1, k2, b2), 1.0, 0.1, master="iterative",
                  options=RunOptions(iteration=IterationOptions(method=method, tolerance=1e-13)))
    y1 = (k1 * b2 + b1) / (1 - k1 * k2)
    np.testing.assert_allclose(df["g1.y"], y1, rtol=1e-10)
    np.testing.assert_allclose(df["g2.y"], k2 * y1 + b2, rtol=1e-10)
    # the integral of the held input u1 = y2 (order 0: the converged end value)
    np.testing.assert_allclose(df["g1.integral"].iloc[-1], 1.0 * (k2 * y1 + b2), rtol=1e-9)


def test_loop_gain_above_one_diverges_with_fixed_point_but_newton_solves_it(fmu_dir):
    s = gain_ring(fmu_dir, k1=2.0, b1=1.0, k2=-1.5, b2=0.5)
    with pytest.warns(UserWarning):
        df = simulate(s, 0.2, 0.1, master="iterative",
                      options=RunOptions(iteration=IterationOptions(method="fixed-point", max_iterations=30)))
    assert df.attrs["complete"] is False and "algebraic loop g1 / g2" in df.attrs["error"]
    df = simulate(s, 0.2, 0.1, master="iterative", options=RunOptions(iteration=IterationOptions(method="newton")))
    np.testing.assert_allclose(df["g1.y"], (2.0 * 0.5 + 1.0) / (1 + 3.0), rtol=1e-8)


def test_step_doubling_meets_its_tolerance(fmu_dir):
    s = two_inertia(fmu_dir)
    errs, lens = [], []
    for tol in (1e-3, 1e-4, 1e-5):
        df = simulate(s, 0.5, 1e-3, extrapolation=1, step_control="richardson", tolerance=tol)
        assert df.attrs["complete"] and df.attrs["max_error_estimate"] <= 1.0
        assert df.index[-1] == pytest.approx(0.5, abs=1e-12)
        errs.append(global_error(df))
        lens.append(len(df))
    assert errs[0] > errs[1] > errs[2] and lens[0] < lens[1] < lens[2]
    # global error scales like tol^(p/(p+1)) for the local control of an order-2 scheme: at least tol^(1/2)
    assert errs[2] < errs[0] * 0.1


def test_ecco_controls_the_bond_energy_error(fmu_dir):
    s = two_inertia(fmu_dir)
    res = {}
    for tol in (1e-1, 1e-3):
        df = simulate(s, 0.5, 1e-3, step_control="ecco", tolerance=tol)
        h = np.diff(df.index.values)
        assert np.all(h[1:-1] / h[:-2] <= 1.5 + 1e-9) and np.all(h[1:-1] / h[:-2] >= 0.2 - 1e-9)
        res[tol] = (abs(bond_energy(df)["energy_error"].iloc[-1]), len(df))
    assert res[1e-3][0] < res[1e-1][0] and res[1e-3][1] > res[1e-1][1]


def test_bond_energy_follows_its_definition_and_sign(fmu_dir):
    """Jacobi + hold: tau held by a over [t_k, t_k+1] is tau_b(t_k); w held by b is w_a(t_k)."""
    h = 2e-3
    df = simulate(two_inertia(fmu_dir), 0.5, h, outputs=["a.flange.phi", "a.flange.w", "b.drive.tau", "b.phi", "b.w"])
    tau, w = df["b.drive.tau"].values, df["a.flange.w"].values
    p_out = tau[:-1] * 0.5 * (w[:-1] + w[1:])
    p_in = 0.5 * (tau[:-1] + tau[1:]) * w[:-1]
    be = bond_energy(df)
    np.testing.assert_allclose(be["energy_error"].values[1:], np.cumsum((p_out - p_in) * h), rtol=1e-9, atol=1e-15)
    # zero-order hold Jacobi on a free-free pair adds energy: both the bond error and the true energy grow
    e = 0.5 * JA * w ** 2 + 0.5 * JB * df["b.w"].values ** 2 + 0.5 * C * (df["a.flange.phi"].values - df["b.phi"].values) ** 2
    assert be["energy_error"].iloc[-1] > 0 and e[-1] - e[0] > 0
    assert 0.3 < be["energy_error"].iloc[-1] / (e[-1] - e[0]) < 3.0


@pytest.mark.parametrize("master, order", [("jacobi", 0), ("jacobi", 1), ("jacobi-sampled", 1), ("iterative", 1)])
def test_held_inputs_in_floats_equal_the_arrays(master, order, monkeypatch):
    """The held inputs' fast path in plain floats (Master._hold_all_floats) gives the array path's values bit for
    bit: the same run with the arrays only is the same result (and the fast path was taken)."""
    from harness.master import Master
    from harness.run import load

    calls = []
    fast = Master._hold_all_floats
    monkeypatch.setattr(Master, "_hold_all_floats", lambda self, t, h: (calls.append(t), fast(self, t, h)))
    kw = dict(stop_time=0.2, step=1e-3, master=master, extrapolation=order)
    ref = simulate(load("two_inertia"), **kw)
    assert calls, "the fast path was not taken"
    monkeypatch.setattr(Master, "_hold_all_floats", Master._hold_all_arrays)
    arrays = simulate(load("two_inertia"), **kw)
    assert np.array_equal(ref.values, arrays.values)


@pytest.mark.parametrize("master, extrapolation", [("jacobi", 0), ("jacobi", 1), ("gauss-seidel", 0),
                                                   ("gauss-seidel", 1), ("iterative", 1)])
def test_a_linear_transformation_gives_the_same_run_wherever_along_a_chain_it_is_applied(fmu_dir, master,
                                                                                         extrapolation):
    """Inertia a (sped up by tau_drive) -> Gain g (y = 2 u, feed-through) -> Inertia b (driven by the torque):
    b's torque 6 w_a + 1 made once by 3 w_a + 0.5 into g, once by 3 y_g + 1 out of g (unit_conversion declared).
    Under each master's own path for setting inputs (Gauss-Seidel with extrapolation sets a feed-through FMU's
    inputs again at t + h for the FMUs after it), b moves the same to rounding, and g.u is 3 w_a + 0.5 of the
    same row at every point."""
    import warnings

    def run(into_g, out_of_g):
        system = System("chain", [Instance("a", fmu_dir / "Inertia.fmu", {"J": JA, "w0": W0, "tau_drive": 0.02}),
                                  Instance("g", fmu_dir / "Gain.fmu", {"k": 2.0}),
                                  Instance("b", fmu_dir / "Inertia.fmu", {"J": JB})],
                        [Connection("a.flange.w", "g.u", *into_g, unit_conversion=True),
                         Connection("g.y", "b.flange.tau", *out_of_g, unit_conversion=True)])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return simulate(system, 0.05, 1e-2, master=master, extrapolation=extrapolation, on_error="raise",
                            outputs=["a.flange.w", "g.u", "b.flange.phi", "b.flange.w"])

    before, after = run((3.0, 0.5), (1.0, 0.0)), run((1.0, 0.0), (3.0, 1.0))
    assert len(before) == 6 and before["b.flange.w"].iloc[-1] > 1.0          # b is driven: 6 w_a + 1 > 0
    np.testing.assert_allclose(before["g.u"], 3.0 * before["a.flange.w"] + 0.5, rtol=1e-14)
    np.testing.assert_allclose(before[["b.flange.phi", "b.flange.w"]], after[["b.flange.phi", "b.flange.w"]],
                               rtol=1e-12)
