"""``synth groove``: LCSM groove (centroid-profile) synthesis, feasibility scan of lambda2, law comparison.

    synth groove --crank-radius 0.04 --lambda1 3.5 --lambda3 3 --law K0 --scan lambda2 --json
    synth groove ... --lambda2 4.03 --out profile.txt
    synth groove ... --compare-laws [--lambda2 X]

The equations are in fmus.physics.groove (criteria: kinematic connection, rho > 0, cusps inside a stroke,
undercut against --roller-radius, pressure angle <= --max-pressure-angle); see its docstring for every choice.
"""
from __future__ import annotations

import argparse
import json
import math
import warnings

import numpy as np

from fmus.physics import groove
from fmus.physics.laws import KNOWN_LAWS, get_law
from harness.synthesis import fail, summary, typed

COMPARE = ("K0", "C0", "power", "polydynamic", "P6")
# Seed 001's own law names 1,3 / 1,5 (catalogue codes of Tir & Senyk [10]) are not here: the seed does not define
# them (fmus.physics.laws.SEED_UNDEFINED).  'power' is the power-type form at --n, not any of them.
# The criteria seed 001 itself states (feeder.md): the kinematic connection (K6) whose break bounds lambda2
# from below and shows as a cusp of the centroid curve (S1-2), the stone on the working side rho > 0 (K8,
# section 1.3), no cusp / no undercut (S1-6, S1-7; undercut needs a roller radius, which the seed does not
# give).  The pressure-angle limit is the toolkit's (60 deg = 90 - mu_min of seed 004): seed 001 names
# pressure angles but gives no allowable value (feeder.md 2.4 (d)).
SEED_CRITERIA = ("connection", "radius", "cusp", "undercut")
SEED_SOURCES = "feeder.md 2.3 (K6), (K8); 2.4 (a)-(c); S1-2, S1-6, S1-7"


def register(subparsers) -> argparse.ArgumentParser:
    ap = subparsers.add_parser("groove", help="LCSM groove synthesis and feasible lambda2 range",
                               description=summary(__doc__))
    ap.add_argument("--crank-radius", type=float, default=0.040, help="crank radius r [m] (seed 001: 0.040)")
    ap.add_argument("--lambda1", type=float, default=3.5, help="frame length / r (seed 001: 3.5)")
    ap.add_argument("--lambda3", type=float, default=3.0, help="base four-bar rocker length / r (seed 001: 3)")
    ap.add_argument("--lambda2", type=float, default=None,
                    help="conrod length / r of one design (needed for --out; default with --compare-laws: the "
                         "middle of each law's feasible interval)")
    ap.add_argument("--law", default="K0",
                    help=f"law of the forward phase ({', '.join(KNOWN_LAWS)}; seed 001's 1,3 / 1,5 / 2,12 / 3,8 / Ш "
                         "are refused: the seed does not define them)")
    ap.add_argument("--law-return", default=None,
                    help="law of the return phase, or 'base': the kulisa returns as the base four-bar does, the "
                         "roller off the groove's law (default: --law)")
    ap.add_argument("--n", type=float, default=2.0,
                    help="power coefficient n of the power-type law eps = C[1 - (2k)^n] ('power', default 2)")
    ap.add_argument("--k-m", type=float, default=0.4, help="k_m of the P6 stand-in / composite law")
    ap.add_argument("--dwell", type=float, default=0.0, help="dwell [deg], centred on the extended dead centre")
    ap.add_argument("--assembly", type=int, default=1, choices=(1, -1),
                    help="assembly branch of the base four-bar (1 or -1)")
    ap.add_argument("--roller-radius", type=float, default=0.0, help="roller radius [m] for the undercut check")
    ap.add_argument("--max-pressure-angle", type=float, default=math.degrees(groove.DEFAULT_MAX_PRESSURE),
                    help="allowable pressure angle [deg] (default 60 = 90 - mu_min 30 of seed 004)")
    ap.add_argument("--scan", choices=("lambda2",), default=None,
                    help="find the feasible interval of lambda2 (default: no scan)")
    ap.add_argument("--slider-stage", action="store_true",
                    help="the laws are the carriage's: the kulisa follows them through the rocker-slider stage "
                         "(K1)-(K5), seed 001's combined mechanism (default: the laws are the kulisa's)")
    ap.add_argument("--compare-laws", action="store_true", help=f"table of {', '.join(COMPARE)}")
    ap.add_argument("--seed-figures", default=None, metavar="DIR",
                    help="seed 001's statements against ours (slider stage, 80 deg dwell, size and energy) and its "
                         "Figs. 2, 4 and 7 as charts in DIR (slow: about 40 s; default: not written)")
    ap.add_argument("--out", default=None,
                    help="write the profile (x y per line, metres) for --lambda2 (default: not written)")
    ap.add_argument("--points", type=int, default=3600, help="crank-angle grid points")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.set_defaults(func=run)
    return ap


