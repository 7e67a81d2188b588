"""Coupling stability measured on co-simulation runs of the two-inertia benchmark: blow-up criterion,
bisection, and the study table and map (theory beside measurement).

:func:`measured_boundary` bisects on actual runs ``run(h) -> DataFrame``.  Blow-up criterion (stated once,
:func:`is_unstable`): a run is unstable if it did not complete (``attrs["complete"] is False``: the master
stopped on a non-finite output or one beyond its blow-up limit) or any value is non-finite, or the
oscillation amplitude GROWS: over the analysed columns (default: every column whose name ends in ``.tau``,
``.f``, ``.w`` or ``.v`` -- torques and speeds, which a free rigid-body drift of the angles does not
affect), with each column's mean over the second half of the run removed, ``max |y|`` over the last quarter
of the run exceeds ``max |y|`` over the second quarter.  The run callable decides its length; the study uses
a fixed number of periods of the coupled natural frequency (``periods``, default ``PERIODS`` = 90) and at least
``min_steps`` (default 400) communication steps, so that near the boundary the ratio of the two windows,
about ``rho**(n/2)``, resolves ``rho`` to a few 1e-3.  (90 periods, not 60: the divergence detector confirms a
slow geometric growth only once the run is 1.5 times as long as when it first saw it, and at 60 periods the
slowest Gauss-Seidel zero-order-hold points at 1.25 times the boundary ended before that.)
"""
from __future__ import annotations

import math
from dataclasses import asdict, replace
from pathlib import Path
from typing import Callable

import numpy as np

from harness.reporting.charts import save_figure
from harness.studies.trial import StudyInterrupted, quiet_simulate, study_options
from harness.studies.stability.theory import (MASTER_NAMES, TwoInertia, _as_params, _check_h, _master, _order,
                                              orders_for, stability_boundary)


PERIODS = 90.0  # run length of the two-inertia study [periods of the coupled natural frequency]


# -- measured boundary ----------------------------------------------------------------------------------------
GROWTH_SUFFIXES = (".tau", ".f", ".w", ".v")


