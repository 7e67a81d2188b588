"""A drive's engineering quantities over its steady machine cycles: what a press engineer checks after a run.

``quantities(system, df)`` returns a :class:`Quantities` table from a result DataFrame and the drive's
declaration (``System.quantities``, a :class:`harness.specs.QuantitySpec` in ``systems/<name>.py``);
:func:`harness.run.simulate` stores it in ``df.attrs["quantities"]``, ``run`` prints it and writes it beside
the result as JSON.  A saved result read back (:func:`harness.results.read_csv`) gives the same table.

The machine cycles.  One cycle is ``cycle_angle`` of the main shaft's cumulative angle from ``cycle_origin``
(a revolution; the trimmer's block pitch); the cycle boundaries are the instants the angle passes them
(linear interpolation between samples), the incomplete pieces at both ends are left out.  A cycle's mean
speed is its angle over its duration (the exact time mean of the shaft speed).  The start-up is detected
from these means: a cycle is *steady* when its mean is within ``settle`` (0.1 %) of the cycle before's and
every later cycle's is too; everything before the first steady cycle is the start-up.  The first complete
cycle is never steady by itself (nothing before it shows the speed has settled), so a run needs at least two
complete cycles; a shorter one, or one whose speed is still moving at its end, gets no steady number and a
sentence saying why.

The quantities (names as printed):

* ``shaft_speed_mean`` [rpm]: the main shaft's mean speed over the steady cycles; ``machine_rate``
  [cycles/h]: steady cycles per hour;
* ``speed_fluctuation`` [%]: the coefficient of speed fluctuation delta = (w_max - w_min) / w_mean of the
  main shaft (the declared side of it), w_mean the cycle's time mean, the largest over the steady cycles;
* with a motor: ``motor_torque_peak`` (max |T|), ``motor_torque_rms`` (sqrt of the time mean of T^2 over whole
  cycles: the thermal check), both also ``..._to_rated`` (T_rated = P_rated / w_rated of the instance) and
  the peak ``..._to_breakdown``; ``power_electrical_mean``, ``power_electrical_peak``, ``energy_per_cycle``
  (the electrical energy of one steady cycle); ``motor_torque_startup_peak`` over the start-up;
* every declared load: ``<name>_peak``, ``<name>_range`` over the steady cycles, ``<name>_startup_peak``;
* the drive's answers (:class:`harness.specs.Answer`): the bed's speed spread and register error in the
  printing zone, the feeder's take-up angles and impact forces, the proof press's slip, the knife's twist
  and cutting torque, the trimming moment.

Time means and integrals are trapezoidal over the samples inside the window (exact for any step, also a
variable one).
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from harness.reporting import fatigue, qoi
from harness.results import KeptInAttrs
from harness.specs import Answer, QuantitySpec

RPM = 2 * math.pi / 60


@dataclass(frozen=True)
class Row:
    """One quantity: ``value`` a number, a list (angles, forces per impact) or None with ``note`` saying why
    there is none; ``over``: ``"steady"`` or ``"start-up"``; ``what``: its meaning, with the convention."""
    name: str
    value: float | list | None
    unit: str
    over: str
    what: str
    note: str = ""


@dataclass(frozen=True)
class Cycles:
    """The machine cycles of a run: ``bounds`` the n + 1 boundary instants [s] of its n complete cycles,
    ``means`` their mean speeds [rad/s] (cycle angle / duration), ``first_steady`` the index of the first
    steady cycle (None: no steady cycle), ``reason`` why there is none ('' when there is)."""
    bounds: np.ndarray
    means: np.ndarray
    first_steady: int | None
    reason: str
    settle: float

    @property
    def steady(self) -> tuple[float, float] | None:
        """(start, end) [s] of the steady cycles, None without any."""
        if self.first_steady is None:
            return None
        return float(self.bounds[self.first_steady]), float(self.bounds[-1])

    @property
    def n_steady(self) -> int:
        return 0 if self.first_steady is None else len(self.means) - self.first_steady

    def rule(self) -> str:
        """How the start-up was detected, in one sentence."""
        return (f"steady: the cycles from the first whose mean main-shaft speed is within {100 * self.settle:g} % "
                f"of the cycle before's, and every later one's too, to the end of the run")


def cycle_bounds(t: np.ndarray, angle: np.ndarray, origin: float = 0.0,
                 cycle_angle: float = 2 * math.pi) -> np.ndarray:
    """The instants [s] the cumulative shaft ``angle`` [rad] passes ``origin + k * cycle_angle`` (in the sense
    it turns), linearly interpolated between samples: the boundaries of the complete cycles in the run."""
    t, angle = np.asarray(t, dtype=float), np.asarray(angle, dtype=float)
    if t.size < 2 or not np.all(np.isfinite(angle)) or angle[-1] == angle[0]:
        return np.empty(0)
    theta = (angle - origin) * math.copysign(1.0, angle[-1] - angle[0]) / cycle_angle
    reached = np.maximum.accumulate(theta)              # the first passage counts (a shaft rocking back does not)
    ks = np.arange(math.ceil(theta[0]), math.floor(reached[-1]) + 1)
    if ks.size == 0:
        return np.empty(0)
    j = np.searchsorted(reached, ks, side="left")       # first sample at or past each boundary
    j = np.clip(j, 1, t.size - 1)
    lo, hi = reached[j - 1], reached[j]
    frac = np.where(hi > lo, (ks - lo) / np.where(hi > lo, hi - lo, 1.0), 1.0)
    out = t[j - 1] + np.clip(frac, 0.0, 1.0) * (t[j] - t[j - 1])
    out[ks <= theta[0]] = t[0]
    return out


def detect_cycles(t, angle, origin: float = 0.0, cycle_angle: float = 2 * math.pi,
                  settle: float = 1e-3, what: str = "revolution of the main shaft") -> Cycles:
    """The complete cycles of a run and the first steady one (the module docstring's rule)."""
    bounds = cycle_bounds(t, angle, origin, cycle_angle)
    means = cycle_angle / np.diff(bounds) if bounds.size >= 2 else np.empty(0)
    n = means.size
    span = float(np.asarray(t, dtype=float)[-1] - np.asarray(t, dtype=float)[0]) if len(t) else 0.0
    if n < 2:
        period = cycle_angle / abs(means[0]) if n == 1 else None
        need = f"; run to at least {bounds[0] + 2.05 * period:.3g} s" if period else ""
        took = f" (one takes {period:.3g} s)" if period else ""
        return Cycles(bounds, means, None,
                      f"run too short for a steady cycle: {n} complete cycle{'s' if n != 1 else ''}{took} in "
                      f"{span:.3g} s; a steady cycle needs 2 complete ones, the second showing that the speed "
                      f"has settled{need}", settle)
    settled = np.abs(np.diff(means)) <= settle * np.abs(means[1:])       # cycle k + 1 against cycle k
    if not settled[-1]:
        return Cycles(bounds, means, None,
                      f"no steady cycle: the mean main-shaft speed still changes by "
                      f"{100 * abs(means[-1] - means[-2]) / abs(means[-1]):.3g} % from cycle {n - 1} to {n} "
                      f"(settled: within {100 * settle:g} %); run longer", settle)
    k = n - 1                       # walk back while cycle k is settled against cycle k - 1
    while k >= 1 and settled[k - 1]:
        k -= 1
    return Cycles(bounds, means, k + 1, "", settle)      # cycle k is not settled (or k = 0): the next one is


# -- reductions over the samples where a mask holds -------------------------------------------------------
def _weights(t: np.ndarray, on: np.ndarray) -> np.ndarray:
    """Trapezoidal quadrature weights [s] of the samples where ``on`` holds, over each stretch of consecutive
    such samples (an interval between two samples counts when both hold: a gap between stretches does not)."""
    inside = on[1:] & on[:-1]
    half = 0.5 * np.diff(t) * inside
    w = np.zeros(t.size)
    w[1:] += half
    w[:-1] += half
    return w


def _time_mean(t: np.ndarray, x: np.ndarray, on: np.ndarray) -> float:
    w = _weights(t, on)
    total = float(np.sum(w))
    if not total > 0.0:  # single samples only: their plain mean
        return float(np.mean(x[on]))
    return float(np.sum(w * x) / total)


def _integral(t: np.ndarray, x: np.ndarray, on: np.ndarray) -> float:
    return float(np.sum(_weights(t, on) * x))


class _Window:
    """The samples of a result inside [a, b]: ``rows`` a mask over all of them."""

    def __init__(self, t: np.ndarray, a: float, b: float):
        self.rows = (t >= a) & (t <= b)


def _reduce(kind: str, t: np.ndarray, x: np.ndarray, on: np.ndarray) -> float:
    """``kind`` of ``x`` over the samples where ``on`` holds (time means trapezoidal, per stretch)."""
    if kind == "mean":
        return _time_mean(t, x, on)
    if kind == "rms":
        return math.sqrt(_time_mean(t, x * x, on))
    x = x[on]
    if kind == "peak":
        return float(np.max(np.abs(x)))
    if kind == "max":
        return float(np.max(x))
    if kind == "min":
        return float(np.min(x))
    if kind == "range":
        return float(np.ptp(x))
    raise ValueError(kind)


_SIMPLE = ("peak", "max", "min", "range", "mean", "rms")
KINDS = _SIMPLE + ("fluctuation", "register", "angles", "impacts")


# -- the table -------------------------------------------------------------------------------------------------
class Quantities(KeptInAttrs):
    """The engineering quantities of one run: ``rows`` (:class:`Row`), ``cycles`` (:class:`Cycles`), the
    system's name.  ``q["name"]`` is a value (None where the run gives none); :meth:`table` the printed
    table, :meth:`to_dict` / :meth:`write_json` the saved form, :meth:`frame` a DataFrame.

    Immutable once made; copies are the object itself (cheap in ``df.attrs``)."""

    def __init__(self, system: str, rows: list[Row], cycles: Cycles | None, shaft: str = "",
                 cycle_name: str = "", scope: str = ""):
        self.system, self.rows, self.cycles, self.shaft, self.cycle_name = system, tuple(rows), cycles, shaft, cycle_name
        self.scope = scope   # the part of the run they are taken over, in words ('' : the whole run)

    verdicts: dict = {}   # quantity -> harness.reporting.limits.Verdict, where --limits judged this table

    @property
    def names(self) -> list[str]:
        return [r.name for r in self.rows]

    def row(self, name: str) -> Row:
        for r in self.rows:
            if r.name == name:
                return r
        import difflib

        close = difflib.get_close_matches(name, self.names, n=3)
        raise KeyError(f"{self.system} has no quantity {name!r}"
                       + (f" (nearest: {', '.join(close)})" if close else f" (quantities: {', '.join(self.names)})"))

    def __getitem__(self, name: str):
        return self.row(name).value

    def __contains__(self, name: str) -> bool:
        return name in self.names

    def __repr__(self) -> str:
        return f"<Quantities of {self.system}: {len(self.rows)} rows>"

    def heading(self) -> str:
        c = self.cycles
        if c is None:
            return f"{self.system}: no engineering quantities declared"
        scope = f" ({self.scope})" if self.scope else ""
        if c.steady is None:
            return f"{self.system}{scope}: {c.reason}"
        a, b = c.steady
        first = c.first_steady + 1
        which = f"cycle {first}" if c.n_steady == 1 else f"cycles {first}-{len(c.means)}"
        return (f"{self.system}: engineering quantities over the steady {which} of {len(c.means)} complete{scope} "
                f"(t = {a:.4g} to {b:.4g} s); start-up: t < {a:.4g} s\n"
                f"  one cycle: {self.cycle_name}; shaft speeds on the {self.shaft}\n"
                f"  {c.rule()}")

    def table(self, width: int = 118) -> str:
        """The quantities as one text table with units (value, unit, over what, meaning)."""
        import textwrap

        lines = [self.heading()]
        if not self.rows:
            return lines[0]
        reason = self.cycles.reason if self.cycles is not None else ""
        silent = [r.name for r in self.rows if reason and r.note == reason]   # said once, in the heading
        notes = [r.note for r in self.rows if r.value is None and r.note and r.note != reason]
        shared = [n for n in dict.fromkeys(notes) if notes.count(n) >= 3]     # said once, below the table
        grouped = {n: [r.name for r in self.rows if r.value is None and r.note == n] for n in shared}
        quiet = set(silent) | {name for names in grouped.values() for name in names}
        judged = self.verdicts
        quiet -= set(judged)          # a quantity under a limit keeps its own line
        shown = [(r.name, _format(r.value) if r.value is not None else "-", r.unit or "-", r.over,
                  (f"[{judged[r.name].word} {judged[r.name].op} {judged[r.name].limit:g}] " if r.name in judged
                   else "") + r.what + (f" [{r.note}]" if r.note else "")) for r in self.rows if r.name not in quiet]
        w = [max(len(s[i]) for s in shown + [("quantity", "value", "unit", "over", "")]) for i in range(4)]
        head = f"  {'quantity':<{w[0]}}  {'value':>{w[1]}}  {'unit':<{w[2]}}  {'over':<{w[3]}}  meaning"
        lines += [head, "  " + "-" * (len(head) - 2)]
        indent = 2 + sum(w) + 8
        for name, value, unit, over, what in shown:
            text = f"  {name:<{w[0]}}  {value:>{w[1]}}  {unit:<{w[2]}}  {over:<{w[3]}}  "
            wrapped = textwrap.wrap(what, max(30, width - indent)) or [""]
            lines.append(text + wrapped[0])
            lines += [" " * indent + more for more in wrapped[1:]]
        if silent:
            lines.append(textwrap.fill(f"  no value, for the reason above: {', '.join(silent)}", width,
                                       subsequent_indent="    "))
        for note, names in grouped.items():
            lines.append(textwrap.fill(f"  no value ({note}): {', '.join(names)}", width, subsequent_indent="    "))
        return "\n".join(lines)

    def to_dict(self) -> dict:
        c = self.cycles
        out = {"system": self.system, "heading": self.heading()}
        if self.scope:
            out["scope"] = self.scope
        if c is not None:
            out["cycles"] = {"what": self.cycle_name, "shaft": self.shaft,
                             "bounds_s": [float(b) for b in c.bounds],
                             "mean_speed_rpm": [float(m / RPM) for m in c.means],
                             "first_steady": None if c.first_steady is None else c.first_steady + 1,
                             "steady_s": None if c.steady is None else list(c.steady),
                             "rule": c.rule(), "no_steady_reason": c.reason}
        out["quantities"] = [asdict(r) for r in self.rows]
        for r in out["quantities"]:
            v = self.verdicts.get(r["name"])
            if v is not None:
                r["limit"] = {"op": v.op, "value": v.limit, "verdict": v.word}
        return out

    def write_json(self, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(json.dumps(self.to_dict(), indent=1, allow_nan=False, default=_jsonable) + "\n")
        return path

    def frame(self) -> pd.DataFrame:
        """One row per quantity: value, unit, over, what, note (indexed by name)."""
        return pd.DataFrame([asdict(r) for r in self.rows], columns=["name", "value", "unit", "over", "what",
                                                                     "note"]).set_index("name")


def _jsonable(v):
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    raise TypeError(type(v).__name__)


def _format(v) -> str:
    if isinstance(v, (list, tuple)):
        return ", ".join(_format(x) for x in v) if v else "none"
    v = float(v)
    if not math.isfinite(v) or v == 0.0 or not 1e-3 <= abs(v) < 1e6:
        return f"{v:.4g}"
    return f"{v:.{max(0, 3 - math.floor(math.log10(abs(v))))}f}"   # 4 significant digits, no exponent


def json_path(out: str | Path) -> Path:
    """Where ``run --out FILE`` writes the quantities: ``x.csv`` -> ``x.quantities.json``."""
    out = Path(out)
    return out.with_name(f"{out.stem}.quantities.json")


# -- computing them --------------------------------------------------------------------------------------------
def parameter(system, df: pd.DataFrame, instance: str, name: str):
    """The value a run used for ``instance.name``: the run's start value (``df.attrs["start_values"]``), else
    the system's, else the FMU's declared start."""
    given = (df.attrs.get("start_values") or {}) if df is not None else {}
    if f"{instance}.{name}" in given:
        return given[f"{instance}.{name}"]
    inst = system.instance(instance)
    if name in inst.parameters:
        return inst.parameters[name]
    from harness.model import model_description, resolve_fmu

    for v in model_description(resolve_fmu(inst.fmu)).modelVariables:
        if v.name == name:
            return float(v.start) if v.start is not None else None
    return None


def quantities(system, df: pd.DataFrame, scope: str = "") -> Quantities:
    """The engineering quantities of ``system`` (a :class:`~harness.model.System`; ``harness.load(name)`` for
    a name) from its result ``df`` (module docstring).  A system that declares none gets an empty table that
    says so; a quantity whose column the result lacks (``output=`` left it out) or that is zero throughout gets
    no value and a note."""
    spec: QuantitySpec | None = getattr(system, "quantities", None)
    if spec is None:
        return Quantities(system.name, [], None)
    t = df.index.to_numpy(dtype=float)
    if spec.shaft_angle not in df.columns or len(df) < 2:
        cycles = Cycles(np.empty(0), np.empty(0), None,
                        f"no main-shaft angle {spec.shaft_angle!r} in the result", spec.settle)
    else:
        cycles = detect_cycles(t, df[spec.shaft_angle].to_numpy(dtype=float), spec.cycle_origin, spec.cycle_angle,
                               spec.settle, spec.cycle_name)
    rows = _Computer(system, spec, df, t, cycles).rows()
    return Quantities(system.name, rows, cycles, spec.shaft_name, spec.cycle_name, scope)


class _Computer:
    """The rows of one result (kept together: the windows and masks are shared by every row)."""

    def __init__(self, system, spec: QuantitySpec, df: pd.DataFrame, t: np.ndarray, cycles: Cycles):
        self.system, self.spec, self.df, self.t, self.c = system, spec, df, t, cycles
        self.out: list[Row] = []
        steady = cycles.steady
        self.steady = _Window(t, *steady) if steady is not None else None
        end = steady[0] if steady is not None else t[-1] if t.size else 0.0
        self.startup = _Window(t, t[0] if t.size else 0.0, end)
        self.startup_over = "start-up" if steady is not None else "whole run"
        self.at_speed = self._starts_at_speed()

    def _starts_at_speed(self) -> str:
        """Why the run's beginning is no start from rest ('' when it is one): its main shaft turns at the first
        sample at more than 1 % of its first cycle's mean speed (or of its largest speed)."""
        col = self.spec.shaft_speed
        if col not in self.df.columns or not self.t.size:
            return ""
        w = self.col(col)
        ref = abs(float(self.c.means[0])) if len(self.c.means) else float(np.max(np.abs(w)))
        if abs(w[0]) <= 0.01 * ref:
            return ""
        return (f"the run starts at speed ({abs(w[0]) / RPM:.4g} rpm at t = {self.t[0]:g} s), not from rest: a "
                f"start from rest is the drive's startup scenario (run DRIVE --scenario startup)")

    def _startup(self, name, unit, what, column):
        """A start-up peak of ``column``: None with the reason where the run does not start from rest."""
        if self.at_speed:
            self.out.append(Row(name, None, unit, self.startup_over, what, self.at_speed))
            return
        self.add(name, unit, self.startup_over, what, lambda: _reduce("peak", *self.on(self.startup, column)),
                 (column,))

    # a row whose value could not be had, with the reason
    def _missing(self, column: str) -> str:
        if column not in self.df.columns:
            return f"{column} not recorded in this result"
        return ""

    def add(self, name, unit, over, what, compute, columns=()):
        for c in columns:
            why = self._missing(c)
            if why:
                self.out.append(Row(name, None, unit, over, what, why))
                return
        if over in ("steady", "start-up") and self.steady is None:
            self.out.append(Row(name, None, unit, over, what, self.c.reason))
            return
        try:
            value = compute()
        except _NoValue as e:
            self.out.append(Row(name, None, unit, over, what, str(e)))
            return
        if isinstance(value, (np.floating, np.integer)):
            value = value.item()
        if isinstance(value, float) and not math.isfinite(value):
            self.out.append(Row(name, None, unit, over, what, f"not a finite number ({value})"))
            return
        self.out.append(Row(name, value, unit, over, what))

    def col(self, c: str) -> np.ndarray:
        return self.df[c].to_numpy(dtype=float)

    def on(self, w: _Window, c: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(time, column, mask) of the window's samples, for :func:`_reduce` and :func:`_integral`."""
        if not w.rows.any():
            raise _NoValue("no samples in the window")
        return self.t, self.col(c), w.rows

    def per_cycle(self):
        """(start, end) [s] of each steady cycle."""
        b = self.c.bounds
        return [(float(b[k]), float(b[k + 1])) for k in range(self.c.first_steady, len(b) - 1)]

    def rows(self) -> list[Row]:
        s, c = self.spec, self.c
        if c.steady is not None:
            a, b = c.steady
            n = c.n_steady
            mean_w = n * s.cycle_angle / (b - a)
        self.add("shaft_speed_mean", "rpm", "steady", "mean main-shaft speed (cycle angle / duration)",
                 lambda: mean_w / RPM)
        self.add("machine_rate", "cycles/h", "steady", "machine cycles per hour",
                 lambda: 3600.0 * n / (b - a))
        self.add("startup_time", "s", "start-up", "time from the start of the run to the first steady cycle",
                 lambda: a - float(self.t[0]))
        self.add("speed_fluctuation", "%", "steady",
                 "delta = (w_max - w_min) / w_mean of the main shaft, w_mean the cycle's time mean; the "
                 "largest over the steady cycles", lambda: 100 * self._fluctuation(s.shaft_speed, None),
                 (s.shaft_speed,))
        if s.motor is not None:
            self._motor(s.motor)
        for load in s.loads:
            self._load(load)
        for shaft in s.shafts:
            self._shaft(shaft)
        for belt in s.belts:
            self._belt(belt)
        for ans in s.answers:
            self._answer(ans)
        return self.out

    def _motor(self, m: str):
        torque, power = f"{m}.motor_torque", f"{m}.power_electrical"
        p = lambda name: parameter(self.system, self.df, m, name)  # noqa: E731
        try:
            rated = float(p("P_rated")) / float(p("w_rated"))
            breakdown = rated * float(p("breakdown_ratio"))
        except (TypeError, ValueError, ZeroDivisionError):   # a value the FMU refuses: the run said so already
            rated = breakdown = math.nan
        ideal = p("fidelity") == 0
        rating = (f"T_rated = P_rated / w_rated = {rated:.4g} N.m"
                  + (" (ideal speed source at fidelity 0: the instance's nominal rating)" if ideal else ""))
        peak = lambda: _reduce("peak", *self.on(self.steady, torque))  # noqa: E731
        rms = lambda: _reduce("rms", *self.on(self.steady, torque))  # noqa: E731
        self.add("motor_torque_peak", "N.m", "steady", "max |T| of the motor's own torque", peak, (torque,))
        self.add("motor_torque_rms", "N.m", "steady",
                 "sqrt(time mean of T^2) of the motor's torque over whole cycles: the thermal check", rms, (torque,))
        self.add("motor_torque_rated", "N.m", "rating", rating, lambda: rated)
        self.add("motor_torque_rms_to_rated", "1", "steady", "T_rms / T_rated: <= 1 for continuous duty",
                 lambda: rms() / rated, (torque,))
        self.add("motor_torque_peak_to_rated", "1", "steady", "T_peak / T_rated", lambda: peak() / rated, (torque,))
        self.add("motor_torque_peak_to_breakdown", "1", "steady",
                 f"T_peak / T_breakdown (T_breakdown = {breakdown:.4g} N.m); an overload margin keeps it below 0.8",
                 lambda: peak() / breakdown, (torque,))
        self.add("power_electrical_mean", "W", "steady", "time mean of the motor's electrical input power",
                 lambda: _reduce("mean", *self.on(self.steady, power)), (power,))
        self.add("power_electrical_peak", "W", "steady", "largest electrical input power",
                 lambda: _reduce("max", *self.on(self.steady, power)), (power,))
        self.add("energy_per_cycle", "J", "steady", "electrical energy drawn per steady machine cycle",
                 lambda: _integral(*self.on(self.steady, power)) / self.c.n_steady, (power,))
        self._startup("motor_torque_startup_peak", "N.m", "max |T| of the motor during the start-up from rest",
                      torque)

    def _load(self, load):
        c = load.column
        unit = (self.df.attrs.get("units") or {}).get(c, "")
        if c in self.df.columns and not np.any(self.col(c)):  # one row says it, not three
            self.out.append(Row(f"{load.name}_peak", None, unit, "steady", f"peak |x|: {load.what}",
                                f"{c} is 0 throughout the run: not modelled at this instance's fidelity"))
            return
        self.add(f"{load.name}_peak", unit, "steady", f"peak |x| (static sizing): {load.what}",
                 lambda: _reduce("peak", *self.on(self.steady, c)), (c,))
        self.add(f"{load.name}_range", unit, "steady", "max - min (fatigue)",
                 lambda: _reduce("range", *self.on(self.steady, c)), (c,))
        self._startup(f"{load.name}_startup_peak", unit, "peak |x| during the start-up from rest", c)
        self.add(f"{load.name}_damage_equivalent", unit, "steady",
                 f"damage-equivalent range per machine cycle, (sum n_i S_i^m / N_c)^(1/m), Wohler slope m = "
                 f"{load.slope:g}: rainflow count (ASTM E1049) over the steady cycles",
                 lambda: self._damage(c, load.slope), (c,))

    def _damage(self, column: str, slope: float, scale: float = 1.0) -> float:
        t, x, on = self.on(self.steady, column)
        return fatigue.damage_equivalent(scale * x[on], self.c.n_steady, slope)

    def _load_of(self, name: str, what: str):
        load = next((ld for ld in self.spec.loads if ld.name == name), None)
        if load is None:
            raise ValueError(f"system {self.system.name}: {what} names no declared load {name!r} (loads: "
                             f"{', '.join(ld.name for ld in self.spec.loads)})")
        return load

    def _value(self, key: str) -> float:
        inst, _, name = key.partition(".")
        v = parameter(self.system, self.df, inst, name)
        if v is None:
            raise _NoValue(f"no value of {key}")
        return float(v)

    def _shaft(self, shaft):
        load = self._load_of(shaft.load, "a shaft")
        c = load.column

        def stress(kind: str) -> float:
            d = self._value(shaft.diameter)
            if kind == "peak":
                torque = _reduce("peak", *self.on(self.steady, c))
                return float(fatigue.shear_stress(torque * shaft.share, d)) / 1e6
            return self._damage(c, load.slope, float(fatigue.shear_stress(shaft.share, d)) / 1e6)

        each = f"; {shaft.share:g} of the torque in each shaft" if shaft.share != 1.0 else ""
        self.add(f"{load.name}_shear_stress_peak", "MPa", "steady",
                 f"tau = 16 T / (pi d^3) at the peak torque, d = {shaft.diameter}{each}", lambda: stress("peak"), (c,))
        self.add(f"{load.name}_shear_stress_damage_equivalent", "MPa", "steady",
                 f"damage-equivalent shear stress range per machine cycle (Wohler slope m = {load.slope:g}; "
                 f"d = {shaft.diameter}{each})", lambda: stress("range"), (c,))

    def _belt(self, belt):
        load = self._load_of(belt.load, "a belt")
        c = load.column

        def capacity() -> float:
            return fatigue.belt_capacity(belt.tight_force, belt.mu, math.radians(belt.wrap),
                                         0.5 * self._value(belt.diameter), math.radians(belt.groove))

        kind = f"V-belt, groove {belt.groove:g} deg" if belt.groove else "flat belt"
        self.add(f"{load.name}_transmittable", "N.m", "rating",
                 f"largest torque the belt transmits on the pulley of {belt.diameter} before it slips: F_1 (1 - "
                 f"exp(-mu' beta)) r ({kind}; F_1 = {belt.tight_force:g} N, mu = {belt.mu:g}, beta = "
                 f"{belt.wrap:g} deg{'; ' + belt.source if belt.source else ''})", capacity)
        self.add(f"{load.name}_slip_margin", "1", "steady",
                 "transmittable torque / peak belt torque over the steady cycles: > 1 the belt holds",
                 lambda: capacity() / _reduce("peak", *self.on(self.steady, c)), (c,))

    # -- the drives' own answers -------------------------------------------------------------------------------
    def _mask(self, where: str | None) -> np.ndarray:
        if where is None:
            return np.ones(len(self.t), dtype=bool)
        return qoi.mask(where, self.df)

    def _fluctuation(self, column: str, where: str | None) -> float:
        x, on = self.col(column), self._mask(where)
        worst = None
        for a, b in self.per_cycle():
            rows = (self.t >= a) & (self.t <= b) & on
            if rows.sum() < 2:
                continue
            d = float(np.ptp(x[rows])) / abs(_time_mean(self.t, x, rows))
            worst = d if worst is None else max(worst, d)
        if worst is None:
            raise _NoValue("the zone is not met in any steady cycle")
        return worst

    def _register(self, column: str, where: str) -> float:
        x, on = self.col(column), self._mask(where)
        worst = None
        for a, b in self.per_cycle():
            rows = np.flatnonzero((self.t >= a) & (self.t <= b) & on)
            if rows.size < 3:
                continue
            tt, xx = self.t[rows], x[rows]
            uniform = xx[0] + (xx[-1] - xx[0]) * (tt - tt[0]) / (tt[-1] - tt[0])
            d = float(np.max(np.abs(xx - uniform)))
            worst = d if worst is None else max(worst, d)
        if worst is None:
            raise _NoValue("the zone is not met in any steady cycle")
        return worst

    def _last_cycle_rises(self, counter: str) -> tuple[np.ndarray, float, float]:
        a, b = self.per_cycle()[-1]
        n = self.col(counter)
        rises = np.flatnonzero(n[1:] > n[:-1]) + 1
        return rises[(self.t[rises] >= a) & (self.t[rises] < b)], a, b

    def _angles(self, counter: str) -> list:
        rises, _, _ = self._last_cycle_rises(counter)
        s = self.spec
        angle = self.col(s.shaft_angle)
        sense = math.copysign(1.0, angle[-1] - angle[0])
        theta = ((angle[rises] - s.cycle_origin) * sense) % s.cycle_angle
        return [float(v) for v in np.degrees(theta)]

    def _impacts(self, counter: str, force: str, flag: str) -> list:
        rises, _, b = self._last_cycle_rises(counter)
        f, on = np.abs(self.col(force)), self.col(flag)
        out = []
        for i, r in enumerate(rises):
            stop = rises[i + 1] if i + 1 < rises.size else int(np.searchsorted(self.t, b, side="right"))
            off = np.flatnonzero(on[r:stop] == 0)
            end = r + (int(off[0]) if off.size else stop - r)
            out.append(float(np.max(f[r:max(end, r + 1)])))
        return out

    def _answer(self, ans: Answer):
        k = ans.kind
        c0 = ans.columns[0]
        if k in _SIMPLE:
            def compute():
                on = self._mask(ans.where) & self.steady.rows
                if not on.any():
                    raise _NoValue("the condition holds in no steady sample")
                return ans.scale * _reduce(k, self.t, self.col(c0), on)
        elif k == "fluctuation":
            compute = lambda: ans.scale * self._fluctuation(c0, ans.where)  # noqa: E731
        elif k == "register":
            compute = lambda: ans.scale * self._register(c0, ans.where)  # noqa: E731
        elif k == "angles":
            compute = lambda: self._angles(c0)  # noqa: E731
        elif k == "impacts":
            compute = lambda: [ans.scale * v for v in self._impacts(*ans.columns[:3])]  # noqa: E731
        else:
            raise ValueError(f"system {self.system.name}: answer {ans.name}: unknown kind {k!r} "
                             f"(allowed: {', '.join(KINDS)})")
        needed = list(ans.columns) + (qoi.columns(ans.where) if ans.where else [])
        self.add(ans.name, ans.unit, "steady", ans.what, compute, needed)


class _NoValue(Exception):
    """A quantity the result cannot give (the reason is its message)."""


__all__ = ["Quantities", "Row", "Cycles", "quantities", "detect_cycles", "cycle_bounds", "json_path", "parameter",
           "KINDS"]
