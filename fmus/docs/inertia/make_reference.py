"""Standard run of Inertia (pure model, in-process); writes reference.csv next to this script.

J = 0.01 kg.m2, c_ground = 50 N.m/rad, d_ground = 0.05 N.m.s/rad, phi0 = 0.1 rad; load torque
flange.tau = 0.2*sin(20 t) N.m held over each 1 ms step; t = 0 ... 1 s.
"""
from __future__ import annotations

import math

from fmus.physics.elements import InertiaModel, InertiaParams
from fmus.reference import standard_run, write_reference


def main(h=1e-3, T=1.0):
    model = InertiaModel(InertiaParams(J=0.01, c_ground=50.0, d_ground=0.05, phi0=0.1))
    rows = standard_run(model, lambda k, t: (0.2 * math.sin(20.0 * t),), h, int(round(T / h)),
                        x0=model.initial_state((0.0,)))
    write_reference(__file__, model, rows)


if __name__ == "__main__":
    main()
