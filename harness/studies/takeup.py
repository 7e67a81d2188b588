"""``python -m harness study takeup``: seed 000's take-up map, classical vs non-classical impacts, over
alpha_c x alpha_m x restitution x beta, for the seed's take-up and for the running feeder's.

Model: :mod:`fmus.physics.takeup` (the seed's frozen eq. (1), the play in the conrod element c2, contact
located as events).  alpha_c = c1 / (c2 R3^2) and alpha_m = I1 / I2 as the seed defines them (the
normalised model of its eqs (8)-(9)).  Classification as in that module: classical when the first contact
opens again within one take-up period 2 pi / lambda_m.

Geometries (crank radius r = 0.040 m of seed 001; the stone radius R3 of the running feeder's groove is
0.071-0.12 m, ``systems/feeder_gto52``):
* ``seed`` -- r = R3 (= 0.040 m): the seed's normalised model (r = R3 = 1 in its eqs (2)-(9));
* ``feeder R3=0.071``, ``feeder R3=0.12`` -- the feeder's lever ratios.

Take-up cases:
* ``seed`` -- eq. (5) "without external forces": the rocker at rest, the crank pin closing the play at
  omega1 r cos(beta) (``--rpm``, default 150 rpm: 0.63 m/s at beta = 0);
* ``feeder`` -- the running feeder's take-ups as the co-simulation measured them: the median approach
  speed (``impact_velocity``) with the rocker moving nearly with the pin, no load;
* ``feeder held`` -- the same approach with the smallest pin load measured in those take-ups
  (``peak_pin_force``) pressing the rocker back onto the pin: the take-up at a load reversal.
The feeder's numbers are read from the clearance sweep's CSV (``--feeder-csv``, default
``docs/images/feeder_clearance.csv``: ``python -m harness sweep feeder_gto52 --grid
systems/studies/feeder_clearance.yaml``), which also gives the share of classical take-ups in the running
mechanism (its ``impacts_classical`` over ``impacts``), printed beside the map.

Writes ``takeup.csv`` (one row per point), ``takeup_summary.csv`` (per geometry, case, e, beta, alpha_m: the
first and last alpha_c of the grid with a non-classical take-up) and ``takeup.png/.svg``.
"""
from __future__ import annotations

import itertools
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from fmus.physics.takeup import TakeUpParams, simulate
from harness.charts import save_figure

ALPHA_C = tuple(float(v) for v in np.round(np.logspace(-2, 1, 19), 4))
ALPHA_M = (0.5, 1.0, 2.0, 5.0)
RESTITUTION = (0.2, 0.5, 0.8)
BETA_DEG = (0.0, 30.0, 60.0)
GEOMETRIES = {"seed r=R3": 0.040, "feeder R3=0.071": 0.071, "feeder R3=0.12": 0.12}
SEED_BAND = (0.3, 0.4)   # S0-3: classical impact possible for alpha_c < 0.3 ... 0.4


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


def run_map(rpm: float = 150.0, feeder: dict | None = None, alpha_c=ALPHA_C, alpha_m=ALPHA_M,
            restitution=RESTITUTION, beta_deg=BETA_DEG, geometries=None, progress=None) -> pd.DataFrame:
    geometries = GEOMETRIES if geometries is None else geometries
    cases = [("seed", b) for b in beta_deg]
    if feeder is not None:
        cases += [("feeder", 0.0), ("feeder held", 0.0)]
    rows = []
    base = TakeUpParams(omega1=rpm * 2 * math.pi / 60)
    for (geo, R3), (case, b) in itertools.product(geometries.items(), cases):
        for e, am, ac in itertools.product(restitution, alpha_m, alpha_c):
            p = replace(base, R3=R3, beta=math.radians(b), e=e, alpha_m=am, alpha_c=ac)
            if case != "seed":
                p = replace(p, V3=p.v_pin - feeder["v_median"], load=feeder["F_min"] if case == "feeder held" else 0.0)
            res = simulate(p)
            f = p.frequencies()
            rows.append({"geometry": geo, "case": case, "R3": R3, "beta_deg": b, "e": e, "alpha_m": am,
                         "alpha_c": ac, "v_in": res.v_in, "load": p.load, "classical": res.classical,
                         "opened": res.opened, "contact_ms": res.duration * 1e3, "period_ms": res.period * 1e3,
                         "e_measured": res.e_measured, "contacts": res.contacts, "z_peak_um": res.z_peak * 1e6,
                         "F_peak": res.F_peak, "alpha_y": float(f.alpha_y), "lambda_m": p.lambda_m()})
        if progress:
            progress(f"{geo} / {case} beta={b:g}: done")
    return pd.DataFrame(rows)


