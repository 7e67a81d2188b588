"""Standard run of the FourBar physics model -> reference.csv (run: python fmus/docs/fourbar/make_reference.py).

Fidelity 2 with the default (seed 004 x 0.1 m) linkage and a 20 um clearance, the crank driven at a constant
15 rad/s from crank.phi = 0.3 rad, a constant load torque rocker.tau = -0.5 N.m, communication step 1 ms, 0.5 s.
"""
from __future__ import annotations

import csv
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))

from fmus.physics.fourbar import FourBarModel, FourBarParams  # noqa: E402


def main() -> None:
    model = FourBarModel(FourBarParams(fidelity=2, clearance=2e-5))
    w, tau, phi0, h, n = 15.0, -0.5, 0.3, 1e-3, 500
    u = [phi0, w, tau]
    x = model.initial_state(u)
    rows = [[0.0, *model.output(0.0, x, u)]]
    for k in range(n):
        x = model.advance(k * h, h, x, u)
        u = [phi0 + w * (k + 1) * h, w, tau]
        rows.append([(k + 1) * h, *model.output((k + 1) * h, x, u)])
    with open(HERE / "reference.csv", "w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(["time", *FourBarModel.outputs])
        out.writerows([[f"{v:.12g}" for v in row] for row in rows])


if __name__ == "__main__":
    main()
