"""The quantities of a jam (``kind: jam``): the drive's tool runs into an end stop and the drive is blocked, or
rebounds (:class:`fmus.physics.contact.EndStop`, a component's stop that the scenario sets: an instance's
``stop_stiffness`` above 0 in its parameters or its changes).  Like a stop's (:mod:`harness.run.settling`), a
jam's run goes on past its stop time until the main shaft has settled at rest, so no quantity depends on how long
the run was asked to be.

The stop's load is not an output of the FMU (a default run's columns stay those without a stop): it is the
component's own law (:meth:`~fmus.physics.contact.EndStop.stop_load`) at the recorded coordinate and rate it
names (``stop_signals``), with the catch's memory from the coordinate's history.  With t_j the instant the tool
reaches the stop (after the stop was set; linear interpolation) and w_j the main shaft's speed just before:

* ``jam_time`` [s], ``speed_at_jam`` [rpm] (at the last point before it);
* ``time_to_block`` [s]: from t_j to the main shaft's first standstill (|w| <= 1 % of its speed when the stop
  was set, the band of the run's own watch, or its first zero: :func:`first_standstill`); ``blocked_time``
  [s]: from t_j until it stays there (seen for the hold, 0.25 s), the drive blocked; None with the reason where
  the run does not get there (a tool that rebounds off an end stop that cannot pull; a drive that keeps swinging
  against the held tool), and then ``speed_swing_at_end`` [rpm], the largest |w| over the run's last hold;
* ``stop_force_peak`` (``stop_torque_peak`` on a rotation): the largest load of the stop on the tool from t_j on;
  ``stop_force_held``: the stop's load on the blocked drive (its mean over the hold after blocked, Hann-weighted:
  :func:`held_mean`), and ``motor_torque_held``, the motor's then (its stall torque, which the drive's torque
  chain hands to the stop);
* ``speed_drop`` and the motor's verdicts (:func:`harness.reporting.stops.overload_rows`: OVERLOAD, PULLED OUT)
  from t_j on; the peak loads of the drive ``<load>_peak`` from t_j to blocked (to the run's end if never).
"""
from __future__ import annotations

import importlib
import math

import numpy as np

from harness.reporting.stops import BAND, HOLD, belt_rows, first_inside, overload_rows, settled_at

RPM = 2 * math.pi / 60


def stops_set(system, scenario) -> list[tuple[str, float, float]]:
    """(instance, stiffness, time it is set) of each end stop the scenario sets: a change of an instance's
    ``stop_stiffness`` to a value above 0 (its first), else a parameter of it above 0 (set from the start)."""
    out = {}
    for c in sorted(scenario.changes, key=lambda c: c.time):
        inst, _, name = c.variable.partition(".")
        if name == "stop_stiffness" and c.value > 0.0 and inst not in out:
            out[inst] = (inst, float(c.value), float(c.time))
    for ref, value in scenario.parameters:
        inst, _, name = ref.partition(".")
        if name == "stop_stiffness" and float(value) > 0.0 and inst not in out:
            out[inst] = (inst, float(value), 0.0)
    return list(out.values())


def stop_model(system, scenario, df, instance: str, stiffness: float):
    """The instance's model (:mod:`fmus.physics`) with the run's parameters (its start values, else the
    scenario's, else the drive's; a result without start values, e.g. the monolithic reference's, takes the
    scenario's) and the stop's ``stiffness``."""
    from fmus.build import catalog
    from harness.model import model_name
    from harness.reporting.quantities import parameter

    name = model_name(system.instance(instance).fmu)
    cls = getattr(importlib.import_module(f"fmus.components.{catalog()[name].stem}"), name).model
    values = {s.name: parameter(system, df, instance, s.name) for s in cls.Params.specs()}
    given = df.attrs.get("start_values") or {}
    for ref, value in scenario.parameters:
        inst, _, name = ref.partition(".")
        if inst == instance and ref not in given and name in values:
            values[name] = value
    values["stop_stiffness"] = stiffness
    return cls(cls.Params.from_mapping({k: v for k, v in values.items() if v is not None}))


