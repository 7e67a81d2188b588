"""Coupling stability maps of the press drives, measured on co-simulation runs against a reference (the
criterion and the search are stated below; each drive's swept parameter is its ``System.stability``,
declared in ``systems/<name>.py``)."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Mapping

import numpy as np

from harness.reporting.charts import save_figure
from harness.run import declared
from harness.specs import StabilitySpec
from harness.studies.trial import StudyInterrupted, one_line, quiet_simulate, study_options
from harness.studies.stability.measured import GROWTH_SUFFIXES, measured_boundary
from harness.studies.stability.theory import ORDERS, _check_h, _order, orders_for


# -- press drives -----------------------------------------------------------------------------------------------
# The press drives are nonlinear, forced and never at rest, so the growth criterion of the linear benchmark
# (amplitude of the last quarter against the second quarter) is blind there: load events (a cut starting, an
# impact) change the amplitude of a perfectly stable run.  Their criterion is a deviation from a reference:
#
#   reference  the same system and parameters at the system's default step (``experiment.step``) with
#              gauss-seidel, order 0 (halved up to 3 times if that run does not complete);
#   unstable   the run did not complete (FMU error, non-finite output, an output beyond the master's blow-up
#              limit) or, on any analysed column (names ending in .tau .f .w .v), the largest deviation from
#              the reference (linearly interpolated to the run's communication points) over the LAST QUARTER
#              of the run exceeds ``tol`` (default 1) times that column's own variation in the reference
#              (max |y_ref - mean y_ref| over the run; floored at 1e-6 max |y_ref| + 1e-12 so that a column
#              that is physically zero does not turn round-off into a blow-up).
#
# A deviation as large as the signal itself is a blow-up, not a discretisation error: every run compares the
# same physical window [0, T], T = max(duration, periods * 2 pi / omega) with omega an estimate of the stiffest
# coupled mode from the parameters (``StabilitySpec.omega``, declared in ``systems/<name>.py``), so a weakly unstable step whose growth over T stays
# below the signal size counts as stable -- the measured boundary is the largest step whose co-simulation stays
# usable over T.  The search: the default step is judged first, then enlarged by 2^(1/4) (or halved) until the
# verdict changes (at most up to ``cap`` x the default step, and never fewer than 16 steps in T), then bisected
# (:func:`measured_boundary`) to a relative bracket width ``rtol``.  The fine upward scan matters for the
# ``jacobian`` master, whose verdicts are not monotone in the step: on the bed drive it deviated at 2.6 ms and was
# within the criterion again at 3-3.7 ms (rocker inertia 0.5 kg.m2, measured), so doubling from 0.5 ms to 4 ms and
# bisecting would have reported a boundary above an unstable step; the map reports the first one.
SCAN_FACTOR = 2.0 ** 0.25
"""Ratio of successive steps of the upward scan (the search above)."""
PRESS_MASTERS = ("jacobi", "gauss-seidel", "jacobian")
"""Default masters of the press maps (``jacobian`` at one order: :func:`orders_for`); ``jacobi-sampled``
(libcosim/FMPy style) via ``--masters``."""


PRESS_STUDIES: dict[str, StabilitySpec] = declared("stability")
"""System name -> its :class:`~harness.specs.StabilitySpec`, as declared in ``systems/<name>.py``."""


def _parameter_table(system) -> dict:
    """``{"inst.param": (value, model_variable)}`` of every Real parameter of the system's FMUs: the system's
    value, else the FMU's start value."""
    from harness.model import model_description, resolve_fmu

    out = {}
    for inst in system.instances:
        md = model_description(resolve_fmu(inst.fmu))
        for v in md.modelVariables:
            if v.causality != "parameter":
                continue
            val = inst.parameters.get(v.name, v.start)
            out[f"{inst.name}.{v.name}"] = (val, v)
    return out


def _variable_unit(v) -> str:
    """A model variable's unit (its own, else its declared type's); "1" where it has none."""
    from harness.model import _unit

    return _unit(v) or "1"


def check_sweep(system, sweep: str, values=None) -> None:
    """One-line ValueError unless ``sweep`` is ``INST.PARAM``, a Real parameter of an instance of ``system``,
    and every value a finite number."""
    from harness import load

    system = load(system)
    inst, dot, name = str(sweep).partition(".")
    if not dot or not inst or not name:
        raise ValueError(f"--sweep {sweep!r} is not admissible: write it INSTANCE.PARAMETER (e.g. bed.c_mesh)")
    names = [i.name for i in system.instances]
    if inst not in names:
        raise ValueError(f"--sweep {sweep}: system {system.name} has no instance {inst!r} "
                         f"(instances: {', '.join(names)})")
    table = _parameter_table(system)
    own = sorted(k.partition(".")[2] for k, (_, v) in table.items() if k.startswith(inst + ".") and v.type == "Real")
    if f"{inst}.{name}" not in table or table[f"{inst}.{name}"][1].type != "Real":
        raise ValueError(f"--sweep {sweep}: instance {inst} ({system.instance(inst).fmu}) has no Real parameter "
                         f"{name!r} (parameters: {', '.join(own)})")
    for v in values or ():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"--values: {v!r} is not admissible for {sweep}: must be a finite number")


