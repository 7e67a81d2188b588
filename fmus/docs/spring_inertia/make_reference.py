"""Standard run of SpringInertia (pure model, in-process); writes reference.csv next to this script.

Default parameters (J = 0.01 kg.m2, c = 100 N.m/rad, d = 0); the drive turns at 2 rad/s from angle 0, its
angle and speed held over each 1 ms step (the benchmark holds every input); t = 0 ... 1 s.
"""
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))
from fmus.physics.elements import SpringInertiaModel, SpringInertiaParams  # noqa: E402


def main(h=1e-3, T=1.0, w=2.0):
    model = SpringInertiaModel(SpringInertiaParams())
    x = model.initial_state((0.0, w))
    rows = []
    for k in range(int(round(T / h)) + 1):
        t = k * h
        u = (w * t, w)
        rows.append((t, *model.output(t, x, u)))
        x = model.advance(t, h, x, u)
    np.savetxt(HERE / "reference.csv", np.array(rows), delimiter=",", fmt="%.12g",
               header=",".join(("time",) + model.outputs), comments="")


if __name__ == "__main__":
    main()
