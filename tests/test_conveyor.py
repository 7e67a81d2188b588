"""ConveyorLoad (seed 003's second article, the non-stop trimmer's belt conveyors): the force model's own laws
written out here (the cutting work per pitch, the edge inside the cutting zone counted by hand), on the
article's grid of blocks and cut lengths."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fmus.physics import conveyor as cv

THICKNESS = (0.005, 0.010, 0.018, 0.036)                    # m (article)
CUTS = {"coated": (0.22, 0.32, 0.45), "offset": (0.21, 0.29, 0.32, 0.41)}   # m (article)


@pytest.mark.parametrize("h", THICKNESS)
@pytest.mark.parametrize("cut", sorted({c for v in CUTS.values() for c in v}))
@pytest.mark.parametrize("zone", [0.3, 0.7, 1.2])
def test_mean_force_is_the_cutting_work_per_pitch(h, cut, zone):
    """Over a pitch of travel the conveyor does the two edges' cutting work w*h*L_c each, whatever the zone."""
    p = cv.ConveyorLoadParams(thickness=h, cut_length=cut, zone=zone, F0=12.0)
    x = 3.0 + (np.arange(200_000) + 0.5) * p.pitch / 200_000            # midpoints of one pitch, blocks running
    mean = float(np.mean(cv.transport_force(x, p)))
    assert mean == pytest.approx(12.0 + 2 * p.w_cut * h * cut / p.pitch, rel=1e-6)
    assert cv.mean_force(p) == pytest.approx(mean, rel=1e-6)


def test_a_zone_of_whole_pitches_gives_a_steady_force():
    p = cv.ConveyorLoadParams(zone=1.0)                                 # two pitches of 0.5 m
    F = cv.transport_force(np.linspace(2.0, 4.0, 4001), p)
    assert np.ptp(F) < 1e-9 * F.mean()
    ripple = cv.transport_force(np.linspace(2.0, 4.0, 4001), cv.ConveyorLoadParams())   # 1.2 m: 2.4 pitches
    assert np.ptp(ripple) > 0.1 * ripple.mean()


def test_force_at_a_point_counted_by_hand():
    """Travel 0.6 m, blocks of 0.32 m at 0.5 m: block 0 spans [0.28, 0.60], block 1 [-0.22, 0.10] (0.10 inside
    the zone [0, 1.2]): 0.42 m of edge, two knives, h/zone of thickness per metre of travel."""
    p = cv.ConveyorLoadParams()
    assert float(cv.transport_force(0.6, p)) == pytest.approx(2 * p.w_cut * 0.036 / 1.2 * 0.42, rel=1e-12)
    assert float(cv.transport_force(-0.1, p)) == 0.0                     # no block yet


@pytest.mark.parametrize("cut", sorted({c for v in CUTS.values() for c in v}))
def test_blocks_in_the_zone(cut):
    """At most ceil((zone + L_c)/pitch) blocks have edge inside the zone (the window one edge sweeps).  With
    the article's 1200 mm tool cutting over its whole length that is 3 for cut lengths below 300 mm and 4
    above -- the article says no more than three are trimmed at once (docs/seed_003.md)."""
    p = cv.ConveyorLoadParams(cut_length=cut)
    _, count = cv.edge_in_zone(np.linspace(3.0, 3.5, 50_001), p.pitch, cut, p.zone)
    assert count.max() == math.ceil((p.zone + cut) / p.pitch)
    assert count.max() == (3 if cut < 0.3 else 4)


def test_model_moment_on_the_drive_shaft_and_parameter_errors():
    p = cv.ConveyorLoadParams(r_pulley=0.08, eta=0.9, x0=0.1)
    m = cv.ConveyorLoadModel(p)
    phi = 0.5 / 0.08                                                     # travel 0.1 + 0.5 = 0.6 m
    tau, F, n = m.output(0.0, (), (phi, 30.0))
    assert F == pytest.approx(float(cv.transport_force(0.6, p)), rel=1e-12)
    assert tau == pytest.approx(-F * 0.08 / 0.9, rel=1e-12) and n == 2.0   # its bad parameters: test_parameter_errors


# ------------------------------------------------------------------------------------------ the system and sweep
def test_trimmer_conveyor_moment_is_the_cutting_work_per_pitch(fmu_dir):
    """The co-simulated drive (motor, belt, compliant drive shaft, load) delivers the mean moment of the cutting
    work over whole pitches, 2 w h L_c r/(s eta), to 0.5 %; the speed stays within 5 % of the set 1.8 m/s."""
    import warnings

    from harness import load, simulate
    from harness.reporting import qoi

    s = load("trimmer_conveyor")
    s = s.on_fmus(fmu_dir)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                           # a shipped system runs without a warning
        df = simulate(s, on_error="raise")
    p = s.instance("trim").parameters
    expect = 2 * p["w_cut"] * p["thickness"] * p["cut_length"] / p["pitch"] * p["r_pulley"]
    scene = {sc.name: sc for sc in s.scenes}["mean_moment"]
    assert -qoi.evaluate(scene.quantity, df) == pytest.approx(expect, rel=5e-3)
    speed = df["drive.crank.w"].to_numpy() * p["r_pulley"]
    assert np.all(np.abs(speed / 1.8 - 1.0) < 0.05)
    assert df["trim.blocks_cut"].max() == 4.0                    # 320 mm blocks on the 1200 mm tool


def test_conveyor_grid_study_is_the_articles_grid_and_runs_a_point():
    from pathlib import Path

    from harness.studies import sweep

    spec = sweep.read_spec(Path(__file__).resolve().parents[1] / "systems" / "studies" / "conveyor_grid.yaml")
    assert spec.system == "trimmer_conveyor"
    grid = {v: sorted({pt[v] for pt in spec.points}) for v in spec.variables}
    assert grid["speed"] == [0.5, 1.0, 1.8, 2.7] and grid["thickness"] == list(THICKNESS)
    assert grid["cut"] == sorted({c for v in CUTS.values() for c in v})
    spec.run["stop_time"] = 0.3
    point = {"speed": 2.7, "thickness": 0.036, "cut": 0.45}
    row = sweep.run_point("trimmer_conveyor", spec, point)
    assert row["error"] == ""
    assert row["force_mean"] == pytest.approx(cv.mean_force(cv.ConveyorLoadParams(cut_length=0.45)), rel=0.02)
