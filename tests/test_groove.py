"""Tier 1: LCSM groove synthesis (K6-K9) against geometry, the base four-bar check, and the CLI."""
import argparse
import json
import math

import numpy as np
import pytest

from fmus.physics import groove as G
from fmus.physics import laws as L
from harness.synthesis import groove as cli

LAM1, LAM3 = 3.5, 3.0


@pytest.mark.parametrize("lam2", [3.5, 4.5])
def test_base_fourbar_law_gives_constant_radius(lam2):
    phi = np.linspace(0, 2 * math.pi, 4001)
    g = np.unwrap(G.base_fourbar_angle(phi, LAM1, lam2, LAM3))
    h = phi[1] - phi[0]
    g1 = np.gradient(g, h)
    p = G.synthesize(phi, g, g1, np.gradient(g1, h), LAM1, lam2, G.base_branch(LAM1, lam2, LAM3))
    assert np.max(np.abs(p.rho - LAM3)) < 1e-9


def test_profile_point_is_on_the_ray_and_at_conrod_length():
    lam2 = 4.03
    law = G.kulisa_law(LAM1, lam2, LAM3, L.get_law("K0"))
    p = G.synthesize_law(law, LAM1, lam2, 2000, G.base_branch(LAM1, lam2, LAM3))
    A = np.stack([-LAM1 + np.cos(p.phi), np.sin(p.phi)], axis=1)
    assert np.allclose(np.hypot(*(p.B - A).T), lam2, atol=1e-12)
    assert np.allclose(np.arctan2(p.B[:, 1], p.B[:, 0]) % (2 * math.pi), p.gamma % (2 * math.pi), atol=1e-12)
    # closed-form derivative and curvature equal finite differences of the points
    h = p.phi[1] - p.phi[0]
    dB = (np.roll(p.B, -1, 0) - np.roll(p.B, 1, 0)) / (2 * h)
    inner = p.moving & np.roll(p.moving, 1) & np.roll(p.moving, -1)
    assert np.max(np.abs(dB - p.dB)[inner]) < 1e-3 * np.max(p.speed)
    ddB = (np.roll(p.B, -1, 0) - 2 * p.B + np.roll(p.B, 1, 0)) / h ** 2
    kap = (dB[:, 0] * ddB[:, 1] - dB[:, 1] * ddB[:, 0]) / np.hypot(*dB.T) ** 3
    sel = inner & (p.speed > 0.2 * np.max(p.speed))
    assert np.allclose(kap[sel], p.curvature[sel], rtol=1e-3, atol=1e-3)
    for i in (5, 700, 1500):
        rho, _, th = G.stone_scalar(p.phi[i], p.gamma[i], law(p.phi[i], math)[1], LAM1, lam2, G.base_branch(LAM1, lam2, LAM3))
        assert rho == pytest.approx(p.rho[i], abs=1e-12) and th == pytest.approx(p.theta[i], abs=1e-9)


def test_law_meets_the_base_fourbar_extremes_and_dwell():
    lam2 = 4.03
    ext = G.fourbar_extremes(LAM1, lam2, LAM3)
    for phi_e, g_e in ext.values():
        assert float(G.base_fourbar_angle(phi_e, LAM1, lam2, LAM3)) == pytest.approx(g_e, abs=1e-12)
    law = G.kulisa_law(LAM1, lam2, LAM3, L.get_law("K0"), dwell=0.3)
    g_end = law(ext["extended"][0], math)[0]
    assert g_end == pytest.approx(ext["extended"][1], abs=1e-12)
    assert law(ext["extended"][0] + 0.1, math)[1] == 0.0   # inside the dwell


def _args(*extra):
    ap = argparse.ArgumentParser()
    cli.register(ap.add_subparsers())
    return ap.parse_args(["groove", *extra])


def test_cli_scan_and_criteria(capsys, tmp_path):
    a = _args("--crank-radius", "0.040", "--lambda1", "3.5", "--lambda3", "3", "--law", "K0", "--scan", "lambda2", "--json")
    assert a.func(a) == 0
    out = json.loads(capsys.readouterr().out)
    lo, hi = out["lambda2_min"], out["lambda2_max"]
    assert lo < hi
    mp = math.radians(out["max_pressure_angle_deg"])

    def verdict(l2):
        law = G.kulisa_law(LAM1, l2, LAM3, L.get_law("K0"))
        return G.assess(G.synthesize_law(law, LAM1, l2, 3600, G.base_branch(LAM1, l2, LAM3)), 0.04, 0.0, mp)["failed"]

    assert verdict(0.5 * (lo + hi)) is None
    assert verdict(lo - 1e-3) is not None and verdict(hi + 1e-3) is not None
    f = tmp_path / "p.txt"
    a = _args("--lambda2", str(0.5 * (lo + hi)), "--out", str(f))
    assert a.func(a) == 0
    lines = f.read_text().splitlines()
    data = np.loadtxt(f)
    assert lines[0].startswith("#") and data.shape == (3600, 2)
    assert np.all((np.hypot(*data.T) > 0.05) & (np.hypot(*data.T) < 0.2))   # metres, not r units


def test_cli_errors(capsys):
    a = _args("--lambda2", "1.2")
    assert a.func(a) == 2
    assert capsys.readouterr().err.count("\n") == 1
    a = _args("--law", "nope", "--scan", "lambda2")
    assert a.func(a) == 2


