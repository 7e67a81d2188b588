"""Seed 002 (proof press, eccentric round gear sectors): `synth sectors` refuses out-of-range data in one line,
calls a pair feasible only where every junction condition of the seed holds (the ones not solved for
included), and the proof_press system keeps the seed's rules (docs/seed_002.md)."""
from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fmus.physics import gear_sectors as gs
from harness.synthesis.sectors import example_task

ROOT = Path(__file__).resolve().parents[1]


def synth(*args):
    p = subprocess.run([sys.executable, "-m", "harness", "synth", "sectors", *args], capture_output=True,
                       text=True, timeout=120)
    return p.returncode, p.stdout, p.stderr


# ------------------------------------------------------------------------------------------ bugs (issue 32)
@pytest.mark.parametrize("option, value, allowed", [
    ("--D-Ci", "-5", "(0, inf)"), ("--D-Ci", "0", "(0, inf)"), ("--l-i", "-1", "(0, inf)"),
    ("--v1", "0", "(0, inf)"), ("--v2", "-0.9", "(0, inf)"), ("--phi12", "-1", "(0, 6.28319)"),
    ("--phiC12", "0", "(0, inf)"),
])
def test_out_of_range_sizes_speeds_and_angles_are_refused_in_one_line(option, value, allowed):
    rc, out, err = synth(option, value)
    lines = err.strip().splitlines()
    assert rc == 2 and len(lines) == 1, err
    assert lines[0].startswith("error: synth sectors: ") and f"{option} {value}" in lines[0], lines[0]
    assert f"allowed range {allowed}" in lines[0], lines[0]
    assert "converged" not in out


def test_feasible_needs_the_junction_conditions_not_solved_for():
    """The default set solves (18), (21), (23), (24'); with a uniform speed v1 that the solved pair does not
    have, (17) is unmet and the pair cannot join the uniform phase: not feasible (it was 'feasible: True')."""
    task = dataclasses.replace(example_task(), v1=0.5)
    sol = gs.solve_sectors(task)
    assert sol.converged
    assert abs(sol.residuals["r17"]) > 0.1
    assert not sol.feasible and "r17" in sol.message and "eq. 17" in sol.message
    # least squares over inconsistent data converges, but what it fits is not a solution of the seed's system
    fit = gs.solve_sectors(task, "lsq")
    assert fit.converged and not fit.feasible


def test_cli_reports_an_unmet_junction_as_no_feasible_solution():
    rc, out, err = synth("--v1", "0.5")
    assert rc == 2 and "feasible: False" in out and "feasible: True" not in out
    assert err.strip().startswith("error: synth sectors: no feasible solution") and "r17" in err


def test_consistent_data_and_not_given_conditions_stay_feasible():
    """The worked example meets all eight; a task that gives only (17)-(20) (build_law's) is judged on them."""
    sol = gs.solve_sectors(example_task())
    assert sol.converged and sol.feasible
    assert max(abs(r) for r in sol.residuals.values()) < 1e-12
    t = example_task()
    only = dataclasses.replace(t, l_i=math.nan, phi12=math.nan, phiC12=math.nan, c1=math.nan)
    assert gs.checked_residuals(only) == ("r17", "r18", "r19", "r20")
    sol = gs.solve_sectors(only, ("r17", "r18", "r19", "r20"))
    assert sol.converged and sol.feasible


# ------------------------------------------------------------------------------------------ the seed's rules
@pytest.fixture(scope="module")
def press():
    import systems.proof_press as pp
    inst = next(i for i in pp.SYSTEM.instances if i.name == "press")
    p = gs.GearSectorsParams(**inst.parameters)
    return p, gs.GearSectorsModel(p)


def test_proof_press_phases_fill_one_turn_and_the_cylinder_path_closes(press):
    """Eq. (2): the four phase angles sum to 2 pi, each positive; eq. (1): the surface path of one cycle is
    n pi D_Ci, here with n = 1 (the cylinder angle after one turn of the main shaft, evaluated)."""
    _, m = press
    law = m.law
    phases = (law.phi12, law.phi23, law.phi34, law.phi41)
    assert min(phases) > 0 and sum(phases) == pytest.approx(2 * math.pi, abs=1e-12)
    turn = law.evaluate(law.phi1 + 0.1 + 2 * math.pi)[0] - law.evaluate(law.phi1 + 0.1)[0]
    assert turn == pytest.approx(2 * math.pi * law.n_rev, abs=1e-9) and law.n_rev == 1


