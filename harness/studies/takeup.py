"""``python -m harness study takeup``: seed 000's take-up map -- classical against non-classical impacts
over alpha_c x alpha_m at every crank angle beta of the seed (0-180 deg), and how the threshold moves with
the seed's other parameters (pressure angle theta, restitution e up to 1, clearance, c2, chi, crank speed).

Model: :mod:`fmus.physics.takeup` (the seed's frozen eq. (1), the play in the conrod element, the no-pull
contact of the FMUs, contacts located as events).  alpha_c = c1 / (c2 R3^2) and alpha_m = I1 / I2 as the seed
defines them (the normalised model of its eqs (8)-(9)).  A take-up is classical when the seed's alpha_y --
the natural period 2 pi/lambda3 over the duration of the first contact -- exceeds 4
(:func:`fmus.physics.takeup.is_classical`); S0-6's "only the first impact counts" is checked in every run.

The grid (``--quick`` for a small one):
* the seed's cases: alpha_m 0.5-5 and alpha_c 0.01-5 (the seed: 0.5-2 and 0.05-0.3 simulated, 0.5-5 in the
  frequency study, the threshold 0.3-0.4), beta 0-180 deg every 30 (at 90 deg the crank pin moves across the
  joint: no take-up, the row says so), I2 = 0.00043 kg.m2, e = 0.2, chi = 0.2, 150 rpm, 20 um, c2 = 5e5 N/m;
* one parameter at a time around those, at beta = 0 and 60 deg: theta -40..40 deg (the seed names the
  pressure angle but gives no value; 40 deg is the usual limit of a four-bar's), e 0.2, 0.5, 1, clearance
  5-20 um, c2 1e5-1e6 N/m, chi 0-0.4, 100-200 rpm;
* two geometries: ``seed r=R3`` (r = R3 = 0.040 m, the seed's normalised model) and ``feeder R3=0.12`` (the
  running feeder's longest lever, ``systems/feeder_gto52``).

Take-up cases: ``seed`` -- eq. (5) "without external forces", the rocker at rest, the crank pin closing the
play at omega1 r cos(beta); with the feeder clearance sweep's CSV (``--feeder-csv``, default
``docs/images/feeder_clearance.csv`` of the source tree; skipped with a note when absent) also ``feeder``
(its median approach speed, the rocker moving nearly with the pin) and ``feeder held`` (the same with its
smallest pin load pressing the rocker back).

Writes ``takeup.csv`` (one row per take-up), ``takeup_summary.csv`` (per geometry, case, varied parameter and
alpha_m: the first alpha_c with a non-classical take-up, the classical share), ``takeup.png/.svg``, and the
seed's figures from the model (alone with ``--figures``): ``takeup_velocity.png/.svg`` (Fig. 2, the roller
centre's velocity during the take-up: :func:`plot_velocity`) and ``takeup_liftoff.png/.svg`` with
``takeup_liftoff.csv`` (Fig. 3, where the roller lifts off its groove wall for K0 and C0 on the feeder's
groove: :func:`plot_liftoff`, :func:`fmus.physics.liftoff.lift_off`).
"""
from __future__ import annotations

import itertools
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from fmus.physics.takeup import ALPHA_Y_CLASSICAL, TakeUpParams, simulate
from harness.reporting.charts import save_figure
from harness.studies.trial import StudyInterrupted, keep_interrupted, write_complete

ROOT = Path(__file__).resolve().parents[2]          # the source tree (default input paths work from any folder)
ALPHA_C = (0.01, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 1.0, 2.0, 5.0)
ALPHA_M = (0.5, 1.0, 2.0, 5.0)
BETA_DEG = (0.0, 30.0, 60.0, 90.0, 120.0, 150.0, 180.0)
BASE = {"theta_deg": 0.0, "e": 0.2, "clearance_um": 20.0, "c2": 5e5, "chi": 0.2, "rpm": 150.0}
AXES = {"theta_deg": (-40.0, -20.0, 20.0, 40.0), "e": (0.5, 1.0), "clearance_um": (5.0, 10.0),
        "c2": (1e5, 1e6), "chi": (0.0, 0.4), "rpm": (100.0, 200.0)}
AXIS_BETA_DEG = (0.0, 60.0)
GEOMETRIES = {"seed r=R3": 0.040, "feeder R3=0.12": 0.12}
SEED_BAND = (0.3, 0.4)   # S0-3: classical impact possible for alpha_c < 0.3 ... 0.4
KEYS = ("geometry", "case", "varied", "beta_deg") + tuple(BASE)