def test_scan_names_the_criterion_at_each_end(capsys):
    a = _args("--crank-radius", "0.040", "--lambda1", "3.5", "--lambda3", "3", "--law", "K0", "--scan", "lambda2", "--json")
    assert a.func(a) == 0
    out = json.loads(capsys.readouterr().out)
    lo, hi = out["lambda2_min"], out["lambda2_max"]
    by = out["bounds_by_criterion"]
    # every criterion alone admits an interval that contains the all-criteria one
    for c, v in by.items():
        assert v["interval"][0] <= lo + 1e-9 and v["interval"][1] >= hi - 1e-9, c
    # the end that a criterion alone reproduces (to the bisection's 1e-6) is the one that criterion bounds
    ends = {c: (abs(v["interval"][0] - lo) < 1e-5, abs(v["interval"][1] - hi) < 1e-5) for c, v in by.items()}
    assert any(e[0] for e in ends.values()) and any(e[1] for e in ends.values())
    assert ends["pressure"][1] and not ends["connection"][1]          # the upper end: the pressure-angle limit
    assert ends["connection"][0]                                      # the lower end: the connection break
    # the seed's own criteria (no pressure limit) admit a wider interval; it ends where the base four-bar does
    s_lo, s_hi = out["seed_interval"]
    assert s_lo == pytest.approx(lo, abs=1e-5) and s_hi - s_lo > 10 * (hi - lo)
    assert out["seed_upper_limit"] == "base four-bar"
    assert s_hi == pytest.approx(LAM1 + LAM3 - 1.0, abs=1e-5)       # Grashof: 1 + lambda2 <= lambda1 + lambda3


@pytest.mark.parametrize("branch", [1, -1])
def test_stone_rate_on_both_branches(branch):
    """stone_scalar's drho/dphi is the derivative of stone_radius_scalar along the rocker law on either root of
    (K8), and the same number as stone_radius_rate_scalar's.  (It was +-inf on the root -1, whose Q < 0: the
    pressure angle output read 0 and level 3 started from a non-finite state.)"""
    lam1, lam2, g1, e = 3.5, 4.2, 0.4, 1e-6
    for phi in np.linspace(0.2, 6.0, 13):
        g = 0.3 + 0.2 * math.sin(phi)
        rho, rate, theta = G.stone_scalar(phi, g, g1, lam1, lam2, branch)
        numeric = (G.stone_radius_scalar(phi + e, g + g1 * e, lam1, lam2, branch)
                   - G.stone_radius_scalar(phi - e, g - g1 * e, lam1, lam2, branch)) / (2 * e)
        assert rate == pytest.approx(numeric, rel=1e-6, abs=1e-8)
        assert (rho, rate) == G.stone_radius_rate_scalar(phi, g, g1, lam1, lam2, branch)
        assert 0.0 <= theta <= math.pi / 2


def test_an_undefined_pressure_angle_does_not_fail_the_groove():
    """Issue 31: where the stone stands still in the groove (the kulisa at rest at a stroke end) the pressure
    angle is 0/0 = NaN; np.all over it failed the whole groove at scattered lambda2 (C0: 10 of 160 grid values
    on 3.9-5.5) and ended the C0 interval at such an artefact.  K0 at lambda2 = 5.4 has one such sample."""
    lam2 = 5.4
    law = G.kulisa_law(LAM1, lam2, LAM3, L.get_law("K0"))
    p = G.synthesize_law(law, LAM1, lam2, 3600, G.base_branch(LAM1, lam2, LAM3))
    assert np.isnan(p.theta).sum() == 1
    rep = G.assess(p, 0.04, 0.0, math.radians(89.0))
    assert "pressure" not in rep["all_failed"] and rep["pressure_angle_max"] < math.radians(89.0)
    assert "pressure" in G.assess(p, 0.04, 0.0, rep["pressure_angle_max"] - 1e-6)["all_failed"]   # still checked


def test_scan_labels_the_criterion_that_bounds_each_end_and_prints_no_raw_dicts(capsys):
    """C0: the lower end is the connection break (its own interval ends there; a cusp or the pressure angle
    fail at the same point but do not bound it), the upper end the pressure-angle limit, where the
    pressure criterion's own interval ends; the text output has one line per criterion."""
    a = _args("--law", "C0", "--scan", "lambda2", "--json")
    assert a.func(a) == 0
    out = json.loads(capsys.readouterr().out)
    by = out["bounds_by_criterion"]
    assert out["lower_limit"] == "connection" and out["seed_lower_limit"] == "connection"
    assert out["lambda2_min"] == pytest.approx(by["connection"]["interval"][0], abs=1e-6)
    assert out["upper_limit"] == "pressure"
    assert out["lambda2_max"] == pytest.approx(by["pressure"]["interval"][1], abs=1e-6)
    law = G.kulisa_law(LAM1, out["lambda2_max"] - 1e-4, LAM3, L.get_law("C0"))
    p = G.synthesize_law(law, LAM1, out["lambda2_max"] - 1e-4, 3600, G.base_branch(LAM1, out["lambda2_max"], LAM3))
    assert G.assess(p, 0.04, 0.0, math.radians(60.0))["failed"] is None
    a = _args("--law", "C0", "--scan", "lambda2")
    assert a.func(a) == 0
    text = capsys.readouterr().out
    assert "{" not in text and "  pressure: [" in text


def test_compare_laws_says_where_each_column_belongs(capsys):
    """--compare-laws: the interval column is each law's scan, the failed criteria and the figures are at the
    lambda2 column; no 'feasible True' beside a failed criterion, floats rounded."""
    a = _args("--compare-laws", "--lambda2", "4.2")
    assert a.func(a) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:4] == ["law", "interval", "lambda2", "failed_at_lambda2"]
    k0 = next(line for line in lines if line.split()[0] == "K0")
    assert "True" not in k0 and "[4.0173, 4.0547]" in k0 and "pressure" in k0 and "4.2000" in k0
    assert all(len(tok.split(".")[-1]) <= 4 for line in lines[1:6] for tok in line.split()
               if tok.replace(".", "").replace("-", "").isdigit())
