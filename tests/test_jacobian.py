"""The ``jacobian`` master (interface-Jacobian coupling, harness.master.jacobian): its one-step map against the closed
form, its stability region against theory, its Jacobians against finite differences of the whole coupled step,
and what it refuses."""
from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from harness import simulate
from harness.master import jacobian as ij
from harness.master import InterfaceJacobian
from harness.studies.stability import theory as th
from harness.studies.stability.measured import is_unstable, measured_boundary, two_inertia_run

HERE = Path(__file__).parent


def _quiet(*args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(*args, **kw)


def _two_inertia(fmu_dir, p: th.TwoInertia):
    from harness import load

    base = load("two_inertia")
    params = {f"{i}.{k}": v for i, d in p.instance_parameters().items() for k, v in d.items()}
    return base.on_fmus(fmu_dir), params


@pytest.mark.parametrize("order", [0, 1, 2])
def test_two_inertia_follows_the_closed_form_one_step_map(fmu_dir, order):
    """At a step 6 times Jacobi's limit (omega h = 3), the run is M^k x0 of the theory's amplification matrix
    (RK4 subsystems, as the FMUs integrate) to round-off and finite-difference error: the single Newton
    correction reaches the fixed point exactly on a linear pair, whatever the predictor's order."""
    p = th.TwoInertia(d=0.02)
    h_ns = round(3.0 / p.natural_frequency() * 1e9)   # whole nanoseconds: master time
    h = h_ns / 1e9
    assert h > 5 * th.stability_boundary(p, "jacobi", 1)
    system, params = _two_inertia(fmu_dir, p)
    n = 200
    df = _quiet(system, stop_time=n * h_ns / 1e9, step=h, master="jacobian", extrapolation=order,
                parameters={**params, "a.w0": 1.0})
    assert df.attrs["complete"], df.attrs.get("error")
    M = th.amplification_matrix(p, h, "jacobian", order)
    x = np.array([0.0, 1.0, 0.0, 0.0])
    rows = [x]
    for _ in range(n):
        x = M @ x
        rows.append(x)
    xs = np.array(rows)
    tau = xs @ p.torque_row()
    np.testing.assert_allclose(df["a.flange.w"].to_numpy(), xs[:, 1], rtol=0, atol=1e-7)
    np.testing.assert_allclose(df["b.drive.tau"].to_numpy(), tau, rtol=0, atol=1e-7 * np.abs(tau).max())


def test_theory_the_shift_damps_at_every_step_and_vanishes_at_small_steps():
    """The closed form's claims (harness.master.jacobian): with exact subsystems the oscillating mode of the undamped
    pair decays at every step, far beyond Jacobi's limit, most where the bond's loop gain is of order one
    (omega h 2 to 12) and hardly at small steps, where the shift fades with the gain and the coupling is the
    trapezoid (no first-order damping); with RK4 subsystems the step is limited only near their own bound
    (RK4's is omega h = 2.785; the spring side b has omega_b = sqrt(c / J2))."""
    p = th.TwoInertia()
    w = p.natural_frequency()
    radius = {}
    for wh in (0.05, 0.5, 2.0, 12.0, 100.0):
        M = th.deflate_rigid(th.amplification_matrix(p, wh / w, "jacobian", 1, "exact"))
        radius[wh] = th.spectral_radius(M)
        assert radius[wh] < 1.0 - 1e-12, wh
    assert 1.0 - radius[0.05] < 1e-6                  # per step; a constant shift of 0.1 damps 1e-4 here
    assert radius[2.0] < 0.97 and radius[12.0] < 0.97, radius   # (at omega h -> inf it tends to 1 again)
    h_rk4 = th.stability_boundary(p, "jacobian", 1)
    omega_b = math.sqrt(p.c / p.J2)
    assert 2.6 < h_rk4 * omega_b < 3.2, h_rk4 * omega_b
    assert th.stability_boundary(p, "jacobian", 1, integrator="exact") == math.inf


def test_measured_stability_boundary_matches_theory(fmu_dir):
    """Bisection on real runs (the stability study's blow-up criterion) finds the theory's boundary of the
    damped pair within 3 %, far beyond Jacobi's."""
    p = th.TwoInertia(c1=50.0).with_modal_damping(0.02)
    h_th = th.stability_boundary(p, "jacobian", 1)
    assert math.isfinite(h_th)
    assert h_th > 5 * th.stability_boundary(p, "jacobi", 1)
    run = two_inertia_run(p, "jacobian", 1, periods=30, min_steps=200, fmu_dir=fmu_dir)
    h_me = measured_boundary(run, 0.8 * h_th, 1.2 * h_th, rtol=0.01)
    assert h_me == pytest.approx(h_th, rel=0.03)
    assert not is_unstable(run(0.5 * h_th))


def test_assembled_jacobian_equals_finite_differences_of_the_coupled_step(monkeypatch):
    """On the bed drive (six FMUs, rigid feed-through differential, power bonds), the Jacobian the master
    assembles from per-FMU blocks (harness.master.jacobian.assemble) is the derivative of the whole coupled step
    G(u) - u, taken by differencing complete steps (every FMU stepped, outputs made consistent)."""
    found = {}
    original = InterfaceJacobian._step_impl

    def probe(self, t, h, t_next):
        if t > 0.0099 and not found:
            self._hold_all(t, h)
            u0 = self.u.copy()
            self.snapshot("ij")
            self._take(t, h, t_next, u0)
            self._estimate(t, h, u0)
            r0 = self._implicit_inputs(t, h) - u0   # with the theta of this estimate
            jg = self.theta[:, None] * self.jacobian
            dp = ij.perturbation(u0)
            fd = np.zeros_like(jg)
            for k in range(len(u0)):
                du = np.zeros_like(u0)
                du[k] = dp[k]
                self.restore("ij")
                fd[:, k] = (self._take(t, h, t_next, u0 + du) - r0 + du) / dp[k]
            self.restore("ij")
            found["err"] = np.abs(jg - fd).max()
            found["scale"] = np.abs(fd).max()
            found["n"] = len(u0)
        original(self, t, h, t_next)

    monkeypatch.setattr(InterfaceJacobian, "_step_impl", probe)
    df = _quiet("bed_drive", stop_time=0.012, step=1e-3, master="jacobian", extrapolation=1)
    assert df.attrs["complete"], df.attrs.get("error")
    assert found["n"] >= 15
    assert found["scale"] > 1e3          # the rigid differential's reflected inertia: large entries
    assert found["err"] < 1e-8 * found["scale"], found


def test_bed_drive_full_model_is_stable_where_jacobi_is_not():
    """The scenes' full model (clearances, compliant mesh) at 2 ms: ten times the step Jacobi needs; Jacobi
    with linear extrapolation diverges there and is stopped."""
    from harness import load
    from harness.studies.scenes import fidelity_levels

    system = load("bed_drive")
    full = {f"{k}.fidelity": max(v) for k, v in fidelity_levels(system).items()}
    ok = _quiet(system, stop_time=0.4, step=2e-3, master="jacobian", extrapolation=1, parameters=full)
    assert ok.attrs["complete"], ok.attrs.get("error")
    assert np.ptp(ok["bed.bed.s"].to_numpy()) > 0.05      # the bed moved
    bad = _quiet(system, stop_time=0.4, step=2e-3, master="jacobi", extrapolation=1, parameters=full)
    assert not bad.attrs["complete"]


def test_a_contact_made_within_a_step_is_taken_in_halves():
    """The full model at 1 ms: near 0.45 s the load reverses, and the stone pin's and the four-bar joint's
    clearances open and close within single steps.  One Newton step from Jacobians estimated without the contact
    cannot find such a step's fixed point (the correction does not contract).  Taken whole, the impact came out
    over a hundred times the reference's force and the detector stopped the run at 0.46 s; taken in halves
    where the correction does not contract, the run goes through and the shaft torque's peak after the
    reversal agrees with a run at a quarter of the step."""
    from harness import load
    from harness.studies.scenes import fidelity_levels

    system = load("bed_drive")
    full = {f"{k}.fidelity": max(v) for k, v in fidelity_levels(system).items()}
    run = _quiet(system, stop_time=0.6, step=1e-3, master="jacobian", extrapolation=1, parameters=full)
    assert run.attrs["complete"], run.attrs.get("error")
    assert run.attrs["halved_steps"] > 0
    fine = _quiet(system, stop_time=0.6, step=2.5e-4, master="jacobian", extrapolation=1, parameters=full)
    peak = [df["flywheel.shaft_torque"].loc[0.44:].abs().max() for df in (run, fine)]
    assert abs(peak[0] - peak[1]) < 0.1 * peak[1], peak
    declared = _quiet(system, stop_time=0.6, step=1e-3, master="jacobian", extrapolation=1)  # no clearances:
    assert declared.attrs["complete"] and declared.attrs["halved_steps"] == 0              # no step halved


def test_fmus_without_state_support_are_refused_in_one_line(tmp_path):
    """The scheme takes each step twice: an FMU without fmi2Get/SetFMUstate is refused, named, in one line."""
    from harness.errors import SystemError_
    from harness.model import Connection, Experiment, Instance, System

    from foreign_builds import plain_lag

    fmu = plain_lag()
    s = System("pair", [Instance("a", str(fmu)), Instance("b", str(fmu))],
               [Connection("a.y", "b.u"), Connection("b.y", "a.u")], experiment=Experiment(1.0, 0.1))
    with pytest.raises(SystemError_) as e:
        _quiet(s, master="jacobian", on_error="raise")
    msg = str(e.value)
    assert "\n" not in msg and "a (PlainLag)" in msg and "canGetAndSetFMUstate" in msg


def test_second_order_where_the_step_resolves_the_coupling(fmu_dir):
    """Undamped pair against its exact solution: halving the step quarters the error (the shift fades with the
    loop gain, so no first-order damping is left), and the error is far below Jacobi's with linear extrapolation."""
    from scipy.linalg import expm

    p = th.TwoInertia()
    system, params = _two_inertia(fmu_dir, p)
    A = p.coupled()
    errors = {}
    for h in (2e-3, 1e-3):
        df = _quiet(system, stop_time=0.5, step=h, master="jacobian", extrapolation=1,
                    parameters={**params, "a.w0": 1.0})
        exact = np.array([expm(A * t) @ np.array([0.0, 1.0, 0.0, 0.0]) for t in df.index.to_numpy()])
        errors[h] = np.abs(df["a.flange.w"].to_numpy() - exact[:, 1]).max()
    assert 3.5 < errors[2e-3] / errors[1e-3] < 4.5, errors


def test_two_inertia_runs_with_its_defaults_and_prints_nothing_but_its_result():
    """The benchmark's default experiment (master jacobian) runs to the end without a warning, energy kept:
    the spring torque's amplitude in the last tenth within 1 % of the first tenth's."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        df = simulate("two_inertia")
    assert df.attrs["complete"] and not df.attrs["suspect"], df.attrs.get("error")
    assert not [w for w in caught if issubclass(w.category, UserWarning)], [str(w.message) for w in caught]
    tau = np.abs(df["b.drive.tau"].to_numpy())
    n = len(tau)
    assert tau[-n // 10:].max() == pytest.approx(tau[: n // 10].max(), rel=0.01)


def test_the_command_line_says_how_many_steps_it_took_in_halves(monkeypatch, capsys):
    """A run whose steps the master halved says so in its summary line; one that halved none says nothing."""
    import warnings as w

    from harness.__main__ import main

    monkeypatch.setattr(w, "showwarning", w.showwarning)   # main() sets its own
    full = [a for k in ("motor", "fourbar", "cam") for a in ("--set", f"{k}.fidelity=2")]
    assert main(["run", "bed_drive", "--stop-time", "0.5", "--step", "1e-3", "--master", "jacobian", "--quiet-quantities",
                 *full]) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert " taken again in halves where the coupling's correction did not converge" in line
    assert main(["run", "bed_drive", "--stop-time", "0.05", "--step", "1e-3", "--master", "jacobian"]) == 0
    assert "halves" not in capsys.readouterr().out


@pytest.mark.parametrize("where", ["correction", "feed-through"])
def test_a_singular_interface_jacobian_stops_the_run_in_one_line_naming_the_bond_and_the_time(fmu_dir, monkeypatch,
                                                                                                where):
    """numpy's LinAlgError ("Singular matrix") from the corrector or from the outputs' feed-through loop left the
    run with no result and ended ``study stability proof_press`` with ``error: Singular matrix``.  It is a
    condition of the coupling at that step: the run stops there, marked, with one line naming the time and the
    bond, and keeps what it computed."""
    from harness import load
    from harness.errors import SimulationError

    system = load("two_inertia").on_fmus(fmu_dir)
    if where == "correction":     # J_G = I: the corrector's matrix I - theta S with theta = 1 vanishes
        monkeypatch.setattr(ij, "assemble", lambda A, D, src, factor: np.eye(len(src)))
        monkeypatch.setattr(ij, "target_weights", lambda n, bonds, S, positions: np.ones(n))
    else:                         # I - D C singular: the outputs' feed-through loop has no unique solution
        real = np.linalg.solve

        def solve(a, b):
            if a.shape == (a.shape[0], a.shape[0]) and b.ndim == 2:
                raise np.linalg.LinAlgError("Singular matrix")
            return real(a, b)

        monkeypatch.setattr(ij.np.linalg, "solve", solve)
    df = _quiet(system, stop_time=0.01, step=1e-3, master="jacobian", extrapolation=1)
    assert df.attrs["complete"] is False and len(df) >= 1
    error = df.attrs["error"]
    assert "\n" not in error, error
    assert error.startswith("t = 0 s: master 'jacobian': the interface Jacobian is singular"), error
    assert "on power bond a.flange->b.drive" in error, error
    with pytest.raises(SimulationError, match="singular on power bond a.flange->b.drive"):
        _quiet(system, stop_time=0.01, step=1e-3, master="jacobian", extrapolation=1, on_error="raise")
