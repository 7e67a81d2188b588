"""Standard run of ParallelShafts (pure physics, in-process); writes reference.csv next to this script.

Default parameters (fidelity 1, eq. (10) with the driven shaft and the belt, 600 rpm).  Inputs held over each
0.1 ms step: drive torque pulley.tau = 5 N.m, knife reaction crank.tau = -5 - 5*sin(w0*t) N.m (one load pulse
per revolution), aux.tau = 0.  Rows: outputs at t = 0 ... 0.1 s.
"""
from __future__ import annotations

import math

from fmus.physics.parallel_shafts import ParallelShaftsModel, ParallelShaftsParams
from fmus.reference import standard_run, write_reference


def torques(p, t):
    return (5.0, -5.0 - 5.0 * math.sin(p.w0 * t), 0.0)


def main(h=1e-4, T=0.1):
    model = ParallelShaftsModel(ParallelShaftsParams())
    write_reference(__file__, model, standard_run(model, lambda k, t: torques(model.p, t), h, int(round(T / h))))


if __name__ == "__main__":
    main()