def _fail(msg: str) -> int:
    return fail("groove", msg)


def _kulisa(a, lf, lr, lam2: float) -> groove.KulisaLaw:
    """The kulisa law of lam2: the laws themselves, or with --slider-stage the carriage's laws through (K1)-(K5);
    ``lr`` None: the return stroke is the base four-bar's own."""
    if lr is None:
        if getattr(a, "slider_stage", False):
            raise ValueError("--law-return base and --slider-stage: the base four-bar's return is a kulisa law, "
                             "not a carriage law; give one of them")
        return groove.kulisa_law_base_return(a.lambda1, lam2, a.lambda3, lf, math.radians(a.dwell), a.assembly)
    if getattr(a, "slider_stage", False):
        return groove.combined_kulisa_law(a.lambda1, lam2, a.lambda3, lf, lr, math.radians(a.dwell), a.assembly)[0]
    return groove.kulisa_law(a.lambda1, lam2, a.lambda3, lf, lr, math.radians(a.dwell), a.assembly)


def _return_law(a, lf):
    """The return law: --law-return, the forward law without it, None for 'base' (the base four-bar's)."""
    if a.law_return == "base":
        return None
    return lf if a.law_return is None else get_law(a.law_return, n=a.n, k_m=a.k_m)


def _design(a, law: str, lam2: float):
    lf = get_law(law, n=a.n, k_m=a.k_m)
    lr = _return_law(a, lf)
    kl = _kulisa(a, lf, lr, lam2)
    return kl, groove.synthesize_law(kl, a.lambda1, lam2, a.points,
                                     groove.base_branch(a.lambda1, lam2, a.lambda3, a.assembly))


