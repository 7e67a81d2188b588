"""Bit-for-bit guard of the master: every system x master x extrapolation (and step control) over a short run.

    python -m benchmarks.baseline record FILE      # store the results
    python -m benchmarks.baseline check FILE       # run again and compare bit for bit; exit 1 on a difference

A behaviour-preserving change (a restructure, a faster loop) must leave every one of these runs identical.
The runs are short (a few hundred steps each) so the guard takes about a minute.
"""
from __future__ import annotations

import argparse
import pickle
import sys
import warnings

import numpy as np

SYSTEMS = ("two_inertia", "feeder_gto52", "bed_drive", "spine_knife", "proof_press")
MASTERS = ("jacobi", "jacobi-sampled", "gauss-seidel", "iterative")
ORDERS = (0, 1, 2)
STEP_CONTROLS = ("richardson", "ecco")


def cases():
    for system in SYSTEMS:
        for master in MASTERS:
            for order in ORDERS:
                yield system, master, order, None
        for control in STEP_CONTROLS:
            yield system, "jacobi", 1, control


def run_all() -> dict:
    from harness import load, simulate

    out = {}
    for system, master, order, control in cases():
        s = load(system)
        stop = 200 * s.experiment.step
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            df = simulate(s, stop_time=stop, master=master, extrapolation=order, step_control=control,
                          tolerance=1e-4 if control else None)
        out[(system, master, order, control)] = (df.index.to_numpy(), df.to_numpy(), tuple(df.columns),
                                                 df.attrs.get("complete", True))
    return out


def _deviation(old, new) -> str:
    """How far a differing run moved: the largest change of a value as a share of its column's range."""
    (t0, v0, c0, ok0), (t1, v1, c1, ok1) = old, new
    if c0 != c1 or ok0 != ok1 or v0.shape != v1.shape or not np.array_equal(t0, t1):
        return "(other columns, times or completion)"
    v0, v1 = v0.astype(float), v1.astype(float)
    span = np.nanmax(v0, axis=0) - np.nanmin(v0, axis=0)
    share = np.nanmax(np.abs(v1 - v0), axis=0) / np.where(span > 0, span, 1.0)
    k = int(np.nanargmax(share))
    return f"largest change {share[k]:.2g} of the range of {c0[k]}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("action", choices=("record", "check"))
    ap.add_argument("file")
    a = ap.parse_args(argv)
    runs = run_all()
    if a.action == "record":
        with open(a.file, "wb") as f:
            pickle.dump(runs, f)
        print(f"recorded {len(runs)} runs in {a.file}")
        return 0
    with open(a.file, "rb") as f:
        ref = pickle.load(f)
    bad = []
    for key, (t0, v0, c0, ok0) in ref.items():
        t1, v1, c1, ok1 = runs[key]
        if c0 != c1 or ok0 != ok1 or t0.shape != t1.shape or v0.shape != v1.shape or not (
                np.array_equal(t0, t1) and np.array_equal(v0, v1, equal_nan=True)):
            bad.append(key)
    for key in bad:
        print("DIFFERS:", key, _deviation(ref[key], runs[key]))
    print(f"{len(ref) - len(bad)} of {len(ref)} runs identical bit for bit")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