def feeder_takeups(csv: Path) -> dict:
    """The running feeder's take-ups from the clearance sweep: median approach speed, smallest pin load,
    and the counts of impacts and classical impacts."""
    if not Path(csv).is_file():
        raise FileNotFoundError(f"{csv}: the feeder clearance sweep's CSV is missing (make it with python -m "
                                f"harness sweep feeder_gto52 --grid systems/studies/feeder_clearance.yaml "
                                f"--out {csv}), or pass --feeder-csv")
    d = pd.read_csv(csv)
    for col in ("impact_velocity", "peak_pin_force", "impacts", "impacts_classical"):
        if col not in d.columns:
            raise ValueError(f"{csv}: column {col!r} missing (allowed: the feeder_clearance sweep's outputs)")
    d = d[d["impacts"] > 0]
    return {"v_median": float(d["impact_velocity"].median()), "v_min": float(d["impact_velocity"].min()),
            "v_max": float(d["impact_velocity"].max()), "F_min": float(d["peak_pin_force"].min()),
            "F_max": float(d["peak_pin_force"].max()), "impacts": int(d["impacts"].sum()),
            "classical": int(d["impacts_classical"].sum()), "points": len(d)}


def settings_grid(beta_deg=BETA_DEG, axes=None, axis_beta_deg=AXIS_BETA_DEG):
    """(varied, beta_deg, settings) of the map: the base settings at every beta, then each axis' other values
    at ``axis_beta_deg`` (``varied`` names the parameter that differs from the base, '' for none)."""
    axes = AXES if axes is None else axes
    for b in beta_deg:
        yield "", b, dict(BASE)
    for name, values in axes.items():
        for v, b in itertools.product(values, axis_beta_deg):
            yield name, b, {**BASE, name: v}


def params_for(R3: float, beta_deg: float, s: dict, alpha_m: float, alpha_c: float) -> TakeUpParams:
    return TakeUpParams(R3=R3, beta=math.radians(beta_deg), theta=math.radians(s["theta_deg"]), e=s["e"],
                        clearance=s["clearance_um"] * 1e-6, c2=s["c2"], chi=s["chi"],
                        omega1=s["rpm"] * 2 * math.pi / 60, alpha_m=alpha_m, alpha_c=alpha_c)


def take_up_row(p: TakeUpParams) -> dict:
    """One take-up's numbers; a position where the pin does not close the play (beta = 90 deg) is a row that
    says so (take_up False), not an error."""
    if not abs(p.v_in) > 1e-12 * (abs(p.omega1 * p.r) + abs(p.V3)):
        return {"take_up": False, "v_in": p.v_in, "classical": math.nan}
    res = simulate(p)
    return {"take_up": True, "v_in": res.v_in, "classical": res.classical, "stable": res.stable,
            "opened": res.opened, "contact_ms": res.duration * 1e3, "period_ms": res.period * 1e3,
            "alpha_y": res.alpha_y, "alpha_y_eq89": float(p.frequencies().alpha_y), "e_measured": res.e_measured,
            "contacts": res.contacts, "first_governs": res.first_governs, "z_peak_um": res.z_peak * 1e6,
            "F_peak": res.F_peak, "F_min": res.F_min, "lambda_m": p.lambda_m()}


def run_map(feeder: dict | None = None, alpha_c=ALPHA_C, alpha_m=ALPHA_M, grid=None, geometries=None,
            progress=None) -> pd.DataFrame:
    """Every take-up of the map (``grid``: :func:`settings_grid`'s triples; default the full one)."""
    geometries = GEOMETRIES if geometries is None else geometries
    grid = list(settings_grid() if grid is None else grid)
    cases = [("seed", g) for g in grid]
    if feeder is not None:
        cases += [(c, ("", 0.0, dict(BASE))) for c in ("feeder", "feeder held")]
    rows = []
    try:  # Ctrl-C or SIGTERM: the take-ups finished so far go with the interrupt
        for (geo, R3), (case, (varied, b, s)) in itertools.product(geometries.items(), cases):
            for am, ac in itertools.product(alpha_m, alpha_c):
                p = params_for(R3, b, s, am, ac)
                if case != "seed":
                    p = replace(p, V3=p.v_pin - feeder["v_median"],
                                load=feeder["F_min"] if case == "feeder held" else 0.0)
                rows.append({"geometry": geo, "case": case, "varied": varied, "beta_deg": b, **s, "R3": R3,
                             "alpha_m": am, "alpha_c": ac, "load": p.load, **take_up_row(p)})
            if progress:
                progress(f"{geo} / {case} {varied or 'base'} beta={b:g}: done")
    except KeyboardInterrupt as e:
        raise StudyInterrupted(pd.DataFrame(rows), e) from None
    return pd.DataFrame(rows)