def test_proof_press_sectors_meet_the_junction_conditions_at_both_points(press):
    """(17)-(20) at points 1 and 2 of the acceleration pair and (mapped) of the braking pair, recomputed from
    the bed law and the solved geometry, not read from the solver's residuals."""
    p, m = press
    D = p.D_C / (p.r_K * p.i_CK)
    for sol, d0, phi, sign in ((m.acc, p.delta0_acc, p.phi2, 1.0), (m.brk, p.delta0_brk, p.phi3, -1.0)):
        _, v, w = gs.bed_law(phi, p.lambda_s)
        s = gs.summarize(*sol.x, d0)
        assert s.monotonic
        assert s.omega1 * D / 2 == pytest.approx(p.v1, abs=1e-9)          # (17)
        assert s.eps1_fwd == pytest.approx(0.0, abs=1e-9)                  # (18)
        assert s.omega2 * D / 2 == pytest.approx(v, abs=1e-9)              # (19)
        assert s.eps2_fwd * D / 2 == pytest.approx(sign * w, abs=1e-9)     # (20)
        assert abs(sol.eps1) < sol.kappa and abs(sol.eps2) < 1.0           # round sectors, pivots inside


def test_concentric_sectors_turn_at_the_tooth_ratio():
    """With eps1 = eps2 = 0 the 'non-round' pair is an ordinary gear pair: omega_C = kappa = z_A/z_B, no
    acceleration, constant centre distance kappa + 1."""
    beta = np.linspace(0.0, 0.9, 50)
    _, _, li, om, ec = gs.sector_arrays(beta, 0.0, 0.0, 1.7, 0.9, 0.3)
    assert np.allclose(om, 1.7) and np.allclose(ec, 0.0, atol=1e-12) and np.allclose(li, 2.7)


def test_kinematics_depend_only_on_the_relative_sizes():
    """The seed after eq. (16): the cylinder kinematics depend only on eps1, eps2, kappa and beta0, not on the
    absolute sizes.  Scaling every length of a pair (R_B, e1, e2, R_A) by s leaves the invariants unchanged:
    computed from dimensional coordinates of C_A and C_B (eq. 3-4) for R_B = 0.05 and 0.2 m."""
    def dimensional(R_B, e1, e2, R_A, beta0, delta0, beta):
        dl = delta0 + (R_A / R_B + 1.0) * beta
        x = e2 * np.cos(dl) + (R_A + R_B) * np.cos(beta) - e1 * math.cos(beta0)
        y = e2 * np.sin(dl) + (R_A + R_B) * np.sin(beta) - e1 * math.sin(beta0)
        sigma = np.unwrap(np.arctan2(y, x))
        return np.gradient(dl - sigma, sigma), np.hypot(x, y) / R_B
    beta = np.linspace(0.0, 0.8, 4001)
    a = dimensional(0.05, 0.015, 0.015, 0.075, 0.8, -1.2, beta)
    b = dimensional(0.20, 0.060, 0.060, 0.300, 0.8, -1.2, beta)
    inv = gs.sector_arrays(beta, 0.3, 0.3, 1.5, 0.8, -1.2)
    assert np.allclose(a[0], b[0], atol=1e-12) and np.allclose(a[1], b[1], atol=1e-12)
    # and they are the invariants of eqs (5), (12): |d psi / d sigma| = omega_C (finite differences)
    assert np.allclose(np.abs(a[0][5:-5]), inv[3][5:-5], rtol=1e-5) and np.allclose(a[1], inv[2])


def test_sizes_follow_from_the_driven_sectors_radius():
    """The seed after (25): "then, from the design conditions, with R_B we find the parameters of the
    non-round sectors e1, e2, R_A": the printed sizes are the relative ones times R_B; a non-positive R_B is
    refused in one line."""
    import json

    rc, out, _ = synth("--R-B", "0.05", "--json")
    res = json.loads(out)
    assert rc == 0 and res["sizes_m"] == pytest.approx(
        {"R_B": 0.05, "e1": 0.05 * res["eps1"], "e2": 0.05 * res["eps2"], "R_A": 0.05 * res["kappa"]})
    rc, _, err = synth("--R-B", "0")
    assert rc == 2 and err.strip() == ("error: synth sectors: --R-B 0 m: pitch radius of the driven sector "
                                       "outside the allowed range (0, inf) m")