def _scan(a, law: str) -> dict:
    lf = get_law(law, n=a.n, k_m=a.k_m)
    lr = _return_law(a, lf)
    mp = math.radians(a.max_pressure_angle)

    def failed(l2: float) -> list:
        """Every criterion the groove of l2 violates (groove.CRITERIA names; 'base four-bar' if none exists)."""
        try:
            kl = _kulisa(a, lf, lr, l2)
        except ValueError:
            return ["base four-bar"]
        p = groove.synthesize_law(kl, a.lambda1, l2, a.points, groove.base_branch(a.lambda1, l2, a.lambda3, a.assembly))
        return groove.assess(p, a.crank_radius, a.roller_radius, mp)["all_failed"]

    def ok(l2: float, only=None):
        """The first violated criterion (of ``only`` if given), None if feasible.  Where the connection breaks
        there is no groove, and no other criterion has a value to judge: that is reported as 'connection'
        whatever ``only`` asks (a pressure angle read off a clipped, non-existent groove bounded nothing)."""
        f = failed(l2)
        if f == ["base four-bar"]:
            return f[0]
        if "connection" in f:
            return "connection"
        f = [c for c in f if only is None or c in only]
        return f[0] if f else None

    step = 0.01
    grid = np.arange(0.5, a.lambda1 + a.lambda3 + 1.0, step)
    res = [ok(x) for x in grid]
    flags = np.array([r is None for r in res])
    if not flags.any():
        seed_ok = [x for x, r in zip(grid, res) if r == "pressure" and ok(x, SEED_CRITERIA) is None]
        why = (f"; the seed's criteria alone hold on [{seed_ok[0]:.2f}, {seed_ok[-1]:.2f}] of the grid, where the "
               f"pressure angle exceeds {a.max_pressure_angle:g} deg (--max-pressure-angle)") if seed_ok else ""
        raise ValueError(f"law {law}: no feasible lambda2 for lambda1 = {a.lambda1:g}, lambda3 = {a.lambda3:g} "
                         f"(criteria met nowhere on [{grid[0]:g}, {grid[-1]:g}]){why}")
    runs, i = [], 0
    while i < len(flags):
        if flags[i]:
            j = i
            while j + 1 < len(flags) and flags[j + 1]:
                j += 1
            runs.append((i, j))
            i = j + 1
        else:
            i += 1
    i0, i1 = max(runs, key=lambda r: r[1] - r[0])

    def bisect(good, bad, only=None):
        for _ in range(40):
            mid = 0.5 * (good + bad)
            if ok(mid, only) is None:
                good = mid
            else:
                bad = mid
        return good, ok(bad, only)

    def extent(only):
        """The interval around the feasible run i0..i1 in which the criteria ``only`` alone hold, and what
        ends it on each side (grid walk outward, then bisection)."""
        lo_i, hi_i = i0, i1
        while lo_i > 0 and ok(grid[lo_i - 1], only) is None:
            lo_i -= 1
        while hi_i < len(grid) - 1 and ok(grid[hi_i + 1], only) is None:
            hi_i += 1
        lo_ = bisect(grid[lo_i], grid[lo_i - 1], only) if lo_i > 0 else (grid[0], "scan bound")
        hi_ = bisect(grid[hi_i], grid[hi_i + 1], only) if hi_i < len(grid) - 1 else (grid[-1], "scan bound")
        return [round(float(lo_[0]), 6), round(float(hi_[0]), 6)], lo_[1], hi_[1]

    lo, lo_first = bisect(grid[i0], grid[i0 - 1]) if i0 > 0 else (grid[0], "scan bound")
    hi, hi_first = bisect(grid[i1], grid[i1 + 1]) if i1 < len(grid) - 1 else (grid[-1], "scan bound")
    by_criterion = {}
    for c in groove.CRITERIA:
        if c == "undercut" and not a.roller_radius > 0.0:
            continue                              # not checked without a roller radius
        iv, lc, hc = extent((c,))
        by_criterion[c] = dict(interval=iv, lower_limit=lc, upper_limit=hc)

    def bound_by(end: int, value: float, first: str, names) -> str:
        """The criteria that bound the interval at this end: those whose own interval ends there (to the
        bisection's resolution), or the base four-bar's existence where every one of them runs on to it.  The
        first criterion violated just outside is only a fallback: at the connection break a cusp and the
        pressure angle fail at the same point, and the first of them in the list is not what bounds it."""
        own = {c: by_criterion[c] for c in names if c in by_criterion}
        hits = [c for c, b in own.items() if abs(b["interval"][end] - value) < 1e-5 and
                b[("lower_limit", "upper_limit")[end]] == c]
        if not hits and any(b[("lower_limit", "upper_limit")[end]] == "base four-bar"
                            and abs(b["interval"][end] - value) < 1e-5 for b in own.values()):
            return "base four-bar"
        if "connection" in hits:
            return "connection"       # a cusp appears at the break itself (the seed: the break shows as a sharpening)
        return ", ".join(hits) or first

    seed_iv, seed_lo, seed_hi = extent(SEED_CRITERIA)
    lo, hi = round(float(lo), 6), round(float(hi), 6)
    return dict(law=law, law_return=a.law_return or law, lambda2_min=lo, lambda2_max=hi,
                lower_limit=bound_by(0, lo, lo_first, by_criterion), upper_limit=bound_by(1, hi, hi_first, by_criterion),
                feasible_intervals=len(runs),
                max_pressure_angle_deg=a.max_pressure_angle, roller_radius=a.roller_radius,
                crank_radius=a.crank_radius, lambda1=a.lambda1, lambda3=a.lambda3, dwell_deg=a.dwell,
                scan_step=step,
                criteria="connection |N|<=lambda2 (K6); rho>0 (K8); no cusp inside a stroke; "
                         "curvature radius > roller radius; pressure angle (conrod vs groove, force-based) <= limit",
                bounds_by_criterion=by_criterion,
                seed_criteria=", ".join(SEED_CRITERIA) + " (" + SEED_SOURCES + ")",
                seed_interval=seed_iv, seed_lower_limit=bound_by(0, seed_iv[0], seed_lo, SEED_CRITERIA),
                seed_upper_limit=bound_by(1, seed_iv[1], seed_hi, SEED_CRITERIA))


def _compare(a) -> list[dict]:
    """One row per law: its feasible interval of lambda2 (the scan) and, at one lambda2 -- the one given, else
    the interval's middle (for a law without one, sqrt(lambda1^2 - lambda3^2 + 1)) -- the criteria it fails
    there and the motion's figures."""
    rows = []
    for law in COMPARE:
        row = dict(law=law)
        try:
            s = _scan(a, law)
            row.update(lambda2_min=s["lambda2_min"], lambda2_max=s["lambda2_max"], interval_found=True)
            lam2 = a.lambda2 if a.lambda2 is not None else 0.5 * (s["lambda2_min"] + s["lambda2_max"])
        except ValueError:
            row.update(lambda2_min=math.nan, lambda2_max=math.nan, interval_found=False)
            lam2 = a.lambda2 if a.lambda2 is not None else math.sqrt(a.lambda1 ** 2 - a.lambda3 ** 2 + 1)
        kl, p = _design(a, law, lam2)
        g, g1, g2 = kl(p.phi)
        rep = groove.assess(p, a.crank_radius, a.roller_radius, math.radians(a.max_pressure_angle))
        lf = get_law(law, n=a.n, k_m=a.k_m)
        cv, ca = lf.coefficients()
        row.update(law_params=", ".join(f"{k}={v:g}" for k, v in lf.params) or "none")
        row.update(lambda2=lam2, C_v=cv, C_a=ca, peak_eps_per_w2=float(np.max(np.abs(g2))),
                   rms_eps_per_w2=float(np.sqrt(np.mean(g2 ** 2))),
                   peak_inertia_power_per_Jw3=float(np.max(np.abs(g1 * g2))),
                   dwell_deg=a.dwell, swing_deg=math.degrees(kl.swing),
                   pressure_angle_max_deg=math.degrees(rep["pressure_angle_max"]),
                   failed_at_lambda2=", ".join(rep["all_failed"]) or "none",
                   feasible_at_lambda2=not rep["all_failed"])
        rows.append(row)
    return rows