def deviation_ratio(df, ref, columns=None) -> float:
    """Max over the analysed columns of max |y - y_ref| over the last quarter of ``df`` divided by the
    column's variation in the reference (see the press-drive criterion above); inf for an incomplete or
    non-finite run."""
    if not df.attrs.get("complete", True):
        return math.inf
    if columns is None:
        columns = [c for c in ref.columns if str(c).endswith(GROWTH_SUFFIXES)] or list(ref.columns)
    missing = [c for c in columns if c not in df.columns or c not in ref.columns]
    if missing:
        raise ValueError(f"column {missing[0]!r} is not in both the run and the reference")
    t = df.index.to_numpy(dtype=float)
    tr = ref.index.to_numpy(dtype=float)
    if t[-1] > tr[-1] * (1 + 1e-12):
        raise ValueError(f"the reference ends at {tr[-1]:g} s, before the run ({t[-1]:g} s)")
    n = len(t)
    if n < 8:
        raise ValueError(f"a run of {n} points is too short to judge: need at least 8 communication points")
    y = df[list(columns)].to_numpy(dtype=float)
    if not np.all(np.isfinite(y)):
        return math.inf
    worst = 0.0
    for j, c in enumerate(columns):
        yr_full = ref[c].to_numpy(dtype=float)
        yr = np.interp(t, tr, yr_full)
        scale = float(np.max(np.abs(yr - yr.mean())))
        scale = max(scale, 1e-6 * float(np.max(np.abs(yr_full))) + 1e-12)
        dev = float(np.max(np.abs(y[3 * n // 4:, j] - yr[3 * n // 4:])))
        worst = max(worst, dev / scale)
    return worst


def _with_fmu_dir(system, fmu_dir):
    from harness import load

    system = load(system)
    return system if fmu_dir is None else system.on_fmus(fmu_dir)


class PressRun:
    """``run(h)`` for :func:`measured_boundary` on a press drive, plus its reference and judge.

    ``parameters``: overrides ``{"inst.param": value}``; ``duration``: the physical window T [s] every run
    covers (``n = floor(T / h)`` steps, at least 8)."""

    def __init__(self, system, master: str, order: int, parameters: Mapping | None = None,
                 duration: float = 0.1, fmu_dir=None, tol: float = 1.0, reference=None):
        from harness.master import master_class

        self.system = _with_fmu_dir(system, fmu_dir)
        self.master = master_class(master).name
        self.order = _order(order)
        self.parameters = dict(parameters or {})
        self.duration = _check_h(duration)
        self.tol = float(tol)
        self.h_default = float(self.system.experiment.step)
        self.ref = reference if reference is not None else self.reference()
        self.runs = 0
        self.stops: dict[float, str] = {}  # step -> why its run stopped before its end (judged unstable)

    def reference(self):
        """Gauss-seidel, order 0 at the default step (halved up to 3 times until it completes)."""
        h = self.h_default
        for _ in range(4):
            n = int(math.ceil(self.duration / h - 1e-9))
            df = quiet_simulate(self.system, stop_time=n * h, step=h, master="gauss-seidel", extrapolation=0,
                                 start_values=self.parameters, on_error="return")
            if df.attrs.get("complete", True):
                return df
            err = df.attrs.get("error", "")
            h *= 0.5
        sets = ", ".join(f"{k} = {v:g}" for k, v in self.parameters.items()) or "default parameters"
        raise ValueError(f"{self.system.name} ({sets}): the reference run failed even at step {2 * h:g} s: {err}")

    def n_steps(self, h: float) -> int:
        return max(8, int(math.floor(self.duration / h + 1e-9)))

    def __call__(self, h: float):
        h = _check_h(h)
        n = self.n_steps(h)
        self.runs += 1
        df = quiet_simulate(self.system, stop_time=n * h, step=h, master=self.master,
                            extrapolation=self.order, start_values=self.parameters, on_error="return",
                            options=study_options(n))
        if df.attrs.get("complete") is False:
            self.stops[h] = str(df.attrs.get("error") or "incomplete run")
        return df

    def judge(self, df) -> bool:
        """True if the run is unstable (deviation criterion of the press-drive section)."""
        return deviation_ratio(df, self.ref) > self.tol

    def unstable(self, h: float) -> bool:
        return self.judge(self(h))


def press_boundary(prun: PressRun, rtol: float = 0.02, cap: float = 64.0, floor: float = 1.0 / 16) -> dict:
    """Largest stable step of one method (search of the press-drive section).  Returns ``h_stable`` (largest
    step judged stable), ``h_unstable`` (smallest judged unstable), ``h_boundary`` (their midpoint; NaN if not
    bracketed), ``status`` (``bracketed``, ``stable to cap``, ``unstable at floor``), ``runs`` and ``note``: why
    the run at ``h_unstable`` stopped before its end, where it did (e.g. a singular interface Jacobian), else
    empty (judged on its deviation)."""
    r = _press_search(prun, rtol, cap, floor)
    r["note"] = getattr(prun, "stops", {}).get(r["h_unstable"], "")
    return r


def _press_search(prun: PressRun, rtol: float, cap: float, floor: float) -> dict:
    h0 = prun.h_default
    h_max = min(cap * h0, prun.duration / 16.0)
    h_min = floor * h0
    prun.runs = 0
    h = min(h0, h_max)
    if not prun.unstable(h):
        lo = h
        while True:
            if lo >= h_max * (1 - 1e-12):
                return dict(h_stable=lo, h_unstable=math.nan, h_boundary=math.nan, status="stable to cap",
                            runs=prun.runs)
            hi = min(SCAN_FACTOR * lo, h_max)
            if prun.unstable(hi):
                break
            lo = hi
    else:
        hi = h
        while True:
            if hi <= h_min * (1 + 1e-12):
                return dict(h_stable=math.nan, h_unstable=hi, h_boundary=math.nan, status="unstable at floor",
                            runs=prun.runs)
            lo = max(0.5 * hi, h_min)
            if not prun.unstable(lo):
                break
            hi = lo
    br: list = []
    hb = measured_boundary(prun, lo, hi, rtol=rtol, judge=prun.judge, checked=True, bracket=br)
    lo, hi = br[0], br[1]
    return dict(h_stable=lo, h_unstable=hi, h_boundary=hb, status="bracketed", runs=prun.runs)


def press_stability_table(system: str, sweep: str | None = None, values=None, masters=PRESS_MASTERS,
                          orders=ORDERS, periods: float = 10.0, duration: float | None = None, rtol: float = 0.03,
                          cap: float = 64.0, fmu_dir=None, quick: bool = False, progress=None):
    """DataFrame: one row per (value, master, order) with the largest stable communication step of a press
    drive (:func:`press_boundary`) as the coupling parameter ``sweep`` (``INST.PARAM``) takes ``values``."""
    import pandas as pd

    from harness import load
    from harness.master import master_class

    if system not in PRESS_STUDIES:
        raise ValueError(f"system {system!r} has no stability study: use one of "
                         f"{', '.join(sorted(PRESS_STUDIES))} or two_inertia")
    study = PRESS_STUDIES[system]
    sweep = sweep or study.sweep
    if values is None:
        values = study.quick_values if quick else study.values
        if sweep != study.sweep:
            raise ValueError(f"--sweep {sweep}: give --values (defaults exist only for {study.sweep})")
    values = [float(v) for v in values]
    masters = [master_class(m).name for m in masters]
    orders = [_order(q) for q in orders]
    base = _with_fmu_dir(load(system), fmu_dir)
    check_sweep(base, sweep, values)
    table = _parameter_table(base)
    unit = _variable_unit(table[sweep][1])
    h_default = float(base.experiment.step)
    runs = {}       # value -> (omega, T, reference run): every value's reference first, so a value the
    failed = {}     # drive cannot run is known before any bisection; it becomes rows saying why
    rows = []
    try:  # Ctrl-C or SIGTERM: the rows finished so far go with the interrupt
        for v in values:
            def p(name, _v=v):
                return _v if name == sweep else float(table[name][0])

            try:
                omega = float(study.omega(p))
            except (KeyError, ValueError, ZeroDivisionError, TypeError):
                omega = math.nan
            T = duration if duration is not None else study.duration * (0.5 if quick else 1.0)
            if math.isfinite(omega) and omega > 0:
                T = max(T, periods * 2.0 * math.pi / omega)
            try:
                runs[v] = (omega, T, PressRun(base, "gauss-seidel", 0, {sweep: v}, duration=T).ref)
            except Exception as e:  # the reference does not run with this value (e.g. the FMU refuses it)
                failed[v] = (omega, T, one_line(e))
                if progress:
                    progress(f"{sweep} = {v:g}: not measured, the reference run fails: {failed[v][2]}")
        for v in values:
            for master in masters:
                for order in orders_for(master, orders):
                    if v in failed:
                        omega, T, why = failed[v]
                        r = dict(h_stable=math.nan, h_unstable=math.nan, h_boundary=math.nan, status="failed",
                                 runs=0, note="", error=why)
                    else:
                        omega, T, ref = runs[v]
                        prun = PressRun(base, master, order, {sweep: v}, duration=T, reference=ref)
                        try:
                            r = dict(press_boundary(prun, rtol=rtol, cap=cap), error="")
                        except Exception as e:  # a search that cannot go on: this row says why, the others go on
                            r = dict(h_stable=math.nan, h_unstable=math.nan, h_boundary=math.nan, status="failed",
                                     runs=prun.runs, note="", error=one_line(e))
                        if progress:
                            progress(f"{sweep} = {v:g}  {master:14s} order {order}: {_boundary_text(r)} "
                                     f"({r['runs']} runs)")
                    rows.append(dict(system=system, sweep=sweep, unit=unit, value=v, master=master, order=order,
                                     h_default=h_default, omega_est=omega, duration=T, **r))
    except KeyboardInterrupt as e:
        raise StudyInterrupted(pd.DataFrame(rows), e) from None
    return pd.DataFrame(rows)


def _boundary_text(r: dict) -> str:
    """One method's result of :func:`press_boundary` in words (no "nan" where a side was not reached)."""
    if r["status"] == "stable to cap":
        return f"stable up to the cap of the search, {r['h_stable']:.4g} s"
    if r["status"] == "unstable at floor":
        return f"unstable down to the floor of the search, {r['h_unstable']:.4g} s"
    if r["status"] == "failed":
        return f"failed: {r['error']}"
    stopped = f" (the run stopped: {r['note']})" if r.get("note") else ""
    return f"largest stable step {r['h_stable']:.4g} s, unstable at {r['h_unstable']:.4g} s{stopped}"


def _sweep_unit(system: str, sweep: str) -> str:
    """The unit of ``sweep`` (``INST.PARAM``) from the system's FMU: for a table written before it carried one."""
    from harness import load

    try:
        return _variable_unit(_parameter_table(load(system))[sweep][1])
    except Exception:
        return "?"


def plot_press_map(table, path_stem: Path) -> list[Path]:
    """Largest stable step vs the swept parameter for every method, the default step dashed; <stem>.png/.svg.
    A method stable up to the cap is drawn at the cap with an upward triangle; unstable at the floor with a
    downward one."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9.5, 5.0))
    colors = {0: "tab:blue", 1: "tab:orange", 2: "tab:green"}
    styles = {"jacobi": "-", "gauss-seidel": "--", "jacobi-sampled": ":", "jacobian": "-."}
    markers = {"jacobi": "o", "gauss-seidel": "s", "jacobi-sampled": "d", "jacobian": "D"}
    for (master, order), g in table.groupby(["master", "order"], sort=False):
        g = g.sort_values("value")
        y = np.where(g["status"] == "bracketed", g["h_boundary"],
                     np.where(g["status"] == "stable to cap", g["h_stable"], g["h_unstable"]))
        ax.plot(g["value"], y, styles.get(master, "-"), marker=markers.get(master, "o"), color=colors[order],
                mfc="none", ms=6, label=f"{master}, order {order}")
        for st_, mk in (("stable to cap", "^"), ("unstable at floor", "v")):
            m = (g["status"] == st_).to_numpy()
            if m.any():
                ax.plot(g["value"][m], y[m], mk, color=colors[order], ms=9)
    hd = float(table["h_default"].iloc[0])
    ax.axhline(hd, color="k", ls="-.", lw=1.0, label=f"system default step {hd:g} s")
    ax.set_xscale("log")
    ax.set_yscale("log")
    from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_formatter(FormatStrFormatter("%g"))
        axis.set_minor_formatter(NullFormatter())
    ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    ax.set_xticks(sorted(table["value"].unique()))
    sweep = str(table["sweep"].iloc[0])
    unit = str(table["unit"].iloc[0]) if "unit" in table else _sweep_unit(str(table["system"].iloc[0]), sweep)
    ax.set_xlabel(f"{sweep} [{unit}]")
    ax.set_ylabel("largest stable communication step  H  [s]")
    ax.set_title(f"{table['system'].iloc[0]}: stability map (bisection on co-simulation runs)")
    ax.grid(True, which="both", alpha=0.3)
    ax.plot([], [], "k^", label="stable up to the search's cap")
    ax.plot([], [], "kv", label="unstable down to the search's floor")
    failed = int((table["status"] == "failed").sum())
    if failed:
        ax.plot([], [], " ", label=f"{failed} rows failed (not drawn; see the table's error column)")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)   # off the data
    fig.tight_layout()
    return save_figure(fig, path_stem, dpi=150)
