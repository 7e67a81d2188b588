"""The quantities of a stop (an emergency stop, ``kind: stop``), measured so that none depends on how long the
run was asked to be: :func:`harness.run.simulate_scenario` runs a stop until the drive has settled
(:mod:`harness.run.settling`), and every quantity here is taken from the command to the first standstill or to
settled, never to the run's end.

With w_e the main shaft's speed at the stop command t_e (the scenario's first change) and the band
``BAND`` * |w_e| (1 %):

* ``stopping_time`` [s]: from t_e to the *first standstill*, the first instant |w| reaches the band (linear
  interpolation between samples); ``stopping_angle`` [deg]: the main-shaft angle turned in that time (the
  press-engineering convention: measured to the first standstill of the main shaft);
* ``settle_time`` [s]: from t_e to the instant after which |w| stays inside the band, seen for ``hold`` s
  (0.25) after it; ``settle_angle`` [deg]: the net main-shaft angle from t_e to then; ``ring_down_peak``
  [rpm]: the largest |w| between the first standstill and settled (a belt or shaft ringing after the stop,
  reported apart);
* ``brake_energy`` [J]: for each brake (the motor's rotor brake, a clutch-brake on the main shaft), the energy
  it dissipates from t_e to settled, -integral of T_brake * w over its own shaft (trapezoidal); ``_<brake>``
  per brake where there are several;
* ``overrun``: how far the tool (the scenario's ``watch`` column) moves past the range it swept in the last
  complete cycle before the command, only for a tool that dwells or reverses within a cycle (a bed, a
  rocker); a tool that turns through whole revolutions has no such range, so no overrun;
* the peak loads of the stop, ``<load>_peak`` [their unit]: the largest |value| from t_e to settled; each
  declared belt's ``<load>_slip_margin`` in the stop: its transmittable torque over that peak (< 1: it slips).
"""
from __future__ import annotations

import math

import numpy as np

BAND = 0.01       # the share of the speed at the command inside which the main shaft counts as at rest
HOLD = 0.25       # s: how long it stays inside before the drive counts as settled (harness.run.settling.HOLD)


def first_inside(t: np.ndarray, speed: np.ndarray, start: int, band: float) -> float | None:
    """The first instant at or after sample ``start`` at which |speed| reaches ``band`` (linear interpolation
    of |speed| between the samples around it); None when it never does."""
    a = np.abs(speed[start:])
    inside = np.flatnonzero(a <= band)
    if inside.size == 0:
        return None
    k = start + int(inside[0])
    if k == start or k == 0:
        return float(t[k])
    w0, w1 = abs(speed[k - 1]), abs(speed[k])
    return float(t[k - 1] + (w0 - band) / (w0 - w1) * (t[k] - t[k - 1]))


def settled_at(t: np.ndarray, speed: np.ndarray, start: int, band: float, hold: float = HOLD) -> float | None:
    """The instant after which |speed| stays inside ``band`` to the end of the samples, provided they go on
    ``hold`` s past it (else None: not seen to settle)."""
    outside = np.flatnonzero(np.abs(speed[start:]) > band)
    k = start + (int(outside[-1]) + 1 if outside.size else 0)
    if k >= t.size:
        return None
    at = float(t[k])
    return at if t[-1] - at >= hold - 1e-12 else None


def reverses(x: np.ndarray) -> bool:
    """Whether a position dwells or reverses within the samples (not strictly monotonic): a bed or a rocker,
    not a crank turning through whole revolutions."""
    d = np.diff(np.asarray(x, dtype=float))
    if d.size == 0:
        return False
    scale = float(np.max(np.abs(d))) or 1.0
    moving = d[np.abs(d) > 1e-9 * scale]
    return moving.size < d.size or bool(np.any(moving > 0) and np.any(moving < 0))


