"""Seed 004 as the paper states it (issue 32): the four-bar's invariants in the seed's orientation, the carrier's
laws on both strokes, the cam that meets both the seed's r0/S and its pressure angle, and bed_drive built on
them.  The invariants are checked against an independent computation (circle intersection, finite
differences), never against a number typed here."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fmus.physics import bed_cam, bed_law as B
from fmus.physics.fourbar_synthesis import analyse, synthesise

PUBLISHED = (1.0, 1.91579, 2.10526, 2.25263)


def lower_assembly(b, f, r, phi):
    """Rocker angle by circle intersection, rocker pin on the other side of O5->A than fourbar's branch +1
    (sign(cross(D - O5, A - O5)) = -1), for crank angles phi (crank turning counter-clockwise)."""
    ax, ay = np.cos(phi), np.sin(phi)
    dx, dy = ax - f, ay                               # O5 -> A
    d = np.hypot(dx, dy)
    l = (r * r - b * b + d * d) / (2 * d)             # from O5 along O5->A
    h = np.sqrt(r * r - l * l)
    px, py = f + l * dx / d, l * dy / d
    Dx, Dy = px + h * dy / d, py - h * dx / d           # one of the two intersections
    cross = (Dx - f) * ay - Dy * (ax - f)
    Dx2, Dy2 = px - h * dy / d, py + h * dx / d
    use2 = cross > 0
    Dx, Dy = np.where(use2, Dx2, Dx), np.where(use2, Dy2, Dy)
    return np.unwrap(np.arctan2(Dy, Dx - f))


def invariants_by_differences(psi, phi, start, span):
    """B, C1, C3 of the stroke [start, start + span] of a densely sampled rocker angle psi(phi)."""
    h = phi[1] - phi[0]
    k = ((phi - start) % (2 * np.pi)) / span
    inside = k <= 1.0
    dpsi, ddpsi = np.gradient(psi, h), np.gradient(np.gradient(psi, h), h)
    order = np.argsort(k[inside])
    kk = k[inside][order]
    swing = abs(psi[inside][order][-1] - psi[inside][order][0])
    b = np.abs(dpsi[inside][order]) * span / swing
    c = np.abs(ddpsi[inside][order]) * span ** 2 / swing
    i = int(np.argmax(b))
    return b[i], c[2:i + 1].max(), c[i:-2].max(), kk


def test_seed_branch_puts_the_small_acceleration_peak_at_the_working_stroke_run_up():
    st = B.working_stroke()                 # the seed's orientation is the default of the carrier synthesis
    assert st.branch == B.SEED_BRANCH == -1
    an = analyse(*PUBLISHED, branch=B.SEED_BRANCH)
    _, b, f, r = PUBLISHED
    phi = np.linspace(0.0, 2 * np.pi, 720001)
    psi = lower_assembly(b, f, r, phi)
    for start, span, big_b, c1, c3 in (
            (an.working_start_deg, an.working_stroke_deg, an.velocity_peak_working, an.accel_runup_working,
             an.accel_runout_working),
            (an.idle_start_deg, an.idle_stroke_deg, an.velocity_peak_idle, an.accel_runup_idle,
             an.accel_runout_idle)):
        fb, fc1, fc3, _ = invariants_by_differences(psi, phi, math.radians(start), math.radians(span))
        assert (big_b, c1, c3) == pytest.approx((fb, fc1, fc3), rel=2e-3)
    # the seed's working stroke: small peak at the run-up, large at the run-out
    assert an.accel_runup_working < an.accel_runout_working
    # the carrier synthesis works on that stroke: its start acceleration is the run-up's
    c0 = float(st.invariants(np.array([0.0]))[2][0])
    assert abs(c0) < an.accel_runout_working


def test_synth_fourbar_prints_the_seed_orientation(capsys):
    from harness.__main__ import main

    assert main(["synth", "fourbar", "--analyse", "--coupler", "1.91579", "--frame", "2.10526", "--rocker",
                 "2.25263", "--branch", "-1", "--json"]) == 0
    seed = json.loads(capsys.readouterr().out)
    assert main(["synth", "fourbar", "--swing", "60", "--min-transmission", "30", "--branch", "-1", "--json"]) == 0
    synth = json.loads(capsys.readouterr().out)
    mirror = analyse(*PUBLISHED, branch=1)
    for got in (seed,):
        assert got["branch"] == -1
        assert got["accel_runup_working"] == pytest.approx(mirror.accel_runout_working, rel=1e-6)
        assert got["accel_runout_idle"] == pytest.approx(mirror.accel_runup_idle, rel=1e-6)
    s1 = synthesise(60.0, 30.0, branch=1)
    assert synth["branch"] == -1 and synth["coupler"] == pytest.approx(s1.coupler, rel=1e-12)
    assert synth["accel_runup_working"] == pytest.approx(s1.accel_runout_working, rel=1e-6)


def test_carrier_return_law_returns_the_bed_harmonically():
    """alpha5 = K delta + (1 + K) gamma over the idle stroke is the harmonic K0 return, the carrier returns
    monotonically, and the law's end values match the working stroke's (a continuous cycle)."""
    law = B.carrier_return_law()
    st = B.idle_stroke()
    k = np.linspace(0.0, 1.0, 4001)
    ag, bg, cg = law(k)
    ad, bd, cd = st.invariants(k)
    K, dS, gS = B.SEED_RATIO, abs(st.swing), B.SEED_CARRIER_SWING
    aS = K * dS + (1 + K) * gS
    for g, d, want in zip((ag, bg, cg), (ad, bd, cd), B.bed_idle_invariants(k)):
        np.testing.assert_allclose((K * dS * d + (1 + K) * gS * g) / aS, want, rtol=0, atol=1e-9)
    np.testing.assert_allclose(B.bed_idle_invariants(k)[0], (1 - np.cos(np.pi * k)) / 2, atol=1e-15)
    assert ag[0] == pytest.approx(0.0, abs=1e-12) and ag[-1] == pytest.approx(1.0, abs=1e-9)
    assert np.min(bg) >= -1e-9
    # the four-bar returns the swing of its working stroke: the cycle closes
    assert abs(st.swing) == pytest.approx(abs(B.working_stroke().swing), rel=1e-9)
    # the registry's return law is this one (the component's law_return = 9)
    from fmus.physics.laws import LAW_NAMES, get_law
    assert LAW_NAMES[9] == "bed004r"
    np.testing.assert_allclose(get_law("bed004r")(k)[1], bg, atol=1e-15)


def test_synth_carrier_reports_both_strokes_in_the_seed_orientation(capsys):
    from harness.__main__ import main

    assert main(["synth", "carrier", "--no-cam", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["branch"] == -1
    assert out["carrier_idle"] == pytest.approx(B.stroke_invariants(B.carrier_return_law()), rel=1e-12)
    # not the harmonic law of the carrier itself (the former return): its B would be pi/2
    assert abs(out["carrier_idle"]["B"] - math.pi / 2) > 0.1


def test_cam_meets_the_seeds_pressure_angle_and_r0_over_S_with_a_roller():
    """The seed's r0/S = 0.95 and 28 deg hold together when r0 is the working profile's smallest radius vector:
    the pitch curve's base radius less the roller's.  Checked with CamRocker's own pressure angle."""
    from systems import bed_drive as bd

    arm, dist, r0 = bd.CAM_DESIGN
    d = bed_cam.CamDesign(arm, dist, r0, r0 / (arm * B.SEED_CARRIER_SWING), 0.0, 0.0)
    S = arm * B.SEED_CARRIER_SWING
    assert (r0 - d.roller_radius) / S == pytest.approx(0.95, rel=1e-12)
    assert d.roller_radius > 0.0
    th = bed_cam.max_pressure_angle(bd.CARRIER_RUNUP, dist, arm, r0, points=2881)
    assert math.degrees(th) <= 28.0 + 1e-3
    # on the pitch curve itself r0/S = 0.95 cannot reach 28 deg with these laws (best centre distance)
    best, _ = bed_cam._best_distance(bd.CARRIER_RUNUP, arm, 0.95 * S, bed_cam.SEED_RETURN)
    assert math.degrees(best) > 28.0


