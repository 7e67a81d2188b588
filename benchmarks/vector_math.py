"""numpy's float64 ufuncs against Python's ``math``, bit for bit, on this machine (``python -m benchmarks.vector_math``).

A batch of variants (:mod:`harness.run.batch`) must give each variant the bits its own FMU gives, and the FMU computes
with ``math``.  This measures, per function the physics uses, on how many arguments numpy's ufunc gives other bits
than ``math``: random samples over the ranges the physics uses plus edge values (zeros of both signs, infinities,
NaN, subnormals, the overflow edges), in contiguous arrays, strided views and arrays of 1 to 17 elements, and the
largest difference in ulp.  :data:`fmus.physics.mathns.VECTOR` takes numpy's ufunc only where it found none (its
docstring states the numbers measured on the project's machine) and checks that again on a sample in every process
(:meth:`~fmus.physics.mathns.Vector.check`): numpy's loops depend on its build and the processor.
"""
from __future__ import annotations

import math
import operator
import sys

import numpy as np

N = 200_000
EDGES = [0.0, -0.0, 1.0, -1.0, math.inf, -math.inf, math.nan, 5e-324, -5e-324, 2.2250738585072014e-308, 1e-300,
         1e300, -1e300, 0.5, -0.5, math.pi, -math.pi, math.pi / 2]


def _safe(f):
    def g(*args):
        try:
            r = f(*args)
            return math.nan if isinstance(r, complex) else r    # a negative base to a fractional power
        except ValueError:
            return math.nan
        except (OverflowError, ZeroDivisionError):
            return math.inf
    return g


def samples(rng) -> dict:
    """name -> (numpy's ufunc, math's function, argument tuples)."""
    def u(a, b):
        return rng.uniform(a, b, N)

    def g(s):
        return rng.normal(0.0, s, N)

    def pairs():
        return np.repeat(EDGES, len(EDGES)), np.tile(EDGES, len(EDGES))

    edges = np.array(EDGES)
    return {
        "exp": (np.exp, math.exp, [(u(-745.2, 709.8),), (u(-50.0, 1.0),), (g(1e-3),), (u(-1.0, 1.0),),
                                   (np.concatenate([edges, [709.78, 709.79, -745.13, -745.14, -708.4]]),)]),
        "tanh": (np.tanh, math.tanh, [(u(-30.0, 30.0),), (u(-1e4, 1e4),), (g(1e-3),), (g(1e-9),),
                                      (np.concatenate([edges, [19.06, -19.06, 22.0]]),)]),
        "acos": (np.arccos, math.acos, [(u(-1.0, 1.0),), (1.0 - np.abs(g(1e-6)),), (-1.0 + np.abs(g(1e-6)),),
                                        (np.concatenate([edges, [1.0 - 1e-16, -1.0 + 1e-16, 1.0000001]]),)]),
        "sin": (np.sin, math.sin, [(u(-40.0, 40.0),), (u(-1e4, 1e4),), (g(1e-3),), (u(-1e6, 1e6),),
                                   (np.concatenate([edges, [1e22, 1e10, 1e-8]]),)]),
        "cos": (np.cos, math.cos, [(u(-40.0, 40.0),), (u(-1e4, 1e4),), (g(1e-3),), (u(-1e6, 1e6),),
                                   (np.concatenate([edges, [1e22, 1e10, 1e-8]]),)]),
        "atan2": (np.arctan2, math.atan2, [(g(1.0), g(1.0)), (g(1e-3), g(1.0)), (g(1.0), g(1e-6)),
                                           (u(-0.5, 0.5), u(0.01, 0.3)), pairs()]),
        "pow": (np.power, operator.pow, [(u(0.0, 1e-3), np.full(N, 1.5)), (u(0.0, 1e-3), np.full(N, 0.5)),
                                         (u(1e-9, 1e-4), np.full(N, 2.5)), (u(0.0, 1e-2), u(0.5, 3.0)),
                                         (u(0.0, 100.0), u(-3.0, 3.0)), pairs()]),
        "hypot": (np.hypot, math.hypot, [(g(1.0), g(1.0)), (g(1e-3), g(1.0)), (g(1e200), g(1e200)),
                                         (g(1e-160), g(1e-160)), pairs()]),
        "hypot as abs(complex)": (np.hypot, lambda x, y: abs(complex(x, y)),
                                  [(g(1.0), g(1.0)), (g(1e-3), g(1.0)), (g(1e200), g(1e200)), pairs()]),
    }


def _differ(got, want) -> np.ndarray:
    got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    return (got.view(np.int64) != want.view(np.int64)) & ~(np.isnan(got) & np.isnan(want))


def measure(seed: int = 2026) -> list[dict]:
    """One row per function: arguments, how many differ (whole contiguous arrays), the largest difference in ulp,
    and how many differ in strided views and in arrays of 1 to 17 elements."""
    rows = []
    with np.errstate(all="ignore"):
        for name, (uf, mf, cases) in samples(np.random.default_rng(seed)).items():
            f = _safe(mf)
            row = {"function": name, "arguments": 0, "differ": 0, "max_ulp": 0, "strided": 0, "short": 0}
            for args in cases:
                want = np.array([f(*v) for v in zip(*(a.tolist() for a in args))])
                got = uf(*args)
                bad = _differ(got, want)
                row["arguments"] += len(want)
                row["differ"] += int(bad.sum())
                fin = bad & np.isfinite(got) & np.isfinite(want)
                if fin.any():
                    ulp = np.abs(got[fin].view(np.int64) - want[fin].view(np.int64)).max()
                    row["max_ulp"] = max(row["max_ulp"], int(ulp))
                row["strided"] += int(_differ(uf(*(a[::2] for a in args)), want[::2]).sum())
                for n in (1, 3, 8, 17):
                    row["short"] += int(_differ(uf(*(a[:n].copy() for a in args)), want[:n]).sum())
            row["share_pct"] = 100.0 * row["differ"] / row["arguments"]
            rows.append(row)
    return rows


def main() -> int:
    print(f"numpy {np.__version__}, Python {sys.version.split()[0]}; numpy's ufunc against math, bit for bit")
    print(f"{'function':22s} {'arguments':>9s} {'differ':>7s} {'share':>8s} {'max ulp':>7s} {'strided':>7s} "
          f"{'short':>5s}")
    for r in measure():
        print(f"{r['function']:22s} {r['arguments']:9d} {r['differ']:7d} {r['share_pct']:7.3f}% {r['max_ulp']:7d} "
              f"{r['strided']:7d} {r['short']:5d}")
    from fmus.physics.mathns import VECTOR

    print(f"fmus.physics.mathns.VECTOR here: {VECTOR.check()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
