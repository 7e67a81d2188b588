"""Four-bar synthesis and analysis of seed 004 (bed_drives.md 2.2.2), checked by independent methods."""
from __future__ import annotations

import argparse
import importlib.util
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize

from fmus.physics.base import ParameterError
from fmus.physics.fourbar_synthesis import analyse, synthesise

ROOT = Path(__file__).resolve().parents[1]
CLI = ROOT / "harness" / "synthesis" / "fourbar.py"
PUBLISHED = (1.0, 1.91579, 2.10526, 2.25263)   # crank, coupler, frame, rocker


def brute(b, f, r, n=200001):
    """Brute force by direct geometry (circle intersection), crank angle sampled densely."""
    phi = np.linspace(0.0, 2 * np.pi, n)
    ax, ay = np.cos(phi), np.sin(phi)
    dx, dy = f - ax, -ay                       # A -> O5
    d = np.hypot(dx, dy)
    # D from the intersection of circle(A, b) and circle(O5, r), upper solution in the usual picture
    l = (b * b - r * r + d * d) / (2 * d)
    hgt = np.sqrt(b * b - l * l)
    px, py = ax + l * dx / d, ay + l * dy / d
    Dx, Dy = px - hgt * dy / d, py + hgt * dx / d
    psi = np.unwrap(np.arctan2(Dy, Dx - f))
    mu = np.arccos(((Dx - ax) * (Dx - f) + (Dy - ay) * Dy) / (b * r))
    return phi, psi, mu


def closed_extremes(b, f, r):
    """Spec 2.2.2 closed forms from the two extreme positions."""
    sw = abs(math.acos((f * f + r * r - (b + 1) ** 2) / (2 * f * r)) - math.acos((f * f + r * r - (b - 1) ** 2) / (2 * f * r)))
    th = (math.acos((f * f + (b - 1) ** 2 - r * r) / (2 * f * (b - 1)))
          - math.acos((f * f + (b + 1) ** 2 - r * r) / (2 * f * (b + 1))))
    return sw, th


def test_published_linkage_against_brute_force_and_closed_forms():
    an = analyse(*PUBLISHED)
    _, b, f, r = PUBLISHED
    phi, psi, mu = brute(b, f, r)
    assert an.swing_deg == pytest.approx(math.degrees(psi.max() - psi.min()), abs=1e-6)
    assert an.swing_deg == pytest.approx(60.0, abs=0.05)
    mu_eff = np.minimum(mu, np.pi - mu)
    assert an.min_transmission_deg == pytest.approx(math.degrees(mu_eff.min()), abs=1e-5)
    assert an.min_transmission_deg == pytest.approx(30.0, abs=1.0)
    sw, th = closed_extremes(b, f, r)
    assert math.radians(an.swing_deg) == pytest.approx(sw, abs=1e-10)
    assert an.time_ratio == pytest.approx((math.pi + th) / (2 * math.pi), abs=1e-10)
    # extremes of the sampled rocker angle: crank angle between them
    k_max, k_min = int(np.argmax(psi)), int(np.argmin(psi))
    span = math.degrees((phi[k_min] - phi[k_max]) % (2 * math.pi))
    assert max(span, 360 - span) == pytest.approx(an.working_stroke_deg, abs=0.01)
    assert an.working_stroke_deg + an.idle_stroke_deg == pytest.approx(360.0)
    assert 0.57 <= an.time_ratio <= 0.63                       # the seed's recommended K_px range


def test_velocity_and_acceleration_coefficients_two_ways():
    an = analyse(*PUBLISHED)
    _, b, f, r = PUBLISHED
    phi, psi, _ = brute(b, f, r, n=360001)
    h = phi[1] - phi[0]
    dpsi = np.gradient(psi, h)
    ddpsi = np.gradient(dpsi, h)
    sw = math.radians(an.swing_deg)
    wstroke, istroke = math.radians(an.working_stroke_deg), math.radians(an.idle_stroke_deg)
    # B = peak speed / mean speed of the stroke (mean speed = swing / stroke duration)
    # working stroke: psi moves one way, idle the other; find which direction is the working one
    up = np.max(dpsi) * wstroke / sw, np.max(-dpsi) * istroke / sw
    down = np.max(-dpsi) * wstroke / sw, np.max(dpsi) * istroke / sw
    pairs = [p for p in (up, down) if abs(p[0] - an.velocity_peak_working) < 1e-3]
    assert pairs, (up, down, an)
    assert pairs[0][1] == pytest.approx(an.velocity_peak_idle, rel=1e-4)
    assert an.velocity_peak_working == pytest.approx(pairs[0][0], rel=1e-4)
    # largest |c| over the working + idle strokes is the largest acceleration ratio over the turn
    c_all = max(an.accel_runup_working, an.accel_runout_working) / wstroke ** 2 * sw
    c_idle = max(an.accel_runup_idle, an.accel_runout_idle) / istroke ** 2 * sw
    assert max(c_all, c_idle) == pytest.approx(np.max(np.abs(ddpsi[2:-2])), rel=1e-3)


def test_mirror_branch_swaps_run_up_and_run_out():
    a1 = analyse(*PUBLISHED, branch=1)
    a2 = analyse(*PUBLISHED, branch=-1)
    assert a2.time_ratio == pytest.approx(a1.time_ratio, abs=1e-12)
    assert a2.velocity_peak_working == pytest.approx(a1.velocity_peak_working, rel=1e-9)
    assert a2.accel_runup_working == pytest.approx(a1.accel_runout_working, rel=1e-6)
    assert a2.accel_runout_idle == pytest.approx(a1.accel_runup_idle, rel=1e-6)