def summarise(df: pd.DataFrame) -> pd.DataFrame:
    """Per geometry, case, settings and alpha_m: the first alpha_c with a non-classical take-up (NaN: every
    take-up classical), whether the map turns classical again above it, the classical share, and S0-6's
    check (the share of runs whose first contact is the hardest)."""
    out = []
    df = df[df["take_up"]]
    for key, g in df.groupby(list(KEYS) + ["alpha_m"], sort=False):
        g = g.sort_values("alpha_c")
        cl = g["classical"].astype(bool)
        non = g[~cl]
        out.append(dict(zip(list(KEYS) + ["alpha_m"], key),
                        first_nonclassical=float(non["alpha_c"].min()) if len(non) else math.nan,
                        classical_above=bool(len(non) and cl.iloc[-1]),
                        classical_share=float(cl.mean()),
                        first_governs_share=float(g["first_governs"].astype(bool).mean()),
                        unstable=int((~g["stable"].astype(bool)).sum())))
    return pd.DataFrame(out)


def alpha_y_gap(df: pd.DataFrame) -> tuple[float, float]:
    """(largest alpha_y of a non-classical take-up that opened, smallest alpha_y of a classical one): the
    classification does not hang on the threshold 4 when the first is well below and the second well above."""
    d = df[df["take_up"] & df["opened"].astype(bool) & df["stable"].astype(bool)]
    cl = d["classical"].astype(bool)
    return float(d.loc[~cl, "alpha_y"].max()), float(d.loc[cl, "alpha_y"].min())