def brake_energy(t: np.ndarray, torque: np.ndarray, speed: np.ndarray, on: np.ndarray) -> float:
    """-integral of torque * speed dt over the samples where ``on`` holds (trapezoidal): the energy a brake
    whose torque opposes its shaft's speed dissipates [J]."""
    p = -np.asarray(torque, dtype=float) * np.asarray(speed, dtype=float)
    tt, pp = t[on], p[on]
    return float(np.sum(0.5 * (pp[1:] + pp[:-1]) * np.diff(tt))) if tt.size > 1 else 0.0


def brakes(spec, df) -> list[tuple[str, str, str, str]]:
    """(name, torque column, speed column, what) of each brake the result carries: the drive's declared
    ``QuantitySpec.brakes``, else its motor's rotor brake."""
    declared = list(getattr(spec, "brakes", ()) or ())
    if not declared and spec.motor is not None:
        declared = [("motor", f"{spec.motor}.brake_torque", f"{spec.motor}.motor_speed", "the motor's rotor brake")]
    return [b for b in declared if b[1] in df.columns and b[2] in df.columns]


def stop_rows(system, scenario, df, spec, cycles, t_e: float, row, loads) -> None:
    """The stop's rows (module docstring), added through ``row(name, value, unit, what, note)``; ``loads(a, b)``
    adds the peak loads over [a, b]."""
    t = df.index.to_numpy(dtype=float)
    w = df[spec.shaft_speed].to_numpy(dtype=float)
    angle = df[spec.shaft_angle].to_numpy(dtype=float)
    hold = scenario.settle_hold if scenario.settle_hold is not None else HOLD
    w_e = float(np.interp(t_e, t, w))
    band = BAND * abs(w_e)
    start = int(np.searchsorted(t, t_e, side="left"))
    row("speed_at_command", w_e / (2 * math.pi / 60), "rpm", "main-shaft speed at the stop command")
    if w_e == 0.0 or start >= t.size:
        row("stopping_time", None, "s", "time to the first standstill", "the main shaft is at rest at the command")
        return
    rest = f"|w| <= {100 * BAND:g} % of its speed at the command ({band / (2 * math.pi / 60):.3g} rpm)"
    t_s = first_inside(t, w, start, band)
    if t_s is None:
        row("stopping_time", None, "s", f"from the command to the first standstill ({rest})",
            f"the main shaft does not come to rest within the run (to t = {t[-1]:.4g} s)")
    else:
        row("stopping_time", t_s - t_e, "s", f"from the command to the first standstill of the main shaft ({rest})")
        row("stopping_angle", math.degrees(abs(np.interp(t_s, t, angle) - np.interp(t_e, t, angle))), "deg",
            "main-shaft angle turned from the command to the first standstill")
    t_set = settled_at(t, w, start, band, hold) if t_s is not None else None
    why = (f"not settled within the run (to t = {t[-1]:.4g} s): settled needs the speed inside the band for "
           f"{hold:g} s")
    what_set = f"from the command until the main shaft stays at rest ({rest}, seen for {hold:g} s)"
    row("settle_time", None if t_set is None else t_set - t_e, "s", what_set, "" if t_set is not None else why)
    if t_set is not None:
        row("settle_angle", math.degrees(abs(np.interp(t_set, t, angle) - np.interp(t_e, t, angle))), "deg",
            "net main-shaft angle from the command to settled")
        after = (t >= t_s) & (t <= t_set)
        row("ring_down_peak", float(np.max(np.abs(w[after]))) / (2 * math.pi / 60) if after.any() else 0.0, "rpm",
            "largest |main-shaft speed| between the first standstill and settled (ringing after the stop)")
    end = t_set if t_set is not None else float(t[-1])
    on = (t >= t_e) & (t <= end)
    found = brakes(spec, df)
    for name, torque, speed, what in found:
        suffix = "" if len(found) == 1 else f"_{name}"
        row(f"brake_energy{suffix}", brake_energy(t, df[torque].to_numpy(), df[speed].to_numpy(), on), "J",
            f"energy {what} dissipates from the command to " + ("settled" if t_set is not None else "the run's end"),
            "" if t_set is not None else why)
    if scenario.watch is not None:
        _overrun(df, scenario.watch, cycles, t, t_e, end, row)
    loads(t_e, end)
    belt_rows(system, spec, df, on, row)


