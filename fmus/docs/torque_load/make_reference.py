"""Standard run of TorqueLoad (pure physics, in-process); writes reference.csv next to this script.

Parameters T_const = 0.5 N.m, T_coulomb = 1 N.m, w_reg = 0.05 rad/s, d = 0.05 N.m.s/rad, c = 2 N.m/rad,
phi_ref = 0 (the other defaults).  Input: flange swinging phi = sin(2*pi*t), w = 2*pi*cos(2*pi*t), sampled
every 10 ms, t = 0 ... 2 s.
"""
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))
from fmus.physics.loads import TorqueLoadModel, TorqueLoadParams  # noqa: E402

PARAMS = dict(T_const=0.5, T_coulomb=1.0, w_reg=0.05, d=0.05, c=2.0, phi_ref=0.0)


def main(h=1e-2, T=2.0):
    model = TorqueLoadModel(TorqueLoadParams(**PARAMS))
    rows = []
    for k in range(int(round(T / h)) + 1):
        t = k * h
        u = (math.sin(2.0 * math.pi * t), 2.0 * math.pi * math.cos(2.0 * math.pi * t))
        rows.append((t, *model.output(t, (), u)))
    np.savetxt(HERE / "reference.csv", np.array(rows), delimiter=",", fmt="%.12g",
               header=",".join(("time",) + model.outputs), comments="")


if __name__ == "__main__":
    main()