def stop_series(model, df, instance: str, t: np.ndarray, t_set: float) -> tuple[np.ndarray, np.ndarray] | None:
    """(penetration, load on the tool) at every sample from the component's law, the catch's memory from the
    coordinate's history (reached at or after ``t_set``); None when the result lacks the coordinate."""
    q_col, v_col = (f"{instance}.{name}" for name in model.stop_signals)
    if q_col not in df.columns or v_col not in df.columns:
        return None
    q, v = df[q_col].to_numpy(dtype=float), df[v_col].to_numpy(dtype=float)
    pen = np.array([model.stop_penetration(x) for x in q])
    caught = np.maximum.accumulate((pen > 0.0) & (t >= t_set)) if model.p.stop_catch else np.zeros(t.size, bool)
    load = np.array([model.stop_load(a, b, float(c)) if k >= t_set else 0.0 for a, b, c, k in zip(q, v, caught, t)])
    return pen, load


def first_standstill(t: np.ndarray, w: np.ndarray, start: int, band: float) -> float | None:
    """The first instant at or after sample ``start`` at which the speed is at rest: |w| reaches ``band``
    (:func:`harness.reporting.stops.first_inside`) or w changes sign between two samples (the zero crossing,
    linear interpolation), whichever comes first: a tool stopped dead rings on its stop faster than the samples,
    so its speed may cross zero between two points outside the band."""
    inside = first_inside(t, w, start, band)
    flips = np.flatnonzero(np.sign(w[start + 1:]) * np.sign(w[start:-1]) < 0)
    if not flips.size:
        return inside
    k = start + int(flips[0])
    crossing = float(t[k] + w[k] / (w[k] - w[k + 1]) * (t[k + 1] - t[k]))
    return crossing if inside is None else min(inside, crossing)


def held_mean(x: np.ndarray) -> float:
    """The mean of a load on a blocked drive that may still ring: weighted by a Hann window, so that a ringing
    that has not died out averages out (a plain mean keeps up to its amplitude over the number of periods)."""
    return float(np.average(x, weights=np.hanning(x.size))) if x.size > 2 else float(np.mean(x))