def belt_rows(system, spec, df, on, row, during: str = "in the stop") -> None:
    """Each declared belt's slip margin ``during`` the samples where ``on`` holds (a stop from the command to
    settled, a jam): its transmittable torque (Euler-Eytelwein, :func:`harness.reporting.fatigue.belt_capacity`)
    over its peak torque there."""
    from harness.reporting.fatigue import belt_capacity
    from harness.reporting.quantities import parameter

    for belt in getattr(spec, "belts", ()):
        load = next((ld for ld in spec.loads if ld.name == belt.load), None)
        if load is None or load.column not in df.columns or not on.any():
            continue
        inst, _, name = belt.diameter.partition(".")
        capacity = belt_capacity(belt.tight_force, belt.mu, math.radians(belt.wrap),
                                 0.5 * float(parameter(system, df, inst, name)), math.radians(belt.groove))
        peak = float(np.max(np.abs(df[load.column].to_numpy(dtype=float)[on])))
        row(f"{load.name}_slip_margin", capacity / peak if peak > 0 else None, "1",
            f"transmittable torque ({capacity:.4g} N.m) / peak belt torque {during}: < 1 the belt slips")


def _overrun(df, watch: str, cycles, t, t_e: float, end: float, row) -> None:
    x = df[watch].to_numpy(dtype=float)
    unit = df.attrs.get("units", {}).get(watch, "")
    what = f"how far {watch} moves past the range it swept in the last complete cycle before the command"
    done = np.flatnonzero(cycles.bounds[1:] <= t_e)
    if not done.size:
        row("overrun", None, unit, what, "no complete cycle before the stop")
        return
    k = int(done[-1])
    prior = (t >= cycles.bounds[k]) & (t <= cycles.bounds[k + 1])
    if not reverses(x[prior]):
        row("overrun", None, unit, what, f"{watch} turns on through every cycle (no dwell or reversal): it has "
                                         f"no swept range to overrun")
        return
    later = (t >= t_e) & (t <= end)
    row("overrun", max(0.0, x[later].max() - x[prior].max(), x[prior].min() - x[later].min()), unit, what)


OVERLOAD = 0.8    # the overload margin: a motor's peak torque stays below this share of its breakdown torque


def overload_rows(system, motor: str, df, on, row, after: str = "after the step") -> None:
    """A load step's (a jam's) verdict on the motor over the samples where ``on`` holds: its peak torque over its
    breakdown torque against the margin :data:`OVERLOAD`, and its largest slip against its breakdown slip s_k
    (past it the motor is pulled out: it stalls), each named in its meaning."""
    from fmus.physics.motor_belt import MotorBeltModel, MotorBeltParams
    from harness.reporting.quantities import parameter

    torque, speed = f"{motor}.motor_torque", f"{motor}.motor_speed"
    if torque not in df.columns or speed not in df.columns or not on.any():
        return
    values = {s.name: parameter(system, df, motor, s.name) for s in MotorBeltParams.specs()}
    model = MotorBeltModel(MotorBeltParams.from_mapping({k: v for k, v in values.items() if v is not None}))
    ratio = float(np.max(np.abs(df[torque].to_numpy(dtype=float)[on]))) / model.M_k
    word = "OVERLOAD" if ratio > OVERLOAD else "within the margin"
    row("motor_torque_peak_to_breakdown", ratio, "1",
        f"{word}: peak motor torque {after} over its breakdown torque ({model.M_k:.4g} N.m; margin "
        f"{OVERLOAD:g})")
    slip = 1.0 - float(np.min(df[speed].to_numpy(dtype=float)[on])) / model.p.w_sync
    pulled = "PULLED OUT (the motor stalls)" if slip > model.s_k else "on the stable branch"
    row("motor_slip_peak", 100.0 * slip, "%", f"{pulled}: largest slip {after}, against the breakdown slip "
        f"s_k = {100.0 * model.s_k:.3g} %")
