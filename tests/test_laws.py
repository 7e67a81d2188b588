"""Tier 1: laws of periodic motion against closed forms and numerical derivatives."""
import math

import numpy as np
import pytest

from fmus.physics import laws as L

K = np.linspace(0.0, 1.0, 200001)


@pytest.mark.parametrize("name", L.LAW_NAMES)
def test_ends_and_derivatives(name):
    law = L.get_law(name)
    a, b, c = law(K)
    assert a[0] == pytest.approx(0.0, abs=1e-12) and a[-1] == pytest.approx(1.0, abs=1e-12)
    h = K[1] - K[0]
    # central differences away from the piece joints (where c may jump)
    assert np.max(np.abs((a[2:] - a[:-2]) / (2 * h) - b[1:-1])) < 1e-6
    db = (b[2:] - b[:-2]) / (2 * h) - c[1:-1]
    joints = [e for e, _ in law.pieces[:-1]]
    mask = np.ones_like(db, bool)
    for j in joints:
        mask &= np.abs(K[1:-1] - j) > 3 * h
    assert np.max(np.abs(db[mask])) < 1e-3
    for k in (0.0, 0.13, 0.5, 0.77, 1.0):
        assert np.allclose(law(k, math), [v[0] for v in law(np.array([k]))], rtol=0, atol=1e-12)


def test_closed_form_coefficients():
    cases = {"K0": (math.pi / 2, math.pi ** 2 / 2), "C0": (2.0, 2 * math.pi),
             "polydynamic": (1.875, 10 / math.sqrt(3))}
    for name, (cv, ca) in cases.items():
        got = L.get_law(name).coefficients()
        assert got == pytest.approx((cv, ca), rel=1e-6)
    for n in (1.0, 2.0, 3.5):
        C = 4 * (n + 1) * (n + 2) / (n * (n + 3))
        assert L.get_law("power", n=n).coefficients() == pytest.approx((2 * (n + 2) / (n + 3), C), rel=1e-6)
    assert L.power_constant(1.0) == pytest.approx(6.0) and L.power_constant(2.0) == pytest.approx(4.8)


def test_symmetry_and_special_cases():
    for name in ("K0", "C0", "polydynamic", "4567", "power"):
        a, b, c = L.get_law(name)(K)
        assert np.allclose(a + a[::-1], 1.0, atol=1e-12) and np.allclose(b, b[::-1], atol=1e-9)
        assert np.allclose(c, -c[::-1], atol=1e-6)
    # P6 stand-in with k_m = 1/2 is the cycloidal law; composite joins with c = 0 at k_m
    assert np.allclose(np.array(L.get_law("P6", k_m=0.5)(K)), np.array(L.get_law("C0")(K)), atol=1e-12)
    comp = L.get_law("composite", k_m=0.3)
    _, b, c = comp(np.array([0.3 - 1e-9, 0.3 + 1e-9, 0.0]))
    assert abs(b[0] - b[1]) < 1e-6 and abs(c[0]) < 1e-6 and abs(c[1]) < 1e-6 and c[2] == 0.0
    a, _, _ = L.get_law("P6", k_m=0.3)(K)
    assert not np.allclose(a + a[::-1], 1.0, atol=1e-3)   # asymmetric


def test_unknown_law_and_bad_parameters():
    with pytest.raises(ValueError, match="known laws: K0, C0"):
        L.get_law("Shuna")
    with pytest.raises(ValueError, match="k_m"):
        L.get_law("composite", k_m=1.2)