def growth_ratio(df, columns=None) -> float:
    """Amplitude growth of a run: max over columns of max|y - mean| over the last quarter divided by the same
    over the second quarter (mean over the second half).  inf for an incomplete or non-finite run."""
    if not df.attrs.get("complete", True):
        return math.inf
    if columns is None:
        columns = [c for c in df.columns if str(c).endswith(GROWTH_SUFFIXES)] or list(df.columns)
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise ValueError(f"column {missing[0]!r} is not in the result (columns: {', '.join(map(str, df.columns))})")
    y = df[list(columns)].to_numpy(dtype=float)
    n = len(y)
    if n < 8:
        raise ValueError(f"a run of {n} points is too short to judge growth: need at least 8 communication points")
    if not np.all(np.isfinite(y)):
        return math.inf
    y = y - y[n // 2:].mean(axis=0)
    early = np.max(np.abs(y[n // 4:n // 2]), axis=0)
    late = np.max(np.abs(y[3 * n // 4:]), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(early > 0, late / np.where(early > 0, early, 1.0), np.where(late > 0, math.inf, 0.0))
    return float(np.max(r))


def is_unstable(df, columns=None, threshold: float = 1.0) -> bool:
    """The blow-up criterion of the module docstring: incomplete/non-finite run or growth ratio > threshold."""
    return growth_ratio(df, columns) > threshold


def measured_boundary(run: Callable[[float], "object"], h_lo: float, h_hi: float, rtol: float = 0.005,
                      columns=None, threshold: float = 1.0, max_runs: int = 40, *,
                      judge: Callable[["object"], bool] | None = None, checked: bool = False,
                      bracket: list | None = None) -> float:
    """Largest stable step by bisection on co-simulation runs: ``run(h)`` returns a result DataFrame,
    judged by :func:`is_unstable` (or by ``judge(df) -> unstable?``).  ``run(h_lo)`` must be stable and
    ``run(h_hi)`` unstable (``checked=True``: the caller has already run both, they are not re-run);
    bisection stops at a relative bracket width ``rtol`` and returns the bracket midpoint.  ``bracket``: a
    list that receives the final ``[lo, hi]`` and the number of runs made."""
    lo, hi = _check_h(h_lo), _check_h(h_hi)
    if not hi > lo:
        raise ValueError(f"h_hi = {h_hi!r} must be larger than h_lo = {h_lo!r}")

    def unstable(h):
        df = run(h)
        return judge(df) if judge is not None else is_unstable(df, columns, threshold)

    runs = 0
    if not checked:
        if unstable(lo):
            raise ValueError(f"h_lo = {lo!r}: the run is already unstable; give a smaller h_lo")
        if not unstable(hi):
            raise ValueError(f"h_hi = {hi!r}: the run is still stable; give a larger h_hi")
        runs = 2
    while hi - lo > rtol * hi:
        if runs >= max_runs:
            raise ValueError(f"measured_boundary: no bracket of relative width {rtol} after {max_runs} runs")
        mid = 0.5 * (lo + hi)
        if unstable(mid):
            hi = mid
        else:
            lo = mid
        runs += 1
    if bracket is not None:
        bracket[:] = [lo, hi, runs]
    return 0.5 * (lo + hi)


def two_inertia_run(params, master: str, order: int, periods: float = PERIODS, min_steps: int = 400,
                    system="two_inertia", fmu_dir=None, w0: float = 1.0):
    """A ``run(h)`` callable for :func:`measured_boundary`: co-simulates the two-inertia system with the
    parameters ``params`` (Inertia starting at speed ``w0``) over ``periods`` periods of the coupled natural
    frequency and at least ``min_steps`` steps.  ``fmu_dir``: folder with Inertia.fmu/SpringInertia.fmu
    (default: the system's own FMU resolution)."""
    from harness import load
    from harness.model import Instance

    p = _as_params(params)
    master, order = _master(master), _order(order)
    base = load(system)
    if fmu_dir is not None:
        fmu_dir = Path(fmu_dir)
        inst = []
        for i in base.instances:
            name = str(i.fmu)
            inst.append(Instance(i.name, fmu_dir / f"{name}.fmu" if not name.endswith(".fmu") else i.fmu,
                                 dict(i.parameters)))
        base = replace(base, instances=inst)
    ip = p.instance_parameters()
    ip["a"]["w0"] = float(w0)
    parameters = {f"{i}.{k}": v for i, d in ip.items() for k, v in d.items()}
    omega = p.natural_frequency()
    span = periods * 2.0 * math.pi / omega

    def run(h):
        n = max(int(min_steps), int(math.ceil(span / h)))
        stop = n * h
        return quiet_simulate(base, stop_time=stop, step=h, master=master, extrapolation=order,
                              start_values=parameters, output=["a.flange.w", "b.drive.tau"], on_error="return",
                              options=study_options(n))

    return run


# -- the study ------------------------------------------------------------------------------------------------
STUDY_ZETA = 0.1
STUDY_BASE = TwoInertia(J1=0.01, J2=0.01, c=100.0, c1=20.0).with_modal_damping(STUDY_ZETA)
"""Benchmark of the stability map: the chain ground - c1 - J1 | c, d | J2 (Inertia with a ground spring,
SpringInertia free) with Rayleigh damping giving a damping ratio of 0.1 in BOTH modes.  The damping makes
small steps stable (spectral radius < 1: without it Jacobi with zero-order hold is unstable at every step),
and the ground spring removes the free rigid-body mode, so the boundary is a clean crossing of 1."""


def _inertia_variant(base: TwoInertia, r: float) -> TwoInertia:
    return replace(base, J2=base.J1 * r, d=0.0, d1=0.0, d2=0.0).with_modal_damping(STUDY_ZETA)


def _stiffness_variant(base: TwoInertia, r: float) -> TwoInertia:
    return replace(base, c=base.c1 * r, d=0.0, d1=0.0, d2=0.0).with_modal_damping(STUDY_ZETA)


SWEEPS = {"inertia": ("J2/J1", _inertia_variant), "stiffness": ("c/c1", _stiffness_variant)}
DEFAULT_VALUES = {"inertia": (0.2, 0.5, 1.0, 2.0, 5.0), "stiffness": (1.0, 2.0, 5.0, 10.0, 20.0)}


def stability_table(base: TwoInertia = STUDY_BASE, sweep: str = "inertia", values=None, measure: bool = True,
                    fmu_dir=None, periods: float = PERIODS, rtol: float = 0.005, progress=None):
    """DataFrame: one row per (sweep value, master, order) with the theory boundary h_theory (RK4 map),
    h_exact (matrix-exponential map), h_measured (bisection on runs, NaN without ``measure``) [s], and the
    relative difference."""
    import pandas as pd

    if sweep not in SWEEPS:
        raise ValueError(f"sweep = {sweep!r} is not admissible: must be one of {', '.join(SWEEPS)}")
    label, make = SWEEPS[sweep]
    values = list(values) if values is not None else list(DEFAULT_VALUES[sweep])
    for v in values:
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"--values: {v!r} is not admissible for the {sweep} sweep ({label}): must be a "
                             f"positive number; nothing was run")
    rows = []
    try:  # Ctrl-C or SIGTERM: the rows finished so far go with the interrupt
        for v in values:
            p = make(base, float(v))
            omega = p.natural_frequency()
            for master in MASTER_NAMES:
                for order in orders_for(master):
                    h_th = stability_boundary(p, master, order, integrator="rk4")
                    h_ex = stability_boundary(p, master, order, integrator="exact")
                    h_me = math.nan
                    bounded = math.isfinite(h_th) and h_th > 1e-3 / omega * 1.0001
                    note = ("" if measure and bounded else "not measured: theory only" if not measure
                            else "not measured: the theory has no boundary inside the scanned range to bracket")
                    if measure and bounded:
                        run = two_inertia_run(p, master, order, periods=periods, fmu_dir=fmu_dir)
                        try:
                            h_me = measured_boundary(run, 0.6 * h_th, 1.5 * h_th, rtol=rtol)
                        except ValueError as e:
                            note = f"not bracketed in [0.6, 1.5] x theory: {e}"
                    rows.append(dict(sweep=sweep, ratio_name=label, ratio=float(v), master=master, order=order,
                                     omega=omega, h_theory=h_th, h_exact=h_ex, h_measured=h_me,
                                     rel_diff=(h_me - h_th) / h_th if math.isfinite(h_th) else math.nan,
                                     note=note, **{f"p_{k}": val for k, val in asdict(p).items()}))
                    if progress:
                        progress(f"{label} = {v:g}  {master:12s} order {order}: theory {_boundary_text(h_th, omega)}, "
                                 f"exact-subsystem {_boundary_text(h_ex, omega)}, "
                                 + (f"measured {h_me:.5g} s" if math.isfinite(h_me) else note))
    except KeyboardInterrupt as e:
        raise StudyInterrupted(pd.DataFrame(rows), e) from None
    return pd.DataFrame(rows)


def _boundary_text(h: float, omega: float) -> str:
    """A theory boundary in words where it is no number: :func:`stability_boundary` scans 1e-3/omega to
    10/omega and answers inf (stable over all of it) or the scan's lower end (unstable already there)."""
    if math.isinf(h):
        return f"stable over the whole range (to {10.0 / omega:.3g} s)"
    if h <= 1e-3 / omega * 1.0001:
        return f"unstable at every step (down to {h:.3g} s)"
    return f"{h:.5g} s"


def plot_stability_map(table, path_stem: Path) -> list[Path]:
    """Step limit vs sweep parameter: theory lines, measured markers; writes <stem>.png and <stem>.svg."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    colors = {0: "tab:blue", 1: "tab:orange", 2: "tab:green"}
    styles = {"jacobi": "-", "gauss-seidel": "--", "jacobian": ":"}
    markers = {"jacobi": "o", "gauss-seidel": "s", "jacobian": "D"}
    for (master, order), g in table.groupby(["master", "order"], sort=False):
        g = g.sort_values("ratio")
        y = (g["h_theory"] * g["omega"]).to_numpy()
        ax.plot(g["ratio"], y, styles.get(master, ":"), color=colors[order], label=f"{master}, order {order} (theory)")
        m = g["h_measured"].notna()
        if m.any():
            ax.plot(g["ratio"][m], (g["h_measured"] * g["omega"])[m], markers.get(master, "D"), color=colors[order],
                    mfc="none", ms=7)
    ax.plot([], [], "ko", mfc="none", label="measured (co-simulation, bisection)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

    ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))

    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_formatter(FormatStrFormatter("%g"))
        axis.set_minor_formatter(NullFormatter())
    ax.set_xticks(sorted(table["ratio"].unique()))
    ax.set_xlabel(f"{table['ratio_name'].iloc[0]} [1]")
    ax.set_ylabel(r"largest stable macro step  $\omega\,H$  [1]")
    ax.set_title(r"Two-inertia coupling: stability map ($\omega$: the coupled natural frequency [rad/s])",
                 fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)   # off the data
    fig.tight_layout()
    return save_figure(fig, path_stem, dpi=150)