def test_quantities_left_out_free_their_conditions_and_the_pairs_own_values_are_printed():
    """The seed's data over-determine (25): with --not-given the conditions that need a left-out quantity
    are reported 'not given' instead of failing the pair, and the pair's own value is printed; a solved-for
    condition cannot lose its data, and D_Ci cannot be left out."""
    import json

    rc, out, err = synth("--v1", "0.75", "--residuals", "r17,r18,r19,r20")
    assert rc == 2 and "feasible: False" in out and "r21" in err
    rc, out, err = synth("--v1", "0.75", "--residuals", "r17,r18,r19,r20", "--not-given", "l_i,phi12,phiC12,c1",
                         "--json")
    res = json.loads(out)
    assert rc == 0 and res["converged"] and res["feasible"], err
    assert [res["residuals"][n] for n in ("r21", "r22", "r23", "r24")] == [None] * 4
    own = gs.task_from_geometry(res["eps1"], res["eps2"], res["kappa"], res["beta0"], -1.2, D_Ci=1.68)
    assert res["not_given_the_pairs_own"]["l_i"] == pytest.approx(own.l_i)
    assert gs.summarize(res["eps1"], res["eps2"], res["kappa"], res["beta0"], -1.2).omega1 * 1.68 / 2 == \
        pytest.approx(0.75, abs=1e-9)
    rc, _, err = synth("--residuals", "r17,r18,r19,r20", "--not-given", "v1")
    assert rc == 2 and err.strip() == ("error: synth sectors: residual set r17,r18,r19,r20: r17 needs v1, which "
                                       "is not given")
    rc, _, err = synth("--not-given", "D_Ci")
    assert rc == 2 and "D_Ci cannot be left out (allowed: v1, v2, w2, l_i, phi12, phiC12, c1)" in err
    rc, out, _ = synth("--residuals", "lsq", "--not-given", "c1")
    assert rc == 0 and "r24  =   not given" in out


# ------------------------------------------------------------------------------- the centre distance condition
def _eq5(x, delta0, n=4001):
    """Eqs. (4)-(5) written here: C_B relative to C_A (per R_B) at carrier angles beta in [0, beta0], the centre
    distance l = |C_A C_B| and the crank angle sigma = atan2(Y, X) of the inverted frame."""
    e1, e2, k, b0 = x
    beta = np.linspace(0.0, b0, n)
    X = e2 * np.cos(delta0 + (k + 1) * beta) + (k + 1) * np.cos(beta) - e1 * math.cos(b0)
    Y = e2 * np.sin(delta0 + (k + 1) * beta) + (k + 1) * np.sin(beta) - e1 * math.sin(b0)
    return np.hypot(X, Y), np.unwrap(np.arctan2(Y, X))


def _ends(x, delta0):
    """(l at beta = 0, l at beta0, spread, |dl/dsigma| at beta = 0 by a one-sided difference)."""
    l, s = _eq5(x, delta0)
    return l[0], l[-1], l.max() / l.min() - 1, abs((l[1] - l[0]) / (s[1] - s[0]))


