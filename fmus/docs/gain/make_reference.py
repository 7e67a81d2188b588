"""Standard run of Gain (pure model, in-process); writes reference.csv next to this script.

Default parameters.  Input u = sin(2*pi*t) sampled every 10 ms and held over each step, t = 0 ... 1 s.
"""
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))
from fmus.physics.testing import GainModel, GainParams  # noqa: E402


def main(h=1e-2, T=1.0):
    model = GainModel(GainParams())
    u = (0.0,)
    x = model.initial_state(u)
    rows = []
    for k in range(int(round(T / h)) + 1):
        t = k * h
        u = (math.sin(2.0 * math.pi * t),)
        rows.append((t, *model.output(t, x, u)))
        x = model.advance(t, h, x, u)
    np.savetxt(HERE / "reference.csv", np.array(rows), delimiter=",", fmt="%.12g",
               header=",".join(("time",) + model.outputs), comments="")


if __name__ == "__main__":
    main()