def test_dwell_cycle():
    cyc = L.dwell_cycle("C0", phase_forward=2.0, phase_return=1.5, dwell=1.0, phi_start=0.3)
    phi = np.linspace(0, 4 * math.pi, 40001)
    s, s1, s2 = cyc(phi)
    th = np.mod(phi - 0.3, 2 * math.pi)
    assert np.all(s[(th > 2.0) & (th < 3.0)] == 1.0) and np.all(s[th > 4.5] == 0.0)
    assert np.all(s1[(th > 2.0) & (th < 3.0)] == 0.0)
    # velocity is the numerical derivative of position, continuous through the phase joints (C0)
    h = phi[1] - phi[0]
    assert np.max(np.abs(np.gradient(s, h) - s1)) < 1e-3
    x, v, acc = L.follower_motion(cyc, phi, 10.0, 0.05)
    assert np.max(x) == pytest.approx(0.05) and np.max(v) == pytest.approx(0.05 * 2.0 * 10.0 / 2.0, rel=1e-6)
    with pytest.raises(ValueError, match="exceeds 2"):
        L.dwell_cycle("K0", 4.0, 3.0)


JERK_LAWS = [(name, {}) for name in L.LAW_NAMES] + [("power", {"n": 1.5}), ("power", {"n": 3.0}),
                                                     ("P6", {"k_m": 0.3}), ("composite", {"k_m": 0.6}),
                                                     ("bed004", {"k_m": 0.15})]


def _segment_ends(law):
    """The law's piece ends and, for a law with a run-up share (bed004), its inner segments' ends u and 1 - u."""
    ends = [e for e, _ in law.pieces]
    ends += [v for p, u in law.params if p == "runup" for v in (u, 1.0 - u)]
    return ends


@pytest.mark.parametrize("name, params", JERK_LAWS, ids=[f"{n}-{p}" for n, p in JERK_LAWS])
def test_jerk_is_the_derivative_of_the_acceleration_invariant(name, params):
    """Law.jerk (dc/dk, each piece's c differentiated beside its own equation) against central differences of
    Law.scalar's c over 397 points of [0.002, 0.998], away (>= 1e-3) from the segment junctions, where c's slope
    jumps: within 1e-7 of the largest |dc/dk| (measured: <= 6.4e-10 for all but 4567, 4.9e-9, the rounding of
    its polynomial's differences).  Fails on the previous code (no Law.jerk)."""
    law = L.get_law(name, **params)
    ends = _segment_ends(law)
    h = 1e-6
    got, ref = [], []
    for k in np.linspace(0.002, 0.998, 397):
        if min(abs(k - e) for e in ends) < 1e-3:
            continue
        got.append(law.jerk(k))
        ref.append((law(k + h, math)[2] - law(k - h, math)[2]) / (2 * h))
    got, ref = np.array(got), np.array(ref)
    assert len(got) > 380
    assert np.max(np.abs(got - ref)) <= 1e-7 * np.max(np.abs(ref))


def test_dwell_cycle_jerk_is_the_derivative_of_its_acceleration():
    """DwellCycle.jerk: forward law's jerk / phase^3, 0 in the dwells, the return's with its sign, against central
    differences of DwellCycle.scalar's s'' over a turn (start 1 rad, a dwell, composite forward, P6 return), away
    from the phase junctions and the laws' inner junctions."""
    fwd, ret = L.get_law("composite", k_m=0.3), L.get_law("P6", k_m=0.6)
    cyc = L.DwellCycle(fwd, ret, 2.5, 2.0, 0.6, 1.0)
    junctions = [1.0 + v for v in (0.0, 0.3 * 2.5, 2.5, 3.1, 3.1 + 0.6 * 2.0, 5.1, 2 * math.pi)]
    h = 1e-6
    worst, scale, n = 0.0, 0.0, 0
    for phi in np.linspace(1.0, 1.0 + 2 * math.pi, 601):
        if min(abs(phi - j) for j in junctions) < 1e-3:
            continue
        ref = (cyc(phi + h, math)[2] - cyc(phi - h, math)[2]) / (2 * h)
        worst, scale, n = max(worst, abs(cyc.jerk(phi) - ref)), max(scale, abs(ref)), n + 1
    assert n > 580 and scale > 0.0
    assert worst <= 1e-7 * scale
