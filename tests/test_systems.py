"""The press-drive systems run end to end and give physically plausible results (issue 6, part 1).

Every expected value is recomputed here from the kinematics (fmus.physics.fourbar_synthesis.analyse, closed forms of
the seeds) or from a conservation law, never read from the code under test.  Runs are shortened (one crank
turn or less where the check allows) and shared between the tests of a system (module-scoped fixtures);
the systems' FMUs come from the session build (``fmu_dir``), not from build/fmus.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from fmus.physics import fourbar_synthesis
from harness import load, simulate
from harness.studies.energy import bond_power
from harness.model import SystemWarning

ROOT = Path(__file__).resolve().parents[1]
SYSTEMS = ("two_inertia", "feeder_gto52", "bed_drive", "spine_knife", "proof_press")



def run(name, fmu_dir, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SystemWarning)   # unconnected aux inputs (documented in the systems)
        df = simulate(load(name).on_fmus(fmu_dir), on_error="raise", **kw)
    assert df.attrs["complete"], df.attrs["error"]
    return df


def params(name: str, inst: str) -> dict:
    return load(name).instance(inst).parameters


# ------------------------------------------------------------------------------------------------ every system
@pytest.mark.parametrize("name", SYSTEMS)
def test_every_system_runs_and_stays_finite(fmu_dir, name):
    s = load(name)
    df = run(name, fmu_dir, stop_time=40 * s.experiment.step)
    assert len(df) == 41 and np.isfinite(df.to_numpy()).all()


def test_cli_runs_a_press_drive(fmu_dir, tmp_path):
    out = tmp_path / "knife.csv"
    env = dict(os.environ, PRESSDRIVE_FMU_DIR=str(fmu_dir), PYTHONPATH=str(ROOT))
    r = subprocess.run([sys.executable, "-m", "harness", "run", "spine_knife", "--stop-time", "0.005",
                        "--out", str(out)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    df = pd.read_csv(out)
    assert len(df) == 101 and df.columns[0] == "time" and "knife.knife.tau" in df.columns
    assert np.isfinite(df.to_numpy()).all()


# ------------------------------------------------------------------------------------------------ bed drive
@pytest.fixture(scope="module")
def bed(fmu_dir):
    """1.2 s at 60 rpm: one crank turn from the start of the working stroke, plus a fifth of the next."""
    return run("bed_drive", fmu_dir, stop_time=1.2,
               outputs=["flywheel.crank.phi", "flywheel.crank.w", "flywheel.pulley.phi", "flywheel.pulley.w",
                        "flywheel.aux.phi", "flywheel.aux.w", "flywheel.shaft_torque", "flywheel.shaft_twist",
                        "flywheel.kinetic_energy", "flywheel.potential_energy", "motor.pulley.tau",
                        "fourbar.crank.tau", "cam.crank.tau", "bed.bed.s", "bed.bed.v"])


def _bed_geometry():
    fb, diff, b, cam = (params("bed_drive", i) for i in ("fourbar", "diff", "bed", "cam"))
    a = fourbar_synthesis.analyse(fb["crank_length"], fb["coupler_length"], fb["frame_length"], fb["rocker_length"])
    k = diff["z_ring"] / diff["z_sun"]                        # z3/z5
    alpha = k * math.radians(a.swing_deg) + (1 + k) * cam["swing"]   # alpha_Sigma [rad] of the sun (pinion z6)
    r6 = b["module"] * b["z_pinion"] / 2
    return a, r6 * alpha


def _one_turn(df):
    phi = df["flywheel.crank.phi"].to_numpy()
    return phi, phi <= phi[0] + 2 * math.pi


def test_bed_stroke_is_pinion_radius_times_summed_swing(bed):
    _, stroke = _bed_geometry()
    s = bed["bed.bed.s"].to_numpy()[_one_turn(bed)[1]]
    assert 0.25 < stroke < 0.35                                      # ~0.297 m (system docstring)
    assert np.ptp(s) == pytest.approx(stroke, rel=2e-3)               # elastic mesh/coupler: < 0.6 mm


def test_bed_working_stroke_share_and_one_stroke_per_turn(bed):
    a, stroke = _bed_geometry()
    phi, turn = _one_turn(bed)
    s = bed["bed.bed.s"].to_numpy()
    s1, phi1 = s[turn], phi[turn]
    # starts at the rear extreme; the forward (working) stroke ends where the four-bar's working stroke does
    assert s1[0] == pytest.approx(s1.min(), abs=1e-3 * stroke)
    share = (phi1[np.argmax(s1)] - phi1[0]) / (2 * math.pi)
    assert share == pytest.approx(a.time_ratio, abs=0.01)          # K_px of the four-bar (~0.60)
    # exactly one forward and one return stroke per turn: s rises, then falls (1 mm steps ignore vibration)
    imax = int(np.argmax(s1))
    coarse_up, coarse_down = s1[:imax + 1:100], s1[imax::100]
    assert np.all(np.diff(coarse_up) > -1e-3) and np.all(np.diff(coarse_down) < 1e-3)
    # synchronous with the crank: the next turn repeats the bed position at the same crank angle
    nxt = phi > phi[0] + 2 * math.pi
    again = np.interp(phi[nxt] - 2 * math.pi, phi1, s1)
    assert np.max(np.abs(s[nxt] - again)) < 5e-3 * stroke


# ------------------------------------------------------------------------------------------------ feeder
@pytest.fixture(scope="module")
def feeder(fmu_dir):
    """0.5 s at 150 rpm: the start plus one full crank turn (0.4 s) of the clearance model."""
    return run("feeder_gto52", fmu_dir, stop_time=0.5,
               outputs=["flywheel.crank.phi", "flywheel.crank.w", "feeder.rocker.phi", "feeder.impact_count"])


def test_feeder_rocker_swing_is_the_kinematic_swing(feeder):
    p = params("feeder_gto52", "feeder")
    l1, l2, l3 = p["lambda1"], p["lambda2"], p["lambda3"]
    # the kulisa law takes the swing and extremes of the base four-bar (crank 1, conrod lambda2, frame lambda1,
    # rocker lambda3; fmus/physics/cam_rocker.py).  NOTE: groove.py's docstring says the CENTRIC base four-bar
    # (swing 2 asin(1/lambda3) = 38.9 deg) but groove.base_design uses lambda2 itself (46.2 deg): the code is
    # what runs, so that is the kinematic swing checked here (reported as a docstring inconsistency).
    closed = math.radians(fourbar_synthesis.analyse(1.0, l2, l1, l3).swing_deg)
    phi = feeder["flywheel.crank.phi"].to_numpy()
    turn = phi >= phi[-1] - 2 * math.pi                              # the last full crank turn
    swing = np.ptp(feeder["feeder.rocker.phi"].to_numpy()[turn])
    assert swing == pytest.approx(closed, rel=2e-3)                  # elastic + 10 um play: ~2e-5 here
    assert feeder["feeder.impact_count"].iloc[-1] >= 1               # the stone pin does hit its clearance


def _longest_still_run(crank: np.ndarray, w: np.ndarray, rel: float) -> tuple[float, np.ndarray]:
    """Longest run of consecutive samples with |w| <= rel * max|w|: (its crank-angle span, its mask)."""
    still = np.abs(w) <= rel * np.max(np.abs(w))
    best, best_mask, first = 0.0, np.zeros_like(still), None
    for k in range(len(still) + 1):
        if k < len(still) and still[k]:
            first = k if first is None else first
        elif first is not None:
            if crank[k - 1] - crank[first] > best:
                best = crank[k - 1] - crank[first]
                best_mask = np.zeros_like(still)
                best_mask[first:k] = True
            first = None
    return best, best_mask


def test_feeder_head_dwells_at_the_feed_table(fmu_dir, feeder):
    """Seed 000/001: the correcting groove gives the head a dwell at the feed table.  The system asks for
    ``feeder.dwell`` (30 deg); the rigid mechanism must stand still over exactly that crank angle, and the full
    model (elastic, 10 um clearance) must hold the rocker within a small fraction of its swing there."""
    dwell = params("feeder_gto52", "feeder")["dwell"]
    assert dwell > 0.0
    df = run("feeder_gto52", fmu_dir, stop_time=0.45, step=2e-4, parameters={"feeder.fidelity": 0},
             outputs=["flywheel.crank.phi", "feeder.rocker.phi", "feeder.rocker.w"])
    phi = df["flywheel.crank.phi"].to_numpy()
    turn = phi >= phi[-1] - 2 * math.pi
    best, _ = _longest_still_run(phi[turn], df["feeder.rocker.w"].to_numpy()[turn], 1e-9)
    assert best == pytest.approx(dwell, abs=2 * np.max(np.diff(phi[turn])))
    # the full model over the same crank angles (mod 2 pi) of its last turn
    full_phi = feeder["flywheel.crank.phi"].to_numpy()
    last = full_phi >= full_phi[-1] - 2 * math.pi
    rocker = feeder["feeder.rocker.phi"].to_numpy()[last]
    _, mask = _longest_still_run(phi[turn], df["feeder.rocker.w"].to_numpy()[turn], 1e-9)
    a0, a1 = np.mod(phi[turn][mask][[0, -1]], 2 * math.pi)
    ang = np.mod(full_phi[last], 2 * math.pi)
    inside = (ang >= a0) & (ang <= a1) if a0 <= a1 else (ang >= a0) | (ang <= a1)
    assert inside.sum() > 10
    assert np.ptp(rocker[inside]) < 0.01 * np.ptp(rocker)


# ------------------------------------------------------------------------------------------------ knife drive
@pytest.fixture(scope="module")
def knife(fmu_dir):
    """0.42 s at 600 rpm: four crank turns and a bit."""
    return run("spine_knife", fmu_dir, stop_time=0.42,
               outputs=["shaft.crank.phi", "shaft.crank.w", "shaft.pulley.phi", "shaft.pulley.w",
                        "shaft.aux.phi", "shaft.aux.w", "shaft.shaft_torque", "shaft.shaft_twist",
                        "shaft.kinetic_energy", "shaft.potential_energy", "motor.pulley.tau",
                        "linkage.crank.tau", "knife.knife.tau", "knife.cutting"])


def test_knife_torque_repeats_once_per_crank_turn(knife):
    from fmus.physics.knife import KnifeLoadParams

    kp = KnifeLoadParams(**params("spine_knife", "knife"))
    t_entry = kp.B / (kp.V_B * math.tan(kp.beta))        # seed 003 eq. (3): the entry ramp (~0.16 s)
    phi = knife["shaft.crank.phi"].to_numpy() - knife["shaft.crank.phi"].iloc[0]
    tau = knife["knife.knife.tau"].to_numpy()
    cutting = knife["knife.cutting"].to_numpy() > 0.5
    turns = int(phi[-1] // (2 * math.pi))
    per_turn = []
    for n in range(turns):
        m = (phi >= 2 * math.pi * n) & (phi < 2 * math.pi * (n + 1))
        cut = m & cutting
        onsets = np.flatnonzero(cut[1:] & ~cut[:-1]) + 1
        assert len(onsets) == 1, f"turn {n}: {len(onsets)} plunges"          # one plunge per turn ...
        per_turn.append((phi[onsets[0]] - 2 * math.pi * n, tau[m].min(), np.trapezoid(tau[m], phi[m])))
    starts, peaks, work = map(np.array, zip(*per_turn))
    assert np.ptp(starts) < 0.01                                           # ... at the same crank angle
    stable = [n for n in range(turns) if knife.index[np.searchsorted(phi, 2 * math.pi * n)] > t_entry]
    assert len(stable) >= 2, stable
    a, b = stable[0], stable[1]                  # after the entry ramp the torque repeats turn by turn
    assert peaks[b] == pytest.approx(peaks[a], rel=1e-3) and work[b] == pytest.approx(work[a], rel=1e-3)
    assert abs(peaks[0]) < 0.5 * abs(peaks[a])                             # the ramp: the first cut is lighter
    assert np.all(tau[~cutting] == 0.0) and np.all(tau[cutting] <= 0.0)   # a load: reaction against the drive


# ------------------------------------------------------------------------------------------------ proof press
@pytest.fixture(scope="module")
def proof(fmu_dir):
    """1.1 s at 30 rpm: half a turn, bed from the outer dead centre to the other one, printing phase inside."""
    return run("proof_press", fmu_dir, stop_time=1.1,
               outputs=["flywheel.crank.phi", "press.bed.s", "press.sync_error", "press.phase"])


def test_proof_press_bed_stroke_and_sync_error_while_printing(proof):
    from fmus.physics.gear_sectors import GearSectorsParams

    gs = GearSectorsParams()
    stroke = 2 * gs.r_K * gs.i_CK        # centric slider-crank with skat: S_T goes 0 -> 2 over half a turn
    assert np.ptp(proof["press.bed.s"]) == pytest.approx(stroke, rel=1e-6)
    printing = proof["press.phase"].to_numpy() == 2
    phi = proof["flywheel.crank.phi"].to_numpy()
    assert printing.any()
    assert phi[printing].min() == pytest.approx(gs.phi2, abs=0.01) and phi[printing].max() == pytest.approx(gs.phi3, abs=0.01)
    err = np.abs(proof["press.sync_error"].to_numpy())
    assert np.all(err[~printing] == 0.0)
    assert 0.0 < err[printing].max() < 1e-3 * stroke        # ~1.4e-5 m against a 0.4 m stroke


# ------------------------------------------------------------------------------------------------ energy balance
def _shaft_energy_balance(df, inst: str, bonds: list, p: dict):
    """Work done on a FlywheelShaft through its bonds vs its energy change plus shaft dissipation [J].

    The work is exact in a co-simulation: each side holds the other's torque over a step and its angle is
    the exact integral of its speed, so W = sum tau_held * dphi (harness.studies.energy.bond_power's P_out).  The
    dissipation b * int(dq/dt)^2 dt uses dq/dt = (T - c q)/b from the outputs shaft_torque T and shaft_twist
    q at the communication points (trapezoidal rule), with c and b recomputed from the parameters."""
    H = np.diff(df.index.to_numpy(dtype=float))
    work = sum(np.nansum(bond_power(df, b)["P_out"].to_numpy()[1:] * H) for b in bonds)
    gross = sum(np.nansum(np.abs(bond_power(df, b)["P_out"].to_numpy()[1:]) * H) for b in bonds)
    c = p["G"] * math.pi * p["d"] ** 4 / (32 * p["l"])
    j1, j2 = p["J_flywheel"], p["J_crank"] + p.get("J_flywheel2", 0.0)
    b = p["psi"] * math.sqrt(c * j1 * j2 / (j1 + j2)) / (2 * math.pi)
    qd = (df[f"{inst}.shaft_torque"] - c * df[f"{inst}.shaft_twist"]).to_numpy() / b
    dissipated = np.sum(0.5 * (qd[1:] ** 2 + qd[:-1] ** 2) * H) * b
    energy = (df[f"{inst}.kinetic_energy"] + df[f"{inst}.potential_energy"]).to_numpy()
    return work, energy[-1] - energy[0], dissipated, gross


@pytest.mark.parametrize("name,inst,bonds", [   # spine_knife's ParallelShafts: tests/test_parallel_shafts.py
    ("bed_drive", "flywheel", [("flywheel.pulley", "motor.pulley"), ("flywheel.crank", "fourbar.crank"),
                               ("flywheel.aux", "cam.crank")]),
])
def test_flywheel_shaft_energy_balance_closes(request, name, inst, bonds):
    df = request.getfixturevalue("knife" if name == "spine_knife" else "bed")
    df.attrs.setdefault("master", "jacobi")
    work, d_energy, dissipated, gross = _shaft_energy_balance(df, inst, bonds, params(name, inst))
    assert dissipated > 0.0
    # closes to 1e-3 of the work that crossed the bonds (trapezoidal dissipation at >= 20 points per
    # torsional period is the only approximation)
    assert abs(work - d_energy - dissipated) < 1e-3 * gross, (work, d_energy, dissipated, gross)


def test_on_fmus_takes_catalog_models_from_a_folder_and_keeps_named_files(tmp_path):
    from harness.model import Instance, System

    s = System("pair", [Instance("a", "Inertia", {"J": 2.0}), Instance("b", "/elsewhere/Own.fmu")])
    moved = s.on_fmus(tmp_path)
    assert [i.fmu for i in moved.instances] == [tmp_path / "Inertia.fmu", "/elsewhere/Own.fmu"]
    assert moved.instances[0].parameters == {"J": 2.0} and moved.instances[0].parameters is not s.instances[0].parameters
    assert [i.fmu for i in s.instances] == ["Inertia", "/elsewhere/Own.fmu"]   # the original is left as it was