def summarise(df: pd.DataFrame) -> pd.DataFrame:
    """Per geometry, case, e, beta, alpha_m: the first and last alpha_c with a non-classical take-up and the
    classical share (NaN bounds: every take-up classical)."""
    out = []
    for key, g in df.groupby(["geometry", "case", "e", "beta_deg", "alpha_m"], sort=False):
        g = g.sort_values("alpha_c")
        non = g[~g["classical"]]
        out.append(dict(zip(["geometry", "case", "e", "beta_deg", "alpha_m"], key),
                        first_nonclassical=float(non["alpha_c"].min()) if len(non) else math.nan,
                        last_nonclassical=float(non["alpha_c"].max()) if len(non) else math.nan,
                        classical_above=bool(len(non) and g["classical"].iloc[-1]),
                        classical_share=float(g["classical"].mean())))
    return pd.DataFrame(out)


def plot(summary: pd.DataFrame, out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    geos = list(dict.fromkeys(summary["geometry"]))
    fig, axes = plt.subplots(1, len(geos), figsize=(4.2 * len(geos), 3.8), sharey=True, squeeze=False)
    for ax, geo in zip(axes[0], geos):
        s = summary[(summary["geometry"] == geo) & (summary["beta_deg"] == 0.0)]
        for (case, e), g in s.groupby(["case", "e"], sort=False):
            if case == "feeder":          # the same lines as "seed" (a linear model: only v_in's scale differs)
                continue
            style = {"seed": "-o", "feeder": "--s", "feeder held": ":x"}[case]
            ax.plot(g["alpha_m"], g["first_nonclassical"], style, label=f"{case}, e={e:g}")
        ax.axhspan(*SEED_BAND, color="0.85", label="seed: classical below 0.3-0.4")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(ALPHA_M, [f"{v:g}" for v in ALPHA_M])
        ax.minorticks_off()
        ax.set_xlabel("alpha_m = I1/I2")
        ax.set_title(geo, fontsize=9)
        held = s[s["case"] == "feeder held"]
        if len(held) and (held["classical_share"] == 0).all():
            ax.text(0.03, 0.03, "feeder held: no classical take-up at any alpha_c", transform=ax.transAxes,
                    fontsize=7)
    axes[0][0].set_ylabel("first non-classical alpha_c = c1/(c2 R3^2)")
    axes[0][-1].legend(fontsize=6, loc="upper left")
    fig.suptitle("Seed 000 take-up, beta = 0: classical below each line (no line: classical at every alpha_c; "
                 "at 0.01: at none)",
                 fontsize=9)
    fig.tight_layout()
    return save_figure(fig, out / "takeup", dpi=110)


def register(study_subparsers) -> None:
    p = study_subparsers.add_parser(
        "takeup", help="seed 000: classical vs non-classical take-up of the pin clearance",
        description=__doc__.splitlines()[0])
    p.add_argument("--rpm", type=float, default=150.0, help="crank speed of the seed's take-up (seed: 100-200)")
    p.add_argument("--feeder-csv", type=Path, default=Path("docs/images/feeder_clearance.csv"),
                   help="the feeder clearance sweep's CSV (the running feeder's take-ups)")
    p.add_argument("--quick", action="store_true", help="7 alpha_c, alpha_m 0.5 2, e 0.2, beta 0")
    p.add_argument("--out", type=Path, default=Path("results"), help="output folder (default: results/)")
    p.set_defaults(func=takeup_cli)


def takeup_cli(args) -> int:
    feeder = feeder_takeups(args.feeder_csv)
    kw = {}
    if args.quick:
        kw = dict(alpha_c=ALPHA_C[::3], alpha_m=(0.5, 2.0), restitution=(0.2,), beta_deg=(0.0,))
    df = run_map(args.rpm, feeder, progress=lambda s: print(s, file=sys.stderr), **kw)
    summary = summarise(df)
    args.out.mkdir(parents=True, exist_ok=True)
    df.to_csv(args.out / "takeup.csv", index=False)
    summary.to_csv(args.out / "takeup_summary.csv", index=False)
    files = plot(summary, args.out)
    with pd.option_context("display.width", 160, "display.max_rows", 400):
        print(summary.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    print(f"running feeder ({args.feeder_csv}): {feeder['classical']} classical of {feeder['impacts']} take-ups "
          f"in {feeder['points']} runs; approach {feeder['v_min'] * 1e3:.1f}-{feeder['v_max'] * 1e3:.1f} mm/s "
          f"(median {feeder['v_median'] * 1e3:.1f}), pin load {feeder['F_min']:.2f}-{feeder['F_max']:.2f} N")
    print(f"{len(df)} take-ups ({int(df['classical'].sum())} classical); wrote {args.out / 'takeup.csv'}, "
          f"{args.out / 'takeup_summary.csv'}, {', '.join(str(f) for f in files)}")
    return 0
