"""The engineering quantities of a run (harness.reporting.quantities): the cycle boundaries and the start-up rule on
synthetic signals, every shipped drive's quantities against values computed here from the result columns with
plain numpy (other code than the module's: np.interp for the boundaries, sample loops, np.trapezoid), the
too-short run, the command line's table and JSON."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from harness.reporting import quantities as qm
from harness.run import load, simulate

RPM = 2 * math.pi / 60


# -- cycles and the start-up rule on synthetic signals ---------------------------------------------------------
def _synthetic(w_of_t, t_end, dt=1e-4):
    t = np.arange(0.0, t_end + dt / 2, dt)
    w = w_of_t(t)
    angle = np.concatenate(([0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * dt)))
    return t, w, angle


def test_cycle_bounds_of_a_uniform_shaft_are_the_turns():
    w = 2 * math.pi * 3.0                                  # 3 turns per second
    t, _, angle = _synthetic(lambda t: np.full_like(t, w), 2.0)
    bounds = qm.cycle_bounds(t, angle, origin=0.5)
    expected = (0.5 + 2 * math.pi * np.arange(0, 6)) / w   # the angle passes 0.5 + 2 pi k, k = 0..5
    np.testing.assert_allclose(bounds, expected, atol=1e-9)
    # a shaft turning backwards has the same cycles
    np.testing.assert_allclose(qm.cycle_bounds(t, -angle, origin=-0.5), expected, atol=1e-9)


def test_startup_detected_where_the_cycle_mean_settles():
    # a speed rising to 10 rad/s with a 0.3 s time constant, with a ripple at the cycle frequency
    w_end, tau = 10.0, 0.3
    t, w, angle = _synthetic(lambda t: w_end * (1 - 0.5 * np.exp(-t / tau)) * (1 + 0.05 * np.sin(w_end * t)), 12.0)
    c = qm.detect_cycles(t, angle, settle=1e-3)
    # independently: each cycle's mean from the speed samples, and the first cycle from which on every cycle's
    # mean is within 0.1 % of the one before
    b = np.interp(2 * math.pi * np.arange(1, int(angle[-1] / (2 * math.pi)) + 1), angle, t)
    b = np.concatenate(([0.0], b))
    means = [np.trapezoid(np.interp(np.linspace(a, e, 2001), t, w), np.linspace(a, e, 2001)) / (e - a)
             for a, e in zip(b[:-1], b[1:])]
    ok = [abs(means[k] - means[k - 1]) <= 1e-3 * means[k] for k in range(1, len(means))]
    first = next(k + 1 for k in range(len(ok)) if all(ok[k:]))
    np.testing.assert_allclose(c.means, means, rtol=1e-6)
    assert c.first_steady == first
    assert 3 <= first < len(means) - 2            # the signal was built to settle inside the run
    assert c.steady == pytest.approx((b[first], b[-1]), abs=1e-9)


def test_too_short_and_unsettled_runs_say_so():
    t, _, angle = _synthetic(lambda t: np.full_like(t, 2 * math.pi), 1.5)   # one turn per second
    c = qm.detect_cycles(t, angle)
    assert c.first_steady is None and c.steady is None
    assert "too short" in c.reason and "1 complete cycle" in c.reason and "2.05 s" in c.reason
    t, _, angle = _synthetic(lambda t: 2 * math.pi * (1 + 0.05 * t), 4.0)   # still speeding up
    c = qm.detect_cycles(t, angle)
    assert c.first_steady is None and "still changes" in c.reason


# -- every shipped drive against numpy on its result -----------------------------------------------------------
RUNS = {"bed_drive": 2.0, "feeder_gto52": 1.0, "spine_knife": 0.3, "trimmer_conveyor": 0.9,
        "proof_press": 4.0}   # s: two or more complete cycles each


@pytest.fixture(scope="module", params=[pytest.param(n, marks=pytest.mark.slow) if n == "proof_press" else n
                                        for n in RUNS])   # proof_press: 4 s of press time, 20000 steps
def run(request):
    name = request.param
    system = load(name)
    df = simulate(system, stop_time=RUNS[name], on_error="raise")
    return system, df


def _bounds(df, spec):
    """Cycle boundaries from the angle with np.interp (the angle rises monotonically in these runs)."""
    t, a = df.index.to_numpy(), df[spec.shaft_angle].to_numpy()
    assert np.all(np.diff(a) > 0)
    k = np.arange(math.ceil((a[0] - spec.cycle_origin) / spec.cycle_angle - 1e-12),
                  math.floor((a[-1] - spec.cycle_origin) / spec.cycle_angle) + 1)
    return np.interp(spec.cycle_origin + k * spec.cycle_angle, a, t)


def _rel(a, b, tol):
    assert a == pytest.approx(b, rel=tol), (a, b)


def test_quantities_of_every_drive_match_numpy(run):
    system, df = run
    spec, q = system.quantities, df.attrs["quantities"]
    t = df.index.to_numpy()
    col = lambda c: df[c].to_numpy()  # noqa: E731
    b = _bounds(df, spec)
    np.testing.assert_allclose(q.cycles.bounds, b, atol=1e-9)
    n_cycles = len(b) - 1
    means = spec.cycle_angle / np.diff(b)
    first = min(k for k in range(1, n_cycles)
                if all(abs(means[j] - means[j - 1]) <= spec.settle * means[j] for j in range(k, n_cycles)))
    assert q.cycles.first_steady == first
    ta, tb = b[first], b[-1]
    steady = (t >= ta) & (t <= tb)
    startup = t <= ta
    n = n_cycles - first

    _rel(q["shaft_speed_mean"], np.trapezoid(col(spec.shaft_speed)[steady], t[steady]) / (tb - ta) / RPM, 2e-3)
    _rel(q["machine_rate"], n / (tb - ta) * 3600, 1e-12)
    assert q["startup_time"] == pytest.approx(ta - t[0], abs=1e-12)
    deltas = []
    for k in range(first, n_cycles):
        w = col(spec.shaft_speed)[(t >= b[k]) & (t <= b[k + 1])]
        deltas.append((w.max() - w.min()) / w.mean())
    _rel(q["speed_fluctuation"], 100 * max(deltas), 2e-3)

    m = system.instance(spec.motor).parameters
    rated = m.get("P_rated", 2200.0) / m["w_rated"]   # 2200 W: MotorBelt's default (the knife's, the trimmer's)
    T, P = col(f"{spec.motor}.motor_torque"), col(f"{spec.motor}.power_electrical")
    _rel(q["motor_torque_rated"], rated, 1e-12)
    _rel(q["motor_torque_peak"], np.abs(T[steady]).max(), 1e-12)
    _rel(q["motor_torque_rms"], np.sqrt(np.mean(T[steady] ** 2)), 3e-3)
    _rel(q["motor_torque_rms_to_rated"], np.sqrt(np.mean(T[steady] ** 2)) / rated, 3e-3)
    _rel(q["motor_torque_peak_to_breakdown"], np.abs(T[steady]).max() / (rated * m.get("breakdown_ratio", 2.2)),
         1e-12)
    _rel(q["power_electrical_mean"], np.mean(P[steady]), 3e-3)
    _rel(q["power_electrical_peak"], P[steady].max(), 1e-12)
    _rel(q["energy_per_cycle"], np.trapezoid(P[steady], t[steady]) / n, 1e-9)
    # a run that starts at speed (its first sample above 1 % of the first cycle's mean) has no start-up from rest
    at_speed = abs(col(spec.shaft_speed)[0]) > 0.01 * means[0]
    if at_speed:
        assert q["motor_torque_startup_peak"] is None and "starts at speed" in q.row("motor_torque_startup_peak").note
    else:
        _rel(q["motor_torque_startup_peak"], np.abs(T[startup]).max(), 1e-12)
    for load in spec.loads:
        x = col(load.column)
        if not np.any(x):
            assert q[f"{load.name}_peak"] is None and "0 throughout" in q.row(f"{load.name}_peak").note
            continue
        _rel(q[f"{load.name}_peak"], np.abs(x[steady]).max(), 1e-12)
        _rel(q[f"{load.name}_range"], x[steady].max() - x[steady].min(), 1e-12)
        if at_speed:
            assert q[f"{load.name}_startup_peak"] is None
        else:
            _rel(q[f"{load.name}_startup_peak"], np.abs(x[startup]).max(), 1e-12)
    _check_answers(system.name, q, df, t, b, first, steady, spec)


def _check_answers(name, q, df, t, b, first, steady, spec):
    col = lambda c: df[c].to_numpy()  # noqa: E731
    last = (t >= b[-2]) & (t < b[-1])
    if name == "bed_drive":
        s, v = col("bed.bed.s"), col("bed.bed.v")
        spreads, registers = [], []
        for k in range(first, len(b) - 1):
            zone = np.flatnonzero((t >= b[k]) & (t <= b[k + 1]) & (s >= 0.08) & (s <= 0.24) & (v > 0))
            spreads.append(np.ptp(v[zone]) / np.mean(v[zone]))
            line = np.linspace(s[zone[0]], s[zone[-1]], zone.size)   # uniform motion: equal steps in time
            registers.append(np.abs(s[zone] - line).max())
        _rel(q["bed_speed_spread"], 100 * max(spreads), 2e-3)
        _rel(q["register_error"], 1e6 * max(registers), 1e-9)
        assert q["register_error"] > 1.0                   # um: a real deviation, not a zero
    elif name == "feeder_gto52":
        count, force, contact = col("feeder.impact_count"), np.abs(col("feeder.pin_force")), col("feeder.in_contact")
        rises = [i for i in range(1, len(t)) if count[i] > count[i - 1] and last[i]]
        assert len(rises) >= 2
        angles = np.degrees(np.mod(col("flywheel.crank.phi")[rises] - spec.cycle_origin, 2 * math.pi))
        np.testing.assert_allclose(q["take_up_angles"], angles, atol=1e-9)
        peaks = []
        for j, i in enumerate(rises):
            end, top = i, force[i]
            while end + 1 < len(t) and t[end + 1] < b[-1] and (j + 1 == len(rises) or end + 1 < rises[j + 1]) \
                    and contact[end + 1] != 0:
                end += 1
                top = max(top, force[end])
            peaks.append(top)
        np.testing.assert_allclose(q["impact_forces"], peaks, rtol=1e-12)
        _rel(q["head_swing"], np.degrees(np.ptp(col("feeder.rocker.phi")[steady])), 1e-12)
    elif name == "proof_press":
        printing = steady & (col("press.phase") == 2)
        _rel(q["cylinder_slip"], 1e6 * np.abs(col("press.sync_error")[printing]).max(), 1e-12)
        force = _mesh_force_from_the_cylinder(df)
        _rel(q["mesh_force_peak"], np.abs(force[steady]).max(), 1e-2)
    elif name == "spine_knife":
        cutting = steady & (col("knife.cutting") > 0)
        _rel(q["knife_shaft_twist"], 1e3 * np.abs(col("shaft.shaft_twist")[steady]).max(), 1e-12)
        _rel(q["cutting_torque_peak"], np.abs(col("knife.knife.tau")[cutting]).max(), 1e-12)
        _rel(q["cutting_torque_mean"], np.mean(col("knife.knife.tau")[cutting]), 2e-2)
    elif name == "trimmer_conveyor":
        _rel(q["trimming_moment_mean"], np.mean(col("trim.shaft.tau")[steady]), 3e-3)
        _rel(q["trimming_moment_peak"], np.abs(col("trim.shaft.tau")[steady]).max(), 1e-12)


def _mesh_force_from_the_cylinder(df):
    """The gearing's tooth force on the proof press's cylinder from other columns: the torque it applies, J_cyl
    times the cylinder's acceleration (differences of its recorded speed) minus the load's torque on it, over
    the pitch radius D_C/2 (GearSectors' parameters as the drive sets them)."""
    from fmus.physics.gear_sectors import GearSectorsParams

    p = GearSectorsParams(**load("proof_press").instance("press").parameters)
    t = df.index.to_numpy()
    torque = p.J_cyl * np.gradient(df["press.cylinder.w"].to_numpy(), t) - df["cylinder.flange.tau"].to_numpy()
    return torque / (0.5 * p.D_C)


def test_the_proof_press_mesh_force_is_the_cylinder_torque_over_its_pitch_radius():
    """press.mesh_force (GearSectors) against the torque on the cylinder from its speed and its load, over the
    pitch radius: equal to the differences' error, and its peak is what the quantities report."""
    system = load("proof_press")
    df = simulate(system, stop_time=0.4, on_error="raise")
    force, mesh = _mesh_force_from_the_cylinder(df), df["press.mesh_force"].to_numpy()
    inner = slice(5, -5)   # one-sided differences at the ends
    assert np.abs(mesh).max() > 50.0                                        # N: a real load, not a zero
    assert np.abs(force - mesh)[inner].max() < 5e-3 * np.abs(mesh).max()
    assert df.attrs["units"]["press.mesh_force"] == "N"
    assert "mesh_force_peak" in df.attrs["quantities"].names


def test_saved_result_gives_the_same_quantities(run, tmp_path):
    """compare/size call quantities() on a DataFrame: a CSV read back gives the run's table."""
    from harness.results import read_csv, to_csv

    system, df = run
    back = read_csv(to_csv(df, tmp_path / "r.csv", units=True))
    again = qm.quantities(system, back)
    for row in df.attrs["quantities"].rows:
        got = again[row.name]
        assert (got is None) == (row.value is None)
        if row.value is not None:
            np.testing.assert_allclose(got, row.value, rtol=1e-9)


def test_two_inertia_declares_none():
    df = simulate("two_inertia", stop_time=0.05, on_error="raise")
    q = df.attrs["quantities"]
    assert q.rows == () and "no engineering quantities" in q.table()


def test_a_set_parameter_reaches_the_rating():
    """The rated torque is the run's: a --set P_rated changes it (df.attrs['start_values'])."""
    df = simulate("spine_knife", stop_time=0.05, start_values={"motor.P_rated": 1100.0}, on_error="raise")
    assert df.attrs["quantities"]["motor_torque_rated"] == pytest.approx(1100.0 / (1425 * RPM), rel=1e-12)


# -- the command line -----------------------------------------------------------------------------------------
def test_run_prints_the_table_and_writes_json(tmp_path, capsys):
    from harness.__main__ import main

    out = tmp_path / "knife.csv"
    assert main(["run", "spine_knife", "--stop-time", "0.3", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    saved = json.loads((tmp_path / "knife.quantities.json").read_text())
    rows = {r["name"]: r for r in saved["quantities"]}
    assert saved["cycles"]["first_steady"] == 2 and len(saved["cycles"]["bounds_s"]) == 4
    for name in ("shaft_speed_mean", "speed_fluctuation", "motor_torque_rms", "knife_shaft_twist",
                 "cutting_torque_peak", "shaft_torque_peak"):
        line = next(x for x in text.splitlines() if x.strip().startswith(name + " "))
        assert rows[name]["unit"] in line.split()
        shown = float(line.split()[1])
        assert shown == pytest.approx(rows[name]["value"], rel=1e-3)      # 4 significant digits
    assert "start-up" in text and "within 0.1 %" in text

    assert main(["run", "spine_knife", "--stop-time", "0.3", "--out", str(out), "--quiet-quantities"]) == 0
    quiet = capsys.readouterr().out
    assert "speed_fluctuation" not in quiet and len(quiet.splitlines()) == 1
    assert (tmp_path / "knife.quantities.json").is_file()


def test_run_too_short_says_so_instead_of_a_number(tmp_path, capsys):
    from harness.__main__ import main

    assert main(["run", "spine_knife", "--stop-time", "0.15", "--out", str(tmp_path / "k.csv")]) == 0
    text = capsys.readouterr().out
    assert "run too short for a steady cycle: 1 complete cycle" in text
    assert not any(x.strip().startswith("speed_fluctuation ") for x in text.splitlines())
    saved = json.loads((tmp_path / "k.quantities.json").read_text())
    rows = {r["name"]: r for r in saved["quantities"]}
    assert rows["speed_fluctuation"]["value"] is None and "too short" in rows["speed_fluctuation"]["note"]
    assert rows["motor_torque_startup_peak"]["over"] == "whole run"
