"""Sampled sweeps and the tolerance study: the points of a spec's ``sample:`` section (:func:`sample_points`) and
the spread of each quantity of interest over them (:func:`spread`).

``sample:`` draws ``n`` points by Latin hypercube sampling (``method: lhs``, the default) or plainly at random
(``method: random``), with ``seed`` (default 0), either uniformly over ``ranges`` (``name: [lo, hi]``) or from
stated ``distributions``, a parameter's tolerance::

    sample:
      n: 200                                   # or: sweep ... --sample 200
      seed: 1
      distributions:
        flywheel.J_flywheel: {normal: [8.0, 0.16]}           # mean, standard deviation
        motor.c_belt: {uniform: [3.6e5, 4.4e5]}              # lowest, highest
        bed.m_T: {triangular: [240.0, 250.0, 265.0]}         # lowest, most likely, highest
        fourbar.coupler_stiffness: {lognormal: [5.0e7, 0.1]} # median, standard deviation of its logarithm
        cam.clearance: {normal: [1.0e-5, 2.0e-6], within: [5.0e-6, 1.5e-5]}   # cut to the interval

Each distribution maps the sampler's unit numbers through its inverse distribution function (scipy.stats), so a
Latin hypercube keeps its strata in every parameter.  A tolerance study (``sweep SYSTEM --grid SPEC --sample N``
with ``distributions``) reports, beside every point, the spread of each quantity of interest over the points that
ran: their count, mean, standard deviation, least and largest value and the 5th, 50th and 95th percentiles
(``OUT.spread.csv`` and the command's table).
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from harness.studies.sweep_checks import SweepError

KINDS = {"normal": 2, "uniform": 2, "triangular": 3, "lognormal": 2}
STATISTICS = ("points", "mean", "std", "min", "p5", "p50", "p95", "max")


def _numbers(value, count: int, key: str) -> list[float]:
    ok = isinstance(value, (list, tuple)) and len(value) == count and not any(isinstance(x, bool) for x in value)
    try:
        out = [float(x) for x in value] if ok else []
    except (TypeError, ValueError):
        out = []
    if not out or not all(map(math.isfinite, out)):
        raise SweepError(f"{key}: {value!r} must be a list of {count} finite numbers")
    return out


def parse_distribution(name: str, spec, source: str) -> dict:
    """One parameter's distribution (module docstring), checked: ``{kind, args, within}``."""
    key = f"{source}: sample.distributions.{name}"
    if not isinstance(spec, dict) or not (set(spec) - {"within"}) or len(set(spec) - {"within"}) != 1:
        raise SweepError(f"{key}: give one of {', '.join(f'{{{k}: [...]}}' for k in KINDS)} "
                         f"(optionally with within: [lo, hi]), not {spec!r}")
    kind = next(k for k in spec if k != "within")
    if kind not in KINDS:
        raise SweepError(f"{key}: unknown distribution {kind!r}; known: {', '.join(KINDS)}")
    args = _numbers(spec[kind], KINDS[kind], f"{key}.{kind}")
    if kind in ("normal", "lognormal") and not args[1] > 0.0:
        raise SweepError(f"{key}.{kind}: the spread {args[1]!r} must be > 0")
    if kind == "lognormal" and not args[0] > 0.0:
        raise SweepError(f"{key}.lognormal: the median {args[0]!r} must be > 0")
    if kind == "uniform" and not args[0] < args[1]:
        raise SweepError(f"{key}.uniform: {args!r} must be [lo, hi] with lo < hi")
    if kind == "triangular" and not args[0] <= args[1] <= args[2] and args[0] < args[2]:
        raise SweepError(f"{key}.triangular: {args!r} must be [lo, mode, hi] with lo <= mode <= hi, lo < hi")
    within = None
    if "within" in spec:
        within = _numbers(spec["within"], 2, f"{key}.within")
        if not within[0] < within[1]:
            raise SweepError(f"{key}.within: {within!r} must be [lo, hi] with lo < hi")
    return {"kind": kind, "args": args, "within": within}


def _inverse(d: dict, u: np.ndarray) -> np.ndarray:
    """The distribution's value at the unit numbers ``u`` (its inverse distribution function; ``within`` cuts it
    to an interval: the unit numbers are mapped onto that interval's share of the distribution)."""
    from scipy import stats

    kind, a = d["kind"], d["args"]
    dist = {"normal": lambda: stats.norm(a[0], a[1]),
            "uniform": lambda: stats.uniform(a[0], a[1] - a[0]),
            "triangular": lambda: stats.triang((a[1] - a[0]) / (a[2] - a[0]), a[0], a[2] - a[0]),
            "lognormal": lambda: stats.lognorm(a[1], 0.0, a[0])}[kind]()
    if d["within"] is not None:
        lo, hi = dist.cdf(d["within"][0]), dist.cdf(d["within"][1])
        if not hi > lo:
            raise SweepError(f"sample.distributions: {kind} {a!r} has no probability within {d['within']!r}")
        u = lo + u * (hi - lo)
    return dist.ppf(u)