def slsqp_reference(swing, lim):
    """Independent optimiser for the same formulation (max theta, swing fixed, transmission >= lim)."""
    def parts(z):
        b, f, r = z
        sw, th = closed_extremes(b, f, r)
        m1 = math.acos((b * b + r * r - (f - 1) ** 2) / (2 * b * r))
        m2 = math.acos((b * b + r * r - (f + 1) ** 2) / (2 * b * r))
        return sw, th, m1, m2
    cons = [{"type": "eq", "fun": lambda z: parts(z)[0] - swing},
            {"type": "ineq", "fun": lambda z: parts(z)[2] - lim},
            {"type": "ineq", "fun": lambda z: math.pi - lim - parts(z)[3]}]
    best = None
    for z0 in ([1.9, 2.1, 2.2], [2.5, 2.5, 2.0], [1.5, 2.0, 2.5], [3.0, 3.0, 3.0]):
        try:
            res = minimize(lambda z: -parts(z)[1], z0, constraints=cons, method="SLSQP",
                           bounds=[(1.01, 20), (1.01, 20), (0.05, 20)], options={"ftol": 1e-12, "maxiter": 500})
        except ValueError:
            continue
        if res.success and (best is None or res.fun < best.fun):
            best = res
    return best


def test_synthesis_meets_its_formulation_and_is_close_to_the_published_lengths():
    s = synthesise(60.0, 30.0)
    _, phi_psi, mu = brute(s.coupler, s.frame, s.rocker)
    assert math.degrees(phi_psi.max() - phi_psi.min()) == pytest.approx(60.0, abs=1e-5)
    assert math.degrees(np.minimum(mu, np.pi - mu).min()) == pytest.approx(30.0, abs=1e-4)
    ref = slsqp_reference(math.radians(60), math.radians(30))
    th_ref = -ref.fun
    assert s.time_ratio == pytest.approx((math.pi + th_ref) / (2 * math.pi), abs=2e-5)
    assert s.time_ratio >= (math.pi + th_ref) / (2 * math.pi) - 2e-5
    for got, pub in zip((s.coupler, s.frame, s.rocker), PUBLISHED[1:]):
        assert got == pytest.approx(pub, rel=0.02)
    # a stricter limit gives a smaller time ratio
    assert synthesise(60.0, 35.0).time_ratio < s.time_ratio


def test_impossible_inputs_raise_parameter_errors():
    with pytest.raises(ParameterError, match="rocker = 5"):
        analyse(1.0, 1.91579, 2.10526, 5.0)
    with pytest.raises(ParameterError, match="min_transmission"):
        synthesise(170.0, 80.0)


def _load_cli():
    spec = importlib.util.spec_from_file_location("fourbar_cli_under_test", CLI)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_cli_json_and_errors(capsys):
    cli = _load_cli()
    parser = argparse.ArgumentParser(prog="synth")
    cli.register(parser.add_subparsers(dest="tool"))
    args = parser.parse_args(["fourbar", "--analyse", "--coupler", "1.91579", "--frame", "2.10526",
                              "--rocker", "2.25263", "--json"])
    assert args.func(args) == 0
    data = json.loads(capsys.readouterr().out)
    for key in ("crank", "coupler", "frame", "rocker", "time_ratio", "swing_deg", "min_transmission_deg",
                "working_stroke_deg", "idle_stroke_deg", "velocity_peak_working", "velocity_peak_idle",
                "accel_runup_working", "accel_runout_working", "accel_runup_idle", "accel_runout_idle"):
        assert key in data
    assert data["time_ratio"] == pytest.approx(analyse(*PUBLISHED).time_ratio)
    args = parser.parse_args(["fourbar", "--swing", "60", "--min-transmission", "30"])
    assert args.func(args) == 0
    assert "time ratio" in capsys.readouterr().out
    proc = subprocess.run([sys.executable, str(CLI), "fourbar", "--analyse", "--coupler", "1.9", "--frame", "2.1",
                           "--rocker", "5"], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stdout == "" and len(proc.stderr.strip().splitlines()) == 1
    assert "--rocker 5" in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.parametrize("linkage", [PUBLISHED, (1.0, 3.0, 2.5, 2.8), (1.0, 4.0, 3.5, 2.0), (1.0, 2.2, 2.0, 1.5)])
@pytest.mark.parametrize("branch", [1, -1])
def test_extreme_crank_angles_are_the_zeros_of_the_rockers_speed(linkage, branch):
    """The closed form (crank and coupler collinear) against the sign changes of dpsi/dphi found by SciPy."""
    from scipy.optimize import brentq

    from fmus.physics.fourbar import kinematics
    from fmus.physics.fourbar_synthesis import extreme_crank_angles, stroke_angles
    a, b, f, r = linkage
    speed = lambda x: float(kinematics(x, a, b, f, r, branch)[1])   # noqa: E731
    grid = np.linspace(0.0, 2 * np.pi, 721)
    v = kinematics(grid, a, b, f, r, branch)[1]
    zeros = [brentq(speed, grid[k], grid[k + 1], xtol=1e-15, rtol=1e-15)
             for k in range(len(grid) - 1) if v[k] * v[k + 1] < 0.0]
    assert len(zeros) == 2
    assert extreme_crank_angles(a, b, f, r, branch) == pytest.approx(tuple(zeros), abs=1e-12)
    full, strokes = analyse(*linkage, branch=branch), stroke_angles(*linkage, branch=branch)
    for name in ("coupler", "frame", "rocker", "working_stroke_deg", "idle_stroke_deg", "working_start_deg",
                 "idle_start_deg"):
        assert getattr(strokes, name) == getattr(full, name)