def plot(summary: pd.DataFrame, out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    geos = list(dict.fromkeys(summary["geometry"]))
    fig, axes = plt.subplots(1, len(geos), figsize=(4.6 * len(geos), 4.0), sharey=True, squeeze=False)
    for ax, geo in zip(axes[0], geos):
        s = summary[(summary["geometry"] == geo) & (summary["case"] == "seed") & (summary["varied"] == "")]
        for b, g in s.groupby("beta_deg"):
            ax.plot(g["alpha_m"], g["first_nonclassical"].fillna(max(ALPHA_C) * 1.5), "-o", ms=3,
                    label=f"beta = {b:g} deg")
        e1 = summary[(summary["geometry"] == geo) & (summary["varied"] == "e") & (summary["e"] == 1.0)
                     & (summary["beta_deg"] == 0.0)]
        if len(e1):
            ax.plot(e1["alpha_m"], e1["first_nonclassical"].fillna(max(ALPHA_C) * 1.5), "k--x", label="e = 1, beta = 0")
        ax.axhspan(*SEED_BAND, color="0.85", label="seed: classical below 0.3-0.4")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(ALPHA_M, [f"{v:g}" for v in ALPHA_M])
        ax.minorticks_off()
        ax.set_xlabel("alpha_m = I1/I2")
        ax.set_title(geo, fontsize=9)
    axes[0][0].set_ylabel("first non-classical alpha_c = c1/(c2 R3^2)")
    axes[0][-1].legend(fontsize=6, loc="lower right")
    fig.suptitle(f"Seed 000 take-up: classical (alpha_y > {ALPHA_Y_CLASSICAL:g}) below each line; at the top "
                 f"edge: classical at every alpha_c of the grid", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, out / "takeup", dpi=110)


LIFTOFF_LAWS = ("K0", "C0")            # the seed's Fig. 3: a - K0, b - C0 (and Fig. 2's kinematic row)


def velocity_trace(p: TakeUpParams, samples: int = 4000) -> dict:
    """The seed's Fig. 2 quantity: the roller centre's (stone pin's) velocity R3 gamma' during the take-up,
    beside the crank pin's r cos(beta) phi1' and eq. (10)'s velocity after the first impact (V3y, with the
    reduced mass ratio of the consistent model, :func:`fmus.physics.takeup.mass_ratio`)."""
    from fmus.physics.takeup import mass_ratio, v3y_first

    res = simulate(p, samples=samples)
    alpha = mass_ratio(p.I1, p.I2, p.r, p.R3, p.beta, p.theta, p.chi)
    return {"t": res.t, "v_roller": p.R3 * res.y[:, 3], "v_crank_pin": p.r * math.cos(p.beta) * res.y[:, 1],
            "v3y_eq10": v3y_first(alpha, p.e, p.v_pin, p.V3), "first_end": res.duration, "result": res}


def rocker_extremes(w) -> np.ndarray:
    """Samples where the rocker's kinematic angular velocity is zero (its dead centres, both ends of a dwell):
    where rho gamma' changes sign or enters or leaves exactly zero -- the take-up instants the seed names."""
    v = w.v_rocker
    nxt = np.roll(v, -1)
    hits = np.nonzero(((v * nxt) < 0.0) | ((v == 0.0) != (nxt == 0.0)))[0]
    # one instant per extreme: a dead centre that falls on a sample enters and leaves zero within two samples
    n = len(v)
    keep = [i for k, i in enumerate(hits) if len(hits) == 1 or (i - hits[k - 1]) % n > 2]
    return np.asarray(keep if keep else hits[:1], dtype=int)


def kinematic_rows(w, case, p: TakeUpParams) -> list[dict]:
    """At each of the rocker's extremes: the roller centre's kinematic velocity along the slot V3 (the stone's,
    eq. 10's V3) and eq. (10)'s V3y for it, with the mass ratio and crank-pin speed of the take-up ``p`` (as
    Fig. 2's bottom row: :func:`velocity_trace`)."""
    from fmus.physics import groove
    from fmus.physics.takeup import mass_ratio, v3y_first

    start = groove.base_design(case.lam1, case.lam2, case.lam3)["phi_start"]
    alpha = mass_ratio(p.I1, p.I2, p.r, p.R3, p.beta, p.theta, p.chi)
    return [{"law": case.law, "phi_deg": math.degrees((w.phi[i] - start) % (2 * math.pi)),
             "rho_mm": 1e3 * w.rho[i], "V3": float(w.v_slot[i]), "v_rocker": float(w.v_rocker[i]),
             "V3y_eq10": v3y_first(alpha, p.e, p.v_pin, float(w.v_slot[i]))} for i in rocker_extremes(w)]


def plot_velocity(out: Path, alpha_c=(0.0, 0.05, 0.3), R3: float = 0.040, laws=LIFTOFF_LAWS) -> list[Path]:
    """Fig. 2 of the seed, from the model (the paper's figure is not in the text we have, only its caption and
    two references to it).  Top: "according to the rocker's motion graph its angular (kinematic) velocity is
    zero" at the take-up -- the roller centre's kinematic velocity over the crank turn on the feeder's groove
    for K0 and C0, across the slot (the rocker's) and along it (the stone's V3 of eq. 10), the rocker's
    extremes marked.  Bottom: the roller centre's velocity during the take-up itself at beta = 0 (eq. 5's
    take-up, the rocker at rest), against eq. (10)'s V3y."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fmus.physics import groove
    from fmus.physics.liftoff import LiftOffCase, lift_off

    cols = max(len(alpha_c), len(laws))
    fig, axes = plt.subplots(2, cols, figsize=(4.2 * cols, 6.8), squeeze=False)
    for ax, law in zip(axes[0], laws):
        case = LiftOffCase(law=law)
        w = lift_off(case)
        start = groove.base_design(case.lam1, case.lam2, case.lam3)["phi_start"]
        deg = np.degrees((w.phi - start) % (2 * np.pi))
        order = np.argsort(deg)
        ax.plot(deg[order], np.hypot(w.v_slot, w.v_rocker)[order], "k", lw=1, label="roller centre |v|")
        ax.plot(deg[order], w.v_rocker[order], label="across the slot, rho gamma' (rocker)")
        ax.plot(deg[order], w.v_slot[order], "--", label="along the slot, V3 (stone)")
        for i in rocker_extremes(w):
            ax.axvline(deg[i], color="0.6", lw=0.8)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_title(f"{law}, {case.rpm:g} rpm: kinematic velocity (grey: rocker at an extreme)", fontsize=8)
        ax.set_xlabel("crank angle from the forward stroke's start [deg]")
    axes[0][0].set_ylabel("roller-centre velocity [m/s]")
    axes[0][0].legend(fontsize=6)
    for ax in axes[0][len(laws):]:
        ax.axis("off")
    for ax, ac in zip(axes[1], alpha_c):
        p = params_for(R3, 0.0, BASE, 1.0, ac)
        tr = velocity_trace(p)
        ax.plot(tr["t"] * 1e3, tr["v_roller"], label="roller centre R3 gamma'")
        ax.plot(tr["t"] * 1e3, tr["v_crank_pin"], "--", label="crank pin r cos(beta) phi1'")
        ax.axhline(tr["v3y_eq10"], color="k", lw=0.8, ls=":", label="eq. (10) V3y")
        ax.axvline(tr["first_end"] * 1e3, color="0.6", lw=0.8)
        ax.set_title(f"take-up, alpha_c = {ac:g}: {'classical' if tr['result'].classical else 'non-classical'}, "
                     f"{tr['result'].contacts} contacts", fontsize=8)
        ax.set_xlabel("time from the first onset [ms]")
    axes[1][0].set_ylabel("velocity along the joint [m/s]")
    axes[1][0].legend(fontsize=6)
    for ax in axes[1][len(alpha_c):]:
        ax.axis("off")
    fig.suptitle("Seed 000 Fig. 2 from the model: the roller centre's velocity. Top: over the crank turn on the "
                 "feeder's groove (r = 40 mm, lambda2 = 4.2, 30 deg dwell).\nBottom: during the take-up (alpha_m = "
                 "1, r = R3, e = 0.2, 150 rpm, beta = 0; grey: end of the first contact)", fontsize=8)
    fig.tight_layout()
    return save_figure(fig, out / "takeup_velocity", dpi=110)


LIFTOFF_LOADS = ((150.0, 0.0), (100.0, 0.05), (200.0, 0.05))   # (rpm, head friction N.m): the seed's case
#                                      without external forces, then the feeder head's guide friction
#                                      (systems/feeder_gto52: 0.05 N.m) at the seed's 100 and 200 rpm


GROOVE_CLEARANCE = 10e-6   # m, the feeder's groove play (CamRocker's groove_clearance; seed: 5-20 um)


def liftoff_rows(w, case) -> list[dict]:
    """One row per lift-off: where the roller leaves its wall (crank angle from the forward stroke's start,
    stone radius, kulisa angle), whether the rocker is then at an extreme position (within 1 % of the swing
    of either end: its dead centres and the dwell) or between them, and its crossing of the groove's play to
    the other wall (:func:`fmus.physics.liftoff.crossing`: time, crank angle, impact speed)."""
    from fmus.physics import groove
    from fmus.physics.liftoff import crossing

    start = groove.base_design(case.lam1, case.lam2, case.lam3)["phi_start"]
    g_lo, g_hi = float(w.gamma.min()), float(w.gamma.max())
    rows = []
    h = w.phi[1] - w.phi[0]
    crossings = crossing(w, case, GROOVE_CLEARANCE)
    for (i, j), cr in zip(w.lift_off, crossings):
        Nj = -w.N[j] if (j < i and w.wrap_flip) else w.N[j]     # after the turn's last sample: its first
        f = w.N[i] / (w.N[i] - Nj)                     # linear interpolation of the zero crossing
        dphi = ((j - i) % len(w.phi)) * h
        g = w.gamma[i] + f * (w.gamma[j] - w.gamma[i])
        extreme = min(g - g_lo, g_hi - g) < 0.01 * (g_hi - g_lo)
        rows.append({"law": case.law, "rpm": case.rpm, "head_friction": case.head_friction,
                     "phi_deg": math.degrees((w.phi[i] + f * dphi - start) % (2 * math.pi)),
                     "rho_mm": 1e3 * (w.rho[i] + f * (w.rho[j] - w.rho[i])),
                     "gamma_deg": math.degrees(g), "position": "extreme" if extreme else "intermediate",
                     "leaves": "+n" if w.N[i] > 0 else "-n", "cross_ms": 1e3 * cr["t_cross"],
                     "cross_deg": cr["crank_deg"], "impact_mm_s": 1e3 * cr["v_impact"]})
    return rows


def liftoff_map(laws=LIFTOFF_LAWS, loads=LIFTOFF_LOADS) -> tuple[pd.DataFrame, dict]:
    """Every lift-off of the seed's Fig. 3 cases, and the wall forces behind them ({(law, rpm, friction): w})."""
    from fmus.physics.liftoff import LiftOffCase, lift_off

    rows, runs = [], {}
    for law, (rpm, fr) in itertools.product(laws, loads):
        case = LiftOffCase(law=law, rpm=rpm, head_friction=fr)
        w = lift_off(case)
        runs[(law, rpm, fr)] = (case, w)
        rows += liftoff_rows(w, case)
    return pd.DataFrame(rows), runs


def plot_liftoff(out: Path, runs: dict) -> list[Path]:
    """Fig. 3 of the seed, from the model: the roller's lift-off positions for K0 (a) and C0 (b).  Top: the
    groove's centre line (the roller centre's path) in the kulisa's frame F2, drawn by the wall that carries
    the roller, each lift-off marked; bottom: the wall force over the crank turn for each load case."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fmus.physics import groove

    laws = list(dict.fromkeys(k[0] for k in runs))
    fig, axes = plt.subplots(2, len(laws), figsize=(5.2 * len(laws), 8.0), squeeze=False)
    for col, law in enumerate(laws):
        keys = [k for k in runs if k[0] == law]
        case, w = runs[keys[0]]
        start = groove.base_design(case.lam1, case.lam2, case.lam3)["phi_start"]
        ax = axes[0][col]
        B = w.B * 1e3
        for side, colour, name in ((1, "C0", "roller on the +n wall"), (-1, "C3", "roller on the -n wall")):
            on = np.where(np.sign(w.N) == side, 1.0, np.nan)
            ax.plot(B[:, 0] * on, B[:, 1] * on, color=colour, lw=2, label=name)
        for k, (i, _) in enumerate(w.lift_off, 1):
            ax.plot(*B[i], "ko", ms=4)
            ax.annotate(str(k), B[i], textcoords="offset points", xytext=(4, 4), fontsize=7)
        ax.plot(0.0, 0.0, "k+")
        ax.set_aspect("equal")
        ax.set_xlabel("x [mm] (frame F2, origin at the kulisa pivot)")
        ax.set_ylabel("y [mm]")
        ax.set_title(f"{'ab'[col] if col < 2 else col} - {law}: {len(w.lift_off)} lift-offs "
                     f"({case.rpm:g} rpm, no load)", fontsize=9)
        ax.legend(fontsize=7)
        ax = axes[1][col]
        for (lw_, rpm, fr), style in zip(keys, ("-", "--", ":")):
            c, wf = runs[(lw_, rpm, fr)]
            deg = np.degrees((wf.phi - start) % (2 * np.pi))
            order = np.argsort(deg)
            ax.plot(deg[order], wf.N[order], style, label=f"{rpm:g} rpm, head friction {fr:g} N.m")
            if fr == 0.0:
                ax.plot(deg[wf.lift_off[:, 0]], np.zeros(len(wf.lift_off)), "ko", ms=4)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xlabel("crank angle from the forward stroke's start [deg]")
        ax.set_ylabel("wall force N on the roller [N]")
        ax.legend(fontsize=7)
    fig.suptitle(f"Seed 000 Fig. 3 from the model: where the roller lifts off its groove wall (the rolling "
                 f"roller's normal force passes zero)\nr = {case.r * 1e3:g} mm, lambda2 = {case.lam2:g}, dwell "
                 f"{math.degrees(case.dwell):g} deg, J = {case.J:g} kg.m2, stone {case.m_stone:g} kg; "
                 f"dots: lift-offs without load", fontsize=8)
    fig.tight_layout()
    return save_figure(fig, out / "takeup_liftoff", dpi=110)


def register(study_subparsers) -> None:
    doc = __doc__.split("\n\n")[0].replace("\n", " ")
    p = study_subparsers.add_parser("takeup", help="seed 000: classical vs non-classical take-up of the pin "
                                    "clearance over the seed's parameters", description=doc)
    p.add_argument("--feeder-csv", type=Path, default=ROOT / "docs" / "images" / "feeder_clearance.csv",
                   help="the feeder clearance sweep's CSV (the running feeder's take-ups; default: the source "
                        "tree's docs/images/feeder_clearance.csv, skipped with a note when absent)")
    p.add_argument("--quick", action="store_true", help="a small grid: alpha_c 0.01 0.1 0.3 1 5, alpha_m 0.5 2, "
                   "beta 0 120, theta and e varied, one geometry")
    p.add_argument("--figures", action="store_true", help="only the seed's figures from the model: Fig. 2 "
                   "(takeup_velocity) and Fig. 3 with its table of lift-offs (takeup_liftoff, .csv); no map")
    p.add_argument("--out", type=Path, default=Path("results"), help="output folder (default: results/ in the "
                   "current folder)")
    p.set_defaults(func=takeup_cli)


def figures(out: Path) -> list[Path]:
    """The seed's Figs 2 and 3 from the model, with Fig. 3's lift-offs as ``takeup_liftoff.csv`` and printed."""
    from fmus.physics.liftoff import LiftOffCase, lift_off

    table, runs = liftoff_map()
    table = table.sort_values(["law", "rpm", "head_friction", "phi_deg"])
    write_complete(table, out / "takeup_liftoff.csv")
    p = params_for(0.040, 0.0, BASE, 1.0, 0.0)
    kin = pd.DataFrame([r for law in LIFTOFF_LAWS for r in kinematic_rows(lift_off(LiftOffCase(law=law)),
                                                                            LiftOffCase(law=law), p)])
    files = plot_velocity(out) + plot_liftoff(out, runs)
    with pd.option_context("display.width", 200, "display.max_rows", 1000):
        print("the rocker's extremes (seed Fig. 2; 150 rpm): the roller centre's kinematic velocity along the slot "
              "V3 and eq. (10)'s V3y (alpha_m 1, r = R3, e 0.2, chi 0.2, beta 0, as the take-ups below it):")
        print(kin.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
        print("roller lift-offs (seed Fig. 3; phi from the forward stroke's start):")
        print(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    return files + [out / "takeup_liftoff.csv"]


def takeup_cli(args) -> int:
    from harness.results import check_writable

    check_writable(args.out / "takeup.csv", "--out")  # before any take-up: a bad folder loses nothing
    if args.figures:
        files = figures(args.out)
        print(f"wrote {', '.join(str(f) for f in files)}")
        return 0
    feeder = None
    default_csv = args.feeder_csv == ROOT / "docs" / "images" / "feeder_clearance.csv"
    if args.feeder_csv.is_file() or not default_csv:
        feeder = feeder_takeups(args.feeder_csv)
    else:
        print(f"note: {args.feeder_csv} is missing: the feeder cases are skipped", file=sys.stderr)
    kw = {}
    if args.quick:
        kw = dict(alpha_c=(0.01, 0.1, 0.3, 1.0, 5.0), alpha_m=(0.5, 2.0), geometries={"seed r=R3": 0.040},
                  grid=settings_grid((0.0, 120.0), {"theta_deg": (40.0,), "e": (1.0,)}, (0.0,)))
    try:
        df = run_map(feeder, progress=lambda s: print(s, file=sys.stderr), **kw)
    except StudyInterrupted as e:
        return keep_interrupted(e, args.out / "takeup.csv", "study takeup")
    summary = summarise(df)
    write_complete(df, args.out / "takeup.csv")
    summary.to_csv(args.out / "takeup_summary.csv", index=False)
    files = plot(summary, args.out) + figures(args.out)
    with pd.option_context("display.width", 200, "display.max_rows", 1000):
        print(summary.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    hi, lo = alpha_y_gap(df)
    done = df[df["take_up"]]
    print(f"alpha_y of the first contact: non-classical (opened) at most {hi:.3g}, classical at least {lo:.3g} "
          f"(threshold {ALPHA_Y_CLASSICAL:g}); unstable take-ups (lambda_m^2 < 0): "
          f"{int((~done['stable'].astype(bool)).sum())}; smallest contact force {done['F_min'].min():.3g} N")
    if feeder is not None:
        print(f"running feeder ({args.feeder_csv}): {feeder['classical']} classical of {feeder['impacts']} "
              f"take-ups in {feeder['points']} runs; approach {feeder['v_min'] * 1e3:.1f}-"
              f"{feeder['v_max'] * 1e3:.1f} mm/s (median {feeder['v_median'] * 1e3:.1f}), pin load "
              f"{feeder['F_min']:.2f}-{feeder['F_max']:.2f} N")
    print(f"{len(done)} take-ups ({int(done['classical'].astype(bool).sum())} classical), "
          f"{len(df) - len(done)} positions without one; wrote {args.out / 'takeup.csv'}, "
          f"{args.out / 'takeup_summary.csv'}, {', '.join(str(f) for f in files)}")
    return 0