def test_bed_drive_is_the_seeds_mechanism():
    from harness import load
    from systems import bed_drive as bd

    system = load("bed_drive")
    fb, cam = system.instance("fourbar").parameters, system.instance("cam").parameters
    assert fb["branch"] == B.SEED_BRANCH
    assert (cam["law"], cam["law_return"]) == (8, 9)
    assert cam["cam_distance"] == pytest.approx(fb["frame_length"], rel=1e-12)   # O2O5 carries both
    an = analyse(*PUBLISHED, branch=B.SEED_BRANCH)
    assert bd.PHI_START == pytest.approx(math.radians(an.working_start_deg), abs=1e-12)


def test_equal_peak_runup_joins_the_strokes_without_a_jump_and_lengthens_the_uniform_segment_with_k():
    """The reading of 'conjugate harmonics with equal peaks' over the whole cycle: the working stroke's peak at
    the extreme position equals the harmonic return's, in the cycle's time.  Measured: with it a larger K_px
    gives a longer uniform segment (the seed says the opposite), which is why bed_drive does not use it."""
    shares = []
    for K in (0.57, 0.6025, 0.63):
        u = B.equal_peak_runup(K)
        c_work = B.bed_invariants(0.0, u, math)[2] / K ** 2                 # at the end of the idle stroke ...
        c_idle = B.bed_idle_invariants(1.0, math)[2] / (1 - K) ** 2        # ... and the start of the working one
        assert c_work == pytest.approx(-c_idle, rel=1e-9)       # the return's deceleration is a forward push
        shares.append(1 - 2 * B.bed_invariants(u, u, math)[0])
    assert shares[0] < shares[1] < shares[2]


def test_the_published_linkage_is_the_synthesis_optimum_at_its_own_swing_and_transmission_angle(capsys):
    """The seed's criterion (the largest K_px for a swing and a smallest transmission angle) picks the published
    linkage up to the flatness of K_px near its maximum: at the linkage's own swing (59.965 deg) and smallest
    transmission angle (29.354 deg, not the stated 30) no crank-rocker reaches a K_px larger by 1e-4."""
    from harness.__main__ import main

    assert main(["synth", "fourbar", "--analyse", "--coupler", "1.91579", "--frame", "2.10526", "--rocker",
                 "2.25263", "--branch", "-1", "--optimum", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    best = out["optimum"]
    assert best["swing_deg"] == pytest.approx(out["swing_deg"], abs=1e-6)
    assert best["min_transmission_deg"] == pytest.approx(out["min_transmission_deg"], abs=1e-6)
    assert out["time_ratio"] <= best["time_ratio"] + 1e-9
    assert best["time_ratio"] - out["time_ratio"] < 1e-4
    assert out["min_transmission_deg"] < 30.0 - 0.5          # the published linkage breaks the stated limit