def _compare_table(rows: list[dict]) -> str:
    """The --compare-laws table as text: the interval column is the scan's, every column right of lambda2 is
    evaluated at that lambda2; floats rounded."""
    keys = ("law", "interval", "lambda2", "failed_at_lambda2", "C_v", "C_a", "peak_eps_per_w2", "rms_eps_per_w2",
            "peak_inertia_power_per_Jw3", "swing_deg", "dwell_deg", "pressure_angle_max_deg")
    lines = [" ".join(f"{k:>18}" for k in keys)]
    for r in rows:
        iv = f"[{r['lambda2_min']:.4f}, {r['lambda2_max']:.4f}]" if r["interval_found"] else "none"
        name = r["law"] if r["law_params"] == "none" else f"{r['law']} {r['law_params']}"
        cells = [name, iv] + [r[k] for k in keys[2:]]
        lines.append(" ".join(f"{c:18.4f}" if isinstance(c, float) else f"{c!s:>18}" for c in cells))
    lines.append("interval: each law's feasible lambda2 (the scan); the columns from lambda2 on are at that lambda2")
    return "\n".join(lines)


def _scan_text(out: dict) -> str:
    """The scan as text: one line per item, each criterion's own interval on a line of its own (no raw dicts)."""
    lines = []
    for k, v in out.items():
        if k == "bounds_by_criterion":
            lines.append("bounds by criterion (each alone):")
            for c, b in v.items():
                lines.append(f"  {c}: [{b['interval'][0]:.6f}, {b['interval'][1]:.6f}] (lower end: "
                             f"{b['lower_limit']}, upper end: {b['upper_limit']})")
        elif k == "seed_interval":
            lines.append(f"{k}: [{v[0]:.6f}, {v[1]:.6f}]")
        else:
            lines.append(f"{k}: {round(v, 6) if isinstance(v, float) else v}")
    return "\n".join(lines)


def run(args) -> int:
    warnings.simplefilter("ignore", RuntimeWarning)
    a = args
    try:
        get_law(a.law, n=a.n, k_m=a.k_m)
        if a.law_return not in (None, "base"):
            get_law(a.law_return, n=a.n, k_m=a.k_m)
        if a.slider_stage and a.law_return == "base":
            return _fail("--law-return base with --slider-stage: the base four-bar's return is a kulisa law, not a "
                         "carriage law; give one of them")
        if not a.crank_radius > 0.0:
            return _fail(f"{typed('crank_radius', a.crank_radius, 'm')} must be > 0")
        if a.seed_figures:
            from pathlib import Path

            from harness.synthesis import groove_seed
            try:                                  # the folder is checked before a minute of work, not after
                Path(a.seed_figures).mkdir(parents=True, exist_ok=True)
            except OSError as e:
                return _fail(f"--seed-figures {a.seed_figures}: cannot make the folder ({e.strerror})")
            print(groove_seed.report(a, a.seed_figures, _scan))
            return 0
        if a.compare_laws:
            rows = _compare(a)
            print(json.dumps(rows) if a.json else _compare_table(rows))
            return 0
        if a.scan == "lambda2":
            out = _scan(a, a.law)
            print(json.dumps(out) if a.json else _scan_text(out))
            return 0
        if a.lambda2 is None:
            return _fail("give --scan lambda2, --compare-laws, or --lambda2 (with --out)")
        kl, p = _design(a, a.law, a.lambda2)
        rep = groove.assess(p, a.crank_radius, a.roller_radius, math.radians(a.max_pressure_angle))
        if rep["failed"] in ("connection", "radius"):
            return _fail(f"lambda2 = {a.lambda2:g}: the groove does not exist ({rep['failed']})")
        if a.out:
            groove.export_points(a.out, p, a.crank_radius, f"law {a.law}, dwell {a.dwell:g} deg, feasibility: {rep['failed'] or 'ok'}")
        rep = {k: v for k, v in rep.items() if k != "all_failed"}
        print(json.dumps(rep) if a.json else "\n".join(f"{k}: {v}" for k, v in rep.items()))
        return 0
    except ValueError as e:
        return _fail(str(e))
