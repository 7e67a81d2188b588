"""Standard run of TorqueLoad (pure physics, in-process); writes reference.csv next to this script.

Parameters T_const = 0.5 N.m, T_coulomb = 1 N.m, w_reg = 0.05 rad/s, d = 0.05 N.m.s/rad, c = 2 N.m/rad,
phi_ref = 0 (the other defaults).  Input: flange swinging phi = sin(2*pi*t), w = 2*pi*cos(2*pi*t), sampled
every 10 ms, t = 0 ... 2 s.
"""
from __future__ import annotations

import math

from fmus.physics.loads import TorqueLoadModel, TorqueLoadParams
from fmus.reference import standard_run, write_reference


PARAMS = dict(T_const=0.5, T_coulomb=1.0, w_reg=0.05, d=0.05, c=2.0, phi_ref=0.0)


def main(h=1e-2, T=2.0):
    model = TorqueLoadModel(TorqueLoadParams(**PARAMS))
    u = lambda k, t: (math.sin(2.0 * math.pi * t), 2.0 * math.pi * math.cos(2.0 * math.pi * t))  # noqa: E731
    write_reference(__file__, model, standard_run(model, u, h, int(round(T / h))))


if __name__ == "__main__":
    main()