def jam_rows(system, scenario, df, spec, row, loads) -> None:
    """The jam's rows (module docstring), added through ``row(name, value, unit, what, note)``; ``loads(a, b)``
    adds the peak loads over [a, b]."""
    t = df.index.to_numpy(dtype=float)
    found = stops_set(system, scenario)
    if not found:
        row("jam_time", None, "s", "instant the tool reaches the stop", "the scenario sets no end stop (an "
            "instance's stop_stiffness above 0 in its parameters or changes)")
        return
    instance, stiffness, t_set = found[0]
    model = stop_model(system, scenario, df, instance, stiffness)
    series = stop_series(model, df, instance, t, t_set)
    if series is None:
        row("jam_time", None, "s", "instant the tool reaches the stop", f"the result lacks {instance}'s "
            f"{' and '.join(model.stop_signals)}")
        return
    pen, load = series
    q_name = f"{instance}.{model.stop_signals[0]}"
    q_unit = next(s.unit for s in type(model.p).specs() if s.name == "stop_position")
    rotation = q_unit == "rad"
    where = f"{q_name} at {model.p.stop_position:.6g} {q_unit}".rstrip()
    k_set = int(np.searchsorted(t, t_set, side="left"))
    if k_set < t.size and pen[k_set] > 0.0:
        row("jam_time", None, "s", f"instant the tool reaches the stop ({where})", f"the stop was set inside the "
            f"tool's path ({q_name} {pen[k_set]:.4g} {q_unit} past it at t = {t_set:g} s): set it while the tool "
            f"is short of it")
        return
    past = np.flatnonzero(pen[k_set:] > 0.0)
    if not past.size:
        row("jam_time", None, "s", f"instant the tool reaches the stop ({where})",
            f"the tool does not reach the stop within the run (to t = {t[-1]:.4g} s)")
        return
    k = k_set + int(past[0])
    t_j = float(t[k]) if k == 0 else float(t[k - 1] + (0.0 - pen[k - 1]) / (pen[k] - pen[k - 1]) * (t[k] - t[k - 1]))
    w = df[spec.shaft_speed].to_numpy(dtype=float)
    w_j, w_set = float(w[max(k - 1, 0)]), float(np.interp(t_set, t, w))
    row("jam_time", t_j, "s", f"instant the tool reaches the stop ({where}, set at t = {t_set:g} s)")
    row("speed_at_jam", w_j / RPM, "rpm", "main-shaft speed at the last point before the tool reaches the stop")
    band = BAND * abs(w_set)     # as the run's own watch (harness.run.settling): the speed when the stop was set
    rest = f"|w| <= {100 * BAND:g} % of its speed when the stop was set ({band / RPM:.3g} rpm)"
    hold = scenario.settle_hold if scenario.settle_hold is not None else HOLD
    t_s = first_standstill(t, w, k, band) if band else None
    row("time_to_block", None if t_s is None else max(t_s - t_j, 0.0), "s",
        f"from the jam to the main shaft's first standstill ({rest}, or its speed's first zero)",
        "" if t_s is not None else f"the main shaft does not come to rest within the run (to t = {t[-1]:.4g} s)")
    t_b = settled_at(t, w, k, band, hold) if t_s is not None else None
    why = ("" if t_b is not None else
           f"not blocked within the run (to t = {t[-1]:.4g} s): the main shaft does not stay at rest for {hold:g} s "
           + ("(the tool rebounds off the end stop, which cannot pull: a catch, stop_catch = 1, holds it)"
              if not model.p.stop_catch else "(the drive still swings against the held tool)"))
    row("blocked_time", None if t_b is None else t_b - t_j, "s",
        f"from the jam until the main shaft stays at rest ({rest}, seen for {hold:g} s): the drive blocked", why)
    if t_b is None and t[-1] - t_j >= hold:
        end = t >= t[-1] - hold
        row("speed_swing_at_end", float(np.max(np.abs(w[end]))) / RPM, "rpm",
            f"largest |main-shaft speed| over the run's last {hold:g} s: the drive has not come to rest")
    force, unit = ("stop_torque", "N.m") if rotation else ("stop_force", "N")
    after = t >= t_j
    row(f"{force}_peak", float(np.max(np.abs(load[after]))), unit,
        f"largest load of the stop on the tool in the jam (k_s = {stiffness:.4g} {unit}/{q_unit}, "
        f"d_s = {model.p.stop_damping:.4g} {unit}.s/{q_unit})")
    if t_b is not None:
        held = (t >= t_b) & (t <= t_b + hold)
        row(f"{force}_held", abs(held_mean(load[held])), unit,
            f"load of the stop on the blocked drive (its Hann-weighted mean over the {hold:g} s after blocked): the "
            f"motor's stall torque through the drive's torque chain")
        if spec.motor is not None and f"{spec.motor}.motor_torque" in df.columns:
            row("motor_torque_held", held_mean(df[f"{spec.motor}.motor_torque"].to_numpy(dtype=float)[held]), "N.m",
                f"motor torque with the drive blocked (its Hann-weighted mean over the {hold:g} s after blocked): "
                f"the stalled motor's")
    row("speed_drop", 100 * (1 - np.min(np.abs(w[after])) / abs(w_j)) if w_j else None, "%",
        "largest drop of the main-shaft speed after the jam, of its speed then")
    if spec.motor is not None:
        overload_rows(system, spec.motor, df, after, row, after="in the jam")
    loads(t_j, t_b)
    belt_rows(system, spec, df, after & (t <= (t_b if t_b is not None else t[-1])), row, during="in the jam")
