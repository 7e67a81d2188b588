"""Transients a drive is sized by: start-up, speed change, emergency stop and jam, as time events on its free
inputs (``python -m harness run DRIVE --scenario NAME|FILE``, :func:`harness.run.simulate_scenario`).

A scenario (:class:`harness.specs.Scenario`) is declared per drive in ``systems/<name>.py`` (``show`` lists them)
or read from a small YAML or JSON file::

    name: late_stop
    question: How far does the bed run after a stop at 1.5 s?
    kind: stop                     # startup, speed_change, stop, load or jam
    stop_time: 3.0                 # s
    parameters: {motor.holding_torque: 30.0, motor.brake_delay: 0.05}
    changes:                       # time [s], free input, value, ramp [s] (0: a step)
      - {time: 1.5, variable: motor.supply, value: 0.0}
      - {time: 1.5, variable: motor.brake, value: 1.0}
    accuracy:                      # optional: what the question needs (study accuracy DRIVE --scenario FILE)
      - {name: stopping time, quantity: stopping_time, tolerance: 2.0e-3, unit: s}
      - {name: stopping angle, quantity: stopping_angle, tolerance: 0.005, unit: deg, relative: true}

Its ``parameters`` set the drive up (from rest, a brake's torque); its ``changes`` become the run's input signals
(:mod:`harness.signals`: a step is two rows at one time, a ramp a straight line from the value before it), so the
master sets each new value at the communication point of its time.  Every change's time must be such a point
(a whole multiple of the step from the start) and inside the run; a ramp's length is >= 0; two changes of one
input may not overlap.  Refused in one line before the run: an unknown scenario (the drive's are listed), a
file that is not a scenario, a change outside the run, a negative ramp, a variable that is neither a free input
nor a parameter its FMU declares tunable (a tunable one is set through setReal between steps; a fixed one is
refused, naming it; by :class:`harness.signals.Signals`), a value outside its declared range (naming the
scenario's file).

After the run, the transient's quantities (:func:`transient`) are in ``df.attrs["transient"]``: for a
``startup`` the time and main-shaft angle to 95 % of the speed the run ends at, and the peak motor, shaft and
joint loads on the way; for a ``speed_change`` the new speed and the time to settle within 1 % of it; for a
``stop`` the stopping time and angle of the main shaft from the first change, the tool's overrun and the peak
loads during the stop; for a ``load`` step the speed drop and the peak loads after it; for a ``jam`` (a tool
that runs into an end stop the scenario sets) the time to blocked, the stop's peak and held load, the motor's
overload and the peak loads in the jam (:mod:`harness.reporting.jams`).  A drive that stops
(an emergency stop) ends as a complete run, not as a diverged one.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from harness.errors import SystemDescriptionError
from harness.specs import Change, Requirement, Scenario, load_file

RPM = 2 * math.pi / 60
REACHED = 0.95      # start-up: the share of the final speed that counts as "up to speed"
SETTLED = 0.01      # speed change: the band around the new speed a settled cycle mean stays within
STOPPED = 0.01      # stop: the share of the speed at the stop command below which the shaft counts as stopped
DURING = {"startup": "on the way up to speed", "speed_change": "from the change on", "stop": "during the stop",
          "load": "from the load step on", "jam": "in the jam"}   # the stretch a kind's peak loads are taken over, in words


# -- finding and reading ---------------------------------------------------------------------------------------
def find(system, name_or_file) -> Scenario:
    """The scenario ``name_or_file``: one of the system's by name, a :class:`Scenario`, or a .yaml/.yml/.json
    file."""
    if isinstance(name_or_file, Scenario):
        return name_or_file
    text = str(name_or_file)
    for sc in system.scenarios:
        if sc.name == text:
            return sc
    if Path(text).suffix.lower() in (".yaml", ".yml", ".json"):
        return read(text)
    import difflib

    names = [sc.name for sc in system.scenarios]
    close = difflib.get_close_matches(text, names, n=3, cutoff=0.5)
    hint = f"did you mean {', '.join(close)}? " if close else ""
    raise SystemDescriptionError(f"system {system.name}: no scenario {text!r}: {hint}its scenarios: "
                                 f"{', '.join(names) or 'none'} "
                                 f"(or give a .yaml/.json scenario file)")


def read(path: str | Path) -> Scenario:
    """A scenario from a YAML or JSON file (the module docstring's form)."""
    path = Path(path)
    data = load_file(path, "scenario file")
    if not isinstance(data, dict):
        raise SystemDescriptionError(f"scenario file {path}: a mapping with name, question, kind, stop_time, "
                                     f"parameters "
                                     f"and changes is needed, not {type(data).__name__}")
    known = {"name", "question", "kind", "stop_time", "parameters", "changes", "accuracy"}
    unknown = sorted(set(data) - known)
    if unknown:
        raise SystemDescriptionError(f"scenario file {path}: unknown key {unknown[0]!r} (keys: "
                                     f"{', '.join(sorted(known))})")

    def number(value, key: str) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise SystemDescriptionError(f"scenario file {path}: {key} = {value!r} is not a finite number")
        return float(value)

    changes = data.get("changes") or []
    if not isinstance(changes, list):
        raise SystemDescriptionError(f"scenario file {path}: changes must be a list of {{time, variable, value, ramp}}")
    parsed = []
    for k, c in enumerate(changes):
        where = f"changes[{k}]"
        if not isinstance(c, dict) or not {"time", "variable", "value"} <= set(c) or set(c) - {"time", "variable",
                                                                                               "value", "ramp"}:
            raise SystemDescriptionError(f"scenario file {path}: {where} = {c!r}: give time, variable, value and "
                                         f"optionally "
                                         f"ramp")
        parsed.append(Change(number(c["time"], f"{where}.time"), str(c["variable"]),
                             number(c["value"], f"{where}.value"), number(c.get("ramp", 0.0), f"{where}.ramp")))
    parameters = data.get("parameters") or {}
    if not isinstance(parameters, dict):
        raise SystemDescriptionError(f"scenario file {path}: parameters must map Instance.parameter to a value")
    if "stop_time" not in data:
        raise SystemDescriptionError(f"scenario file {path}: stop_time [s] is missing")
    accuracy = data.get("accuracy") or []
    if not isinstance(accuracy, list):
        raise SystemDescriptionError(f"scenario file {path}: accuracy must be a list of {{name, quantity, tolerance, "
                                     f"unit, "
                                     f"relative}}")
    requirements = []
    for k, a in enumerate(accuracy):
        where = f"accuracy[{k}]"
        if not isinstance(a, dict) or not {"name", "quantity", "tolerance"} <= set(a) or set(a) - {
                "name", "quantity", "tolerance", "unit", "relative", "where"}:
            raise SystemDescriptionError(f"scenario file {path}: {where} = {a!r}: give name, quantity, tolerance and "
                                         f"optionally unit, relative, where")
        tolerance = number(a["tolerance"], f"{where}.tolerance")
        if tolerance < 0:
            raise SystemDescriptionError(f"scenario file {path}: {where}.tolerance = {tolerance:g} is negative")
        requirements.append(Requirement(str(a["name"]), str(a["quantity"]), tolerance, str(a.get("unit", "")),
                                        bool(a.get("relative", False)), a.get("where")))
    return Scenario(str(data.get("name", path.stem)), str(data.get("question", "")), str(data.get("kind", "load")),
                    number(data["stop_time"], "stop_time"), tuple(parsed),
                    tuple((str(k), v) for k, v in parameters.items()), accuracy=tuple(requirements))


# -- checking and the input table ------------------------------------------------------------------------------
def check(system, scenario: Scenario, step: float, stop_time: float) -> None:
    """The scenario's own rules (module docstring), before the run."""
    where = f"system {system.name}, scenario {scenario.name}"
    if scenario.kind not in Scenario.KINDS:
        raise SystemDescriptionError(f"{where}: kind {scenario.kind!r} is not one of {', '.join(Scenario.KINDS)}")
    last_end: dict[str, float] = {}
    for c in sorted(scenario.changes, key=lambda c: c.time):
        what = f"{where}: change of {c.variable} at t = {c.time:g} s"
        if c.ramp < 0.0:
            raise SystemDescriptionError(f"{what}: ramp = {c.ramp:g} s is negative (0 is a step)")
        if not 0.0 <= c.time < stop_time:
            raise SystemDescriptionError(f"{what}: outside the run [0, {stop_time:g}) s")
        points = c.time / step
        if abs(points - round(points)) > 1e-6:
            raise SystemDescriptionError(f"{what}: not a communication point of the {step:g} s step (a whole multiple "
                                         f"of it "
                                         f"is, e.g. {round(points) * step:g} s)")
        if c.time < last_end.get(c.variable, -math.inf):
            raise SystemDescriptionError(f"{what}: starts before its previous ramp ends at {last_end[c.variable]:g} s")
        last_end[c.variable] = c.time + c.ramp


def table(scenario: Scenario, start: dict[str, float]) -> pd.DataFrame:
    """The input signals of the scenario's changes: a ``time`` column and one column per changed input, a step
    as two rows at one time, a ramp as a straight line; ``start``: each input's value before its first change."""
    tracks: dict[str, list[tuple[float, float]]] = {}
    for c in sorted(scenario.changes, key=lambda c: c.time):
        points = tracks.setdefault(c.variable, [(0.0, float(start[c.variable]))])
        points.append((c.time, points[-1][1]))
        points.append((c.time + c.ramp, c.value))
    times = sorted({t for points in tracks.values() for t, _ in points})
    rows = []
    for t in times:
        before = {v: _at(points, t, after=False) for v, points in tracks.items()}
        after = {v: _at(points, t, after=True) for v, points in tracks.items()}
        if before != after:
            rows.append({"time": t, **before})
        rows.append({"time": t, **after})
    return pd.DataFrame(rows, columns=["time", *tracks])


def _at(points: list[tuple[float, float]], t: float, after: bool) -> float:
    """A piecewise-linear track's value at t (points in time order; two at one time are a step: ``after``
    takes the later one), held before the first and after the last point."""
    ts = [p[0] for p in points]
    if after:
        k = max(i for i, p in enumerate(ts) if p <= t) if ts[0] <= t else 0
        if ts[k] == t or k == len(ts) - 1:
            return points[k][1]
        (t0, v0), (t1, v1) = points[k], points[k + 1]
    else:
        k = min((i for i, p in enumerate(ts) if p >= t), default=len(ts) - 1)
        if ts[k] == t or k == 0 or ts[k] < t:
            return points[k][1]
        (t0, v0), (t1, v1) = points[k - 1], points[k]
    return v0 + (v1 - v0) * (t - t0) / (t1 - t0)


def check_ranges(system, scenario: Scenario, origin: str) -> None:
    """Every change's value within the min/max its FMU declares for the input, before the run; ``origin``: the
    file the scenario comes from (its scenario file, or ``systems/<drive>.py``)."""
    from harness.fmi.cache import model_description
    from harness.model import resolve_fmu

    names = {i.name for i in system.instances}
    for c in scenario.changes:
        inst, _, var = c.variable.partition(".")
        if inst not in names:
            continue  # an unknown instance: the input signals say it, with the nearest names
        md = model_description(resolve_fmu(system.instance(inst).fmu))
        v = next((v for v in md.modelVariables if v.name == var), None)
        if v is None:
            continue
        lo = -math.inf if getattr(v, "min", None) in (None, "") else float(v.min)
        hi = math.inf if getattr(v, "max", None) in (None, "") else float(v.max)
        if not lo <= c.value <= hi:
            raise SystemDescriptionError(f"{origin}: system {system.name}, scenario {scenario.name}: change of "
                                         f"{c.variable} at "
                               f"t = {c.time:g} s: value {c.value:g} is outside the range [{lo:g}, {hi:g}] that FMU "
                               f"{md.modelName} of instance {inst} declares for {var}")


def input_starts(system, scenario: Scenario) -> dict[str, float]:
    """Each changed input's start value, as its FMU declares it."""
    from harness.fmi.cache import model_description
    from harness.model import resolve_fmu

    out = {}
    for name in {c.variable for c in scenario.changes}:
        inst, _, var = name.partition(".")
        md = model_description(resolve_fmu(system.instance(inst).fmu))
        found = [v for v in md.modelVariables if v.name == var]
        out[name] = float(found[0].start) if found and found[0].start not in (None, "") else 0.0
    return out


# -- running ---------------------------------------------------------------------------------------------------
def prepare(system, scenario, options: dict) -> tuple[Scenario, dict]:
    """(the scenario, :func:`harness.run.simulate`'s arguments for it): ``options`` with the scenario's stop time
    (unless given), its parameters under the ``start_values`` given and its changes as the input signals,
    checked (module docstring).  :func:`harness.run.simulate_scenario` runs them."""
    sc = find(system, scenario)
    if isinstance(scenario, Scenario):
        origin = "scenario given in Python"
    elif any(s.name == str(scenario) for s in system.scenarios):
        origin = f"systems/{system.name}.py"
    else:
        origin = f"scenario file {scenario}"
    options = dict(options)
    if options.pop("input", None) is not None:
        raise SystemDescriptionError(f"scenario {sc.name} drives the inputs itself: give input signals or a scenario, "
                                     f"not both")
    stop_time = options.pop("stop_time", None) or sc.stop_time
    step = options.get("step") or options.get("step_size") or system.experiment.step
    check(system, sc, step, stop_time)
    check_ranges(system, sc, origin)
    options["start_values"] = {**dict(sc.parameters), **(options.get("start_values") or {})}
    options["input"] = table(sc, input_starts(system, sc)) if sc.changes else None
    options["stop_time"] = stop_time
    return sc, options


# -- the transient's quantities ----------------------------------------------------------------------------------
def transient(system, scenario: Scenario, df: pd.DataFrame):
    """The quantities of the transient (:class:`harness.reporting.quantities.Quantities`, rows over the scenario's kind):
    see the module docstring; a quantity the run does not reach is None with a note saying why."""
    from harness.reporting.quantities import Row, detect_cycles

    spec = system.quantities
    over = scenario.kind

    title = (f"{system.name}, scenario {scenario.name} ({scenario.kind}): {scenario.question}\n"
             f"  main-shaft speed on the {spec.shaft_name}" if spec is not None else
             f"{system.name}, scenario {scenario.name}: no engineering quantities declared")
    during = DURING[scenario.kind]

    if spec is None or df.empty:
        return _transient_table(title, system.name, [], None)
    t = df.index.to_numpy(dtype=float)
    w = df[spec.shaft_speed].to_numpy(dtype=float)
    angle = df[spec.shaft_angle].to_numpy(dtype=float)
    t_e = min((c.time for c in scenario.changes), default=0.0) if scenario.kind != "startup" else 0.0
    cycles = detect_cycles(t, angle, spec.cycle_origin, spec.cycle_angle, spec.settle, spec.cycle_name)
    rows: list = []

    def row(name, value, unit, what, note=""):
        rows.append(Row(name, None if value is None else float(value), unit, over, what, note))

    def at(x, time):
        return float(np.interp(time, t, x))

    def loads(after: float, until: float | None = None) -> None:
        on = (t >= after) & (t <= (t[-1] if until is None else until))
        columns = []
        if spec.motor is not None:
            columns.append((f"{spec.motor}.motor_torque", "motor_torque", "motor torque"))
            if f"{spec.motor}.brake_torque" in df:
                columns.append((f"{spec.motor}.brake_torque", "brake_torque", "brake torque on the rotor"))
        columns += [(load.column, load.name, load.what) for load in spec.loads]
        for column, name, what in columns:
            # a load not modelled at the instance's fidelity (zero throughout) or not recorded: no row
            if column in df and on.any() and df[column].any():
                x = df[column].to_numpy(dtype=float)[on]
                unit = df.attrs.get("units", {}).get(column, "")
                row(f"{name}_peak", np.max(np.abs(x)), unit, f"{what}: largest |value| {during}")

    last_mean = float(cycles.means[-1]) if len(cycles.means) else None
    if scenario.kind == "startup":
        if last_mean is None:
            row("time_to_speed", None, "s", "time to 95 % of the final speed", cycles.reason)
            return _transient_table(title, system.name, rows, cycles, spec.shaft_name, spec.cycle_name)
        target = REACHED * last_mean
        up = np.flatnonzero(w * math.copysign(1.0, last_mean) >= abs(target))
        row("final_speed", last_mean / RPM, "rpm", "main-shaft speed the run ends at: the mean of its last cycle")
        if up.size == 0:
            row("time_to_speed", None, "s", "time to 95 % of the final speed", "the run does not reach it")
            return _transient_table(title, system.name, rows, cycles, spec.shaft_name, spec.cycle_name)
        k = int(up[0])
        t95 = t[k] if k == 0 else t[k - 1] + (target - w[k - 1]) / (w[k] - w[k - 1]) * (t[k] - t[k - 1])
        row("time_to_speed", t95, "s", f"time from rest to {100 * REACHED:g} % of the final speed")
        row("angle_to_speed", math.degrees(abs(at(angle, t95) - angle[0])), "deg",
            f"main-shaft angle turned from rest to {100 * REACHED:g} % of the final speed")
        loads(0.0, t95)
    elif scenario.kind == "speed_change":
        before = cycles.means[cycles.bounds[1:] <= t_e] if len(cycles.means) else []
        row("speed_before", before[-1] / RPM if len(before) else None, "rpm",
            "mean main-shaft speed of the last cycle before the change",
            "" if len(before) else "no complete cycle before the change")
        row("speed_after", None if last_mean is None else last_mean / RPM, "rpm",
            "mean main-shaft speed of the run's last cycle", "" if last_mean is not None else cycles.reason)
        if last_mean is not None:
            # the first cycle after the change from which on every cycle mean is within the band; the last
            # cycle is the band's centre, so at least one before it must be inside too
            ok = (np.abs(cycles.means - last_mean) <= SETTLED * abs(last_mean)) & (cycles.bounds[:-1] >= t_e)
            k = len(ok)
            while k > 0 and ok[k - 1]:
                k -= 1
            settled = k < len(ok) - 1
            row("time_to_settle", cycles.bounds[k] - t_e if settled else None, "s",
                f"from the change to the first cycle whose mean, and every later one's, is within "
                f"{100 * SETTLED:g} % of the final speed", "" if settled else "not settled within the run")
        loads(t_e)
    elif scenario.kind == "stop":
        from harness.reporting.stops import stop_rows

        stop_rows(system, scenario, df, spec, cycles, t_e, row, loads)
    elif scenario.kind == "jam":
        from harness.reporting.jams import jam_rows

        jam_rows(system, scenario, df, spec, row, loads)
    else:  # load
        w_e = at(w, t_e)
        later = t >= t_e
        row("speed_drop", 100 * (1 - np.min(np.abs(w[later])) / abs(w_e)) if w_e else None, "%",
            "largest drop of the main-shaft speed after the load step, of its speed then")
        if spec.motor is not None:
            from harness.reporting.stops import overload_rows

            overload_rows(system, spec.motor, df, later, row)
        loads(t_e)
    return _transient_table(title, system.name, rows, cycles, spec.shaft_name, spec.cycle_name)


def _transient_table(title: str, *args):
    """A :class:`harness.reporting.quantities.Quantities` of a transient: its rows under the scenario's own heading."""
    from harness.reporting.quantities import Quantities

    table = Quantities(*args)
    table.heading = lambda: title
    return table
