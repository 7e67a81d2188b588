"""Seed 004's carrier law (fmus.physics.bed_law): summed with the four-bar through the James differential it
gives a bed that moves uniformly through the printing zone; the co-simulated bed drive keeps that within the
stated tolerance; the disc cam designed for it meets the seed's 28 deg pressure angle."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fmus.physics import bed_cam, bed_law as B
from fmus.physics.laws import get_law

ZONE = (0.08, 0.24)     # bed_drive's printing zone [m]


def stroke_m():
    st = B.working_stroke()
    return 0.05 * (B.SEED_RATIO * abs(st.swing) + (1 + B.SEED_RATIO) * B.SEED_CARRIER_SWING)


@pytest.mark.parametrize("u", [0.15, 0.2, 0.246])
def test_carrier_plus_fourbar_gives_the_uniform_bed_law(u):
    cl = B.carrier_law(u)
    st = B.working_stroke()
    k = np.linspace(0.0, 1.0, 4001)
    ag, bg, cg = cl.law(k)
    ad, bd, cd = st.invariants(k)
    K = cl.ratio
    for (g, d), want in zip(((ag, ad), (bg, bd), (cg, cd)), B.bed_invariants(k, u)):
        bed = (K * cl.delta_swing * d + (1 + K) * cl.gamma_swing * g) / cl.alpha_swing   # alpha5 = K delta + (1+K) gamma
        np.testing.assert_allclose(bed, want, rtol=0, atol=1e-9)
    assert ag[0] == pytest.approx(0.0, abs=1e-12) and ag[-1] == pytest.approx(1.0, abs=1e-9)
    assert np.min(bg) >= -1e-12                                   # the carrier rises monotonically
    zone = (k >= u) & (k <= 1 - u)
    bed_b = (K * cl.delta_swing * bd + (1 + K) * cl.gamma_swing * bg) / cl.alpha_swing
    assert np.ptp(bed_b[zone]) < 1e-9 * np.mean(bed_b[zone])
    # the scalar path (the FMU's inner loop) is the array path
    for x in (0.0, 0.1, u, 0.5, 1 - u, 0.93, 1.0):
        assert cl.law(x, math) == pytest.approx(tuple(float(v[0]) for v in cl.law(np.array([x]))), rel=1e-12, abs=1e-12)


def test_bed_law_closed_forms():
    u = 0.25
    a, b, c = B.bed_invariants(np.array([0.0, u, 0.5, 1 - u, 1.0]), u)
    assert a[0] == 0.0 and a[-1] == pytest.approx(1.0, abs=1e-14)
    assert b[0] == pytest.approx(0.0, abs=1e-14) and b[-1] == pytest.approx(0.0, abs=1e-14)
    assert c[0] == pytest.approx(-c[-1], rel=1e-14)                 # equal peaks, run-up and run-out
    assert c[1] == pytest.approx(0.0, abs=1e-12) and c[3] == pytest.approx(0.0, abs=1e-12)
    # mean speed over the stroke is 1: a(1) - a(0) = integral of b
    k = np.linspace(0, 1, 200001)
    assert np.trapezoid(B.bed_invariants(k, u)[1], k) == pytest.approx(1.0, rel=1e-9)


def test_runup_covers_the_printing_zone_exactly_at_its_binding_end():
    S = stroke_m()
    u = B.runup_for_zone(ZONE[0] / S, ZONE[1] / S)
    start, end = B.bed_invariants(u, u, math)[0], B.bed_invariants(1 - u, u, math)[0]
    assert start <= ZONE[0] / S + 1e-12 and end >= ZONE[1] / S - 1e-12
    assert min(ZONE[0] / S - start, end - ZONE[1] / S) == pytest.approx(0.0, abs=1e-12)


def test_a_runup_that_turns_the_carrier_back_is_refused():
    with pytest.raises(ValueError, match=r"runup = 0.4: the carrier would turn back"):
        B.carrier_law(0.4)
    with pytest.raises(ValueError, match=r"law_km"):
        get_law("bed004", k_m=0.45)


def test_invariants_of_k0_are_its_closed_forms():
    v = B.stroke_invariants(get_law("K0"))
    assert v["B"] == pytest.approx(math.pi / 2, rel=1e-8)
    assert v["C1"] == pytest.approx(math.pi ** 2 / 2, rel=1e-8) and v["C3"] == pytest.approx(math.pi ** 2 / 2, rel=1e-8)


def test_cam_geometry_meets_the_seeds_pressure_angle():
    # the geometry `synth carrier` prints for 28 deg (arm 0.1 m) with the seed's rise and return laws; the
    # pressure angle is CamRocker's own
    S = stroke_m()
    u = B.runup_for_zone(ZONE[0] / S, ZONE[1] / S)
    th = bed_cam.max_pressure_angle(u, 0.14143, 0.1, 0.08242, points=1441)
    assert math.degrees(th) <= 28.05
    # and the former geometry (centre distance 0.15 m, r0 = 0.0663 m) does not
    assert math.degrees(bed_cam.max_pressure_angle(u, 0.15, 0.1, 0.0663)) > 40.0


def test_cosimulated_bed_speed_is_uniform_in_the_printing_zone():
    """Tolerance: in the zone the bed speed over the crank speed is a constant of the rigid kinematics (b_alpha
    = V); the declared model adds the elastic four-bar coupler, cam transmission and rack mesh, and the 500 N
    printing load rises in the zone over 20 mm (bed_drive): its deflection of the mesh, 500 N / 2e7 N/m =
    25 um over 20 mm of travel, is 0.13 % of the speed, and the coupler's and transmission's
    compliance carry the carrier's and ring's accelerations.  Bound: 1 % of the ratio (the harmonic K0 law on
    the carrier varies it by 37 %)."""
    from harness import load, simulate

    system = load("bed_drive")   # the seed's carrier law is bed_drive's default
    S = stroke_m()
    u = B.runup_for_zone(ZONE[0] / S, ZONE[1] / S)
    cam = system.instance("cam").parameters
    assert (cam["law"], cam["law_return"]) == (8, 9) and cam["law_km"] == pytest.approx(u, rel=1e-12)
    df = simulate(system, stop_time=1.6, step=2e-4)
    assert df.attrs.get("complete", True)
    # the cam meets the seed's 28 deg pressure angle (to the recorded geometry's 10 digits)
    assert np.degrees(np.abs(df["cam.pressure_angle"]).max()) < 28.0 + 1e-3
    s, v, w, t = df["bed.bed.s"].values, df["bed.bed.v"].values, df["flywheel.crank.w"].values, df.index.values
    zone = (s >= ZONE[0]) & (s <= ZONE[1]) & (v > 0) & (t > 0.4)
    assert zone.sum() > 100
    ratio = v[zone] / w[zone]
    assert ratio.max() / ratio.min() - 1 < 0.01
    assert v[zone].max() / v[zone].min() - 1 < 0.02        # the crank speed itself varies by about 1 % there


def test_synth_carrier_cli(capsys):
    import json

    from harness.__main__ import main

    assert main(["synth", "carrier", "--no-cam", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["bed_b_zone_max"] - out["bed_b_zone_min"] < 1e-9
    assert out["uniform_shares"][0] <= out["zone_shares"][0] and out["uniform_shares"][1] >= out["zone_shares"][1] - 1e-12
    assert main(["synth", "carrier", "--no-cam", "--runup", "0.45"]) == 2
    assert "carrier would turn back" in capsys.readouterr().err


def test_pitch_curvature_equals_finite_differences_of_the_pitch_curve():
    from fmus.physics.cam_rocker import CamRockerModel, CamRockerParams
    from fmus.physics.laws import LAW_NAMES

    u, a, l, r0 = 0.246, 0.1463, 0.1, 0.0806
    p = CamRockerParams(mechanism=1, law=LAW_NAMES.index("bed004"), law_return=0, law_km=u, cam_distance=a,
                        follower_arm=l, cam_base_radius=r0, swing=B.SEED_CARRIER_SWING)
    m = CamRockerModel(p)
    n = 72000
    phi = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    g = np.array([m.kinematics(float(f))[0] for f in phi])
    psi = m.psi0 + g
    C = np.stack([a - l * np.cos(psi), l * np.sin(psi)])          # roller centre, fixed frame
    X = np.stack([np.cos(phi) * C[0] + np.sin(phi) * C[1], -np.sin(phi) * C[0] + np.cos(phi) * C[1]])
    h = phi[1] - phi[0]
    d1 = (np.roll(X, -1, 1) - np.roll(X, 1, 1)) / (2 * h)
    d2 = (np.roll(X, -1, 1) - 2 * X + np.roll(X, 1, 1)) / h ** 2
    k = -(d1[0] * d2[1] - d1[1] * d2[0]) / np.hypot(*d1) ** 3
    fd = 1.0 / k[int(np.argmin(np.abs(1.0 / k)))]
    assert bed_cam.pitch_curvature_min(u, a, l, r0, law_return=0) == pytest.approx(fd, rel=2e-3)
    assert abs(np.hypot(*X).min() - r0) < 1e-6            # the pitch curve touches the base circle


def test_bed_drive_cam_geometry_is_the_synthesised_one():
    """systems/bed_drive.py records bed_cam.design_cam(CARRIER_RUNUP) (9 s to compute): the synthesis gives it."""
    from systems import bed_drive as sys_bd

    d = bed_cam.design_cam(sys_bd.CARRIER_RUNUP)
    assert d.follower_arm == sys_bd.CAM_DESIGN[0]
    assert d.cam_distance == pytest.approx(sys_bd.CAM_DESIGN[1], abs=1e-9)
    assert d.base_radius == pytest.approx(sys_bd.CAM_DESIGN[2], abs=1e-9)
    # bed_drive scales it so that the cam centre to carrier pivot distance is the four-bar's frame O2O5
    scale = sys_bd.FRAME / d.cam_distance
    assert (sys_bd.CAM_ARM, sys_bd.CAM_DISTANCE, sys_bd.CAM_BASE_RADIUS) == pytest.approx(
        (scale * d.follower_arm, sys_bd.FRAME, scale * d.base_radius), rel=1e-9)
    assert np.degrees(d.pressure_max) <= 28.0 + 1e-9
