"""Standard run of Inertia (pure model, in-process); writes reference.csv next to this script.

J = 0.01 kg.m2, c_ground = 50 N.m/rad, d_ground = 0.05 N.m.s/rad, phi0 = 0.1 rad; load torque
flange.tau = 0.2*sin(20 t) N.m held over each 1 ms step; t = 0 ... 1 s.
"""
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))
from fmus.physics.elements import InertiaModel, InertiaParams  # noqa: E402


def main(h=1e-3, T=1.0):
    model = InertiaModel(InertiaParams(J=0.01, c_ground=50.0, d_ground=0.05, phi0=0.1))
    x = model.initial_state((0.0,))
    rows = []
    for k in range(int(round(T / h)) + 1):
        t = k * h
        u = (0.2 * math.sin(20.0 * t),)
        rows.append((t, *model.output(t, x, u)))
        x = model.advance(t, h, x, u)
    np.savetxt(HERE / "reference.csv", np.array(rows), delimiter=",", fmt="%.12g",
               header=",".join(("time",) + model.outputs), comments="")


if __name__ == "__main__":
    main()