def sample_points(s, source: str, n: int | None = None) -> tuple[list[str], list[dict]]:
    """(names, points) of a ``sample:`` section (module docstring); ``n`` (``--sample N``) in place of its own."""
    if not isinstance(s, dict) or ("ranges" in s) == ("distributions" in s):
        raise SweepError(f"{source}: sample: needs 'n' and one of 'ranges: {{name: [lo, hi], ...}}' or "
                         f"'distributions: {{name: {{normal: [mean, sd]}}, ...}}'")
    count = s.get("n") if n is None else n
    if count is None:
        raise SweepError(f"{source}: sample: needs 'n' (or --sample N)")
    if isinstance(count, bool) or not (isinstance(count, int) and count > 0):
        raise SweepError(f"{source}: sample.n: {count!r} must be a positive integer")
    method = s.get("method", "lhs")
    if method not in ("lhs", "random"):
        raise SweepError(f"{source}: sample.method: {method!r} is not supported (lhs, random)")
    seed = s.get("seed", 0)
    if "ranges" in s:
        if not isinstance(s["ranges"], dict) or not s["ranges"]:
            raise SweepError(f"{source}: sample: needs 'n' and 'ranges: {{name: [lo, hi], ...}}'")
        dists = {}
        for name, r in s["ranges"].items():
            try:
                ok = (isinstance(r, (list, tuple)) and len(r) == 2 and not any(isinstance(x, bool) for x in r)
                      and float(r[0]) < float(r[1]))
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise SweepError(f"{source}: sample.ranges.{name}: {r!r} must be [lo, hi] with lo < hi")
            dists[name] = None
    else:
        if not isinstance(s["distributions"], dict) or not s["distributions"]:
            raise SweepError(f"{source}: sample.distributions: give at least one parameter's distribution")
        dists = {name: parse_distribution(name, d, source) for name, d in s["distributions"].items()}
    names = list(dists)
    unit = _unit_sample(len(names), int(count), seed, method)
    if "ranges" in s:
        from scipy.stats import qmc

        lo = np.array([s["ranges"][nm][0] for nm in names], float)
        hi = np.array([s["ranges"][nm][1] for nm in names], float)
        values = qmc.scale(unit, lo, hi)
    else:
        values = np.column_stack([_inverse(dists[nm], unit[:, j]) for j, nm in enumerate(names)])
    return names, [dict(zip(names, map(float, row))) for row in values]


def _unit_sample(d: int, n: int, seed, method: str) -> np.ndarray:
    if method == "lhs":
        from scipy.stats import qmc

        return qmc.LatinHypercube(d=d, seed=seed).random(n)
    return np.random.default_rng(seed).random((n, d))


def spread(df: pd.DataFrame, outputs) -> pd.DataFrame:
    """Per quantity of interest (``outputs``: their names): the points that ran without error and have a finite
    value (``points``), its mean, standard deviation (n - 1), least and largest value and the 5th, 50th and 95th
    percentiles; NaN where no point has a value."""
    ok = df["error"].fillna("").astype(str) == "" if "error" in df.columns else pd.Series(True, index=df.index)
    rows = []
    for name in outputs:
        x = pd.to_numeric(df.loc[ok, name], errors="coerce").to_numpy(dtype=float)
        x = x[np.isfinite(x)]
        if not x.size:
            rows.append({"quantity": name, **{k: (0 if k == "points" else math.nan) for k in STATISTICS}})
            continue
        p5, p50, p95 = np.percentile(x, [5.0, 50.0, 95.0])
        rows.append({"quantity": name, "points": int(x.size), "mean": float(np.mean(x)),
                     "std": float(np.std(x, ddof=1)) if x.size > 1 else math.nan, "min": float(np.min(x)),
                     "p5": float(p5), "p50": float(p50), "p95": float(p95), "max": float(np.max(x))})
    return pd.DataFrame(rows).set_index("quantity")


def spread_table(table: pd.DataFrame) -> str:
    """The spread as text, one line per quantity."""
    head = ["quantity", *STATISTICS]
    cells = [[q, *(f"{int(v)}" if k == "points" else (f"{v:.5g}" if math.isfinite(v) else "-")
                   for k, v in row.items())] for q, row in table.iterrows()]
    width = [max(len(str(c[i])) for c in cells + [head]) for i in range(len(head))]
    lines = ["  ".join(h.ljust(w) if i == 0 else h.rjust(w) for i, (h, w) in enumerate(zip(head, width)))]
    lines += ["  ".join(x.ljust(w) if i == 0 else x.rjust(w) for i, (x, w) in enumerate(zip(c, width)))
              for c in cells]
    return "\n".join(lines)


def spread_path(out) -> "Path":
    """Where a tolerance study's spread goes beside its result file: ``x.csv`` -> ``x.spread.csv``."""
    from pathlib import Path

    out = Path(out)
    return out.with_name(f"{out.stem}.spread.csv")


__all__ = ["sample_points", "parse_distribution", "spread", "spread_table", "spread_path", "KINDS", "STATISTICS"]