def test_proof_press_centre_distance_against_the_papers_condition(press):
    """The paper: l constant, or following the cylinder's lowering/raising law, else an angular correction.
    Recomputed from eq. (5): l is not constant (13.1 % on the acceleration pair, 9.4 % on braking).  Followed
    by the cylinder's axis (sector_lift), it moves one way on each pair, is at rest at points 1 and 4, but
    with the print heights made one (R_B,7/R_B,9 = l_2/l_3 = 1.086) the uniform phase's heights differ by
    3.4 % (closure), and the axis reaches the print height at 0.754 and 0.486 R_B per radian of crank."""
    from fmus.physics import sector_lift as sl

    p, m = press
    a, b = _ends(m.acc.x, p.delta0_acc), _ends(m.brk.x, p.delta0_brk)
    # the rounded numbers (13.1 %, 9.4 %, 1.086, 3.4 %, 0.754, 0.486) are the ones docs/seeds.md states for seed
    # 002's condition (the seed gives none): each is recomputed here from eq. (5) as this test writes it (_eq5,
    # _ends) and the toolkit's sector_lift must agree with that to 1e-9; the page must say what is computed
    stated = (ROOT / "docs" / "seeds.md").read_text(encoding="utf-8")
    assert all(x in stated for x in ("(13.1 %)", "(9.4 %)", "= 1.086)", "3.4 % of l", "0.754 (point 2)", "0.486 (point 3)"))
    assert (a[2], b[2]) == pytest.approx((0.131, 0.094), abs=5e-4)
    rep = sl.lift_report(m.law)
    for pair, ends in ((rep.acc, a), (rep.brk, b)):
        assert (pair.l_print, pair.l_uniform, pair.spread) == pytest.approx(ends[:3], rel=1e-9)
        assert pair.slope_print == pytest.approx(ends[3], rel=2e-3) and pair.monotonic
        assert pair.slope_uniform < 1e-6
    assert rep.radius_ratio == pytest.approx(a[0] / b[0], rel=1e-12) and rep.radius_ratio == pytest.approx(1.086, abs=1e-3)
    closure = (a[1] / a[0]) / (b[1] / b[0]) - 1
    assert rep.closure == pytest.approx(closure, rel=1e-9) and closure == pytest.approx(0.0338, abs=1e-4)
    assert (rep.acc.slope_print, rep.brk.slope_print) == pytest.approx((0.754, 0.486), abs=1e-3)


def test_braking_sectors_solved_with_the_centre_distance_as_a_condition(press):
    """The braking pair's delta0 solved so that the cylinder's axis has one height while printing and one in the
    uniform phase: the pair, synthesised anew from (17)-(20) by the toolkit, meets the closure to 1e-9 by eq.
    (5) written here; it still meets (17)-(20); the price is eq. (1): the cylinder's turn per cycle moves
    from 6e-14 to 1.4e-3 rad off 2 pi, and the axis still reaches the print height at a speed."""
    from fmus.physics import sector_lift as sl

    p, m = press
    d0, rep, cycle_error = sl.closing_braking_delta0(p, (-1.25, -1.2))
    assert d0 == pytest.approx(-1.2409, abs=1e-4)
    brk = gs.GearSectorsModel(dataclasses.replace(p, delta0_brk=d0)).brk
    a, b = _ends(m.acc.x, p.delta0_acc), _ends(brk.x, d0)
    assert abs((a[1] / a[0]) / (b[1] / b[0]) - 1) < 1e-9 and abs(rep.closure) < 1e-9
    _, v3, w3 = gs.bed_law(p.phi3, p.lambda_s)
    s = gs.summarize(*brk.x, d0)
    D = p.D_C / (p.r_K * p.i_CK)
    assert (s.omega1 * D / 2, s.eps1_fwd, s.omega2 * D / 2, s.eps2_fwd * D / 2) == pytest.approx(
        (p.v1, 0.0, v3, -w3), abs=1e-9)
    assert abs(m.law.cycle_error) < 1e-12 and cycle_error == pytest.approx(1.42e-3, abs=1e-5)
    assert rep.brk.slope_print == pytest.approx(b[3], rel=2e-3) and b[3] > 0.6


def test_rigid_sectors_on_the_compliant_main_shaft_are_refused_in_one_line(fmu_dir):
    """press.fidelity = 0 takes the crank's acceleration as zero: on the compliant shaft the main-shaft speed
    swings (-3.8..10.4 rad/s) without converging; the run is refused at load, naming both values, why, and what
    to use.  On the rigid shaft the rigid sectors run."""
    import warnings

    from harness import load, simulate
    from harness.errors import SystemError_

    system = load("proof_press").on_fmus(fmu_dir)
    with pytest.raises(SystemError_) as e:
        simulate(system, stop_time=0.01, start_values={"press.fidelity": 0}, on_error="raise")
    line = str(e.value)
    assert "\n" not in line and "press.fidelity = 0" in line and "flywheel.fidelity = 1" in line
    assert "crank's acceleration" in line and "use press.fidelity=1" in line
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = simulate(system, stop_time=0.01, start_values={"press.fidelity": 0, "flywheel.fidelity": 0},
                      on_error="raise")
    assert len(df) == 51
