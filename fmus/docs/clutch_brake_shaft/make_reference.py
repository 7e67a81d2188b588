"""Standard run of ClutchBrakeShaft (pure physics, in-process); writes reference.csv next to this script.

FlywheelShaft's standard run (fidelity 1, 100 rpm; belt torque pulley.tau = 60 N.m, mechanism reaction
crank.tau = -60 - 40*sin(2*w0*t) N.m, aux.tau = 0, held over each 1 ms step) with a clutch-brake of 100 N.m
and 30 ms response, commanded from t = 0.2 s on: the clutch opens at 0.23 s and the crank side stops.
Rows: outputs at t = 0 ... 0.5 s.
"""
from __future__ import annotations

import math

from fmus.physics.clutch_brake import ClutchBrakeShaftModel, ClutchBrakeShaftParams
from fmus.reference import standard_run, write_reference


def inputs(p, t):
    return (60.0, -60.0 - 40.0 * math.sin(2.0 * p.w0 * t), 0.0, 1.0 if t >= 0.2 - 1e-12 else 0.0)


def main(h=1e-3, T=0.5):
    model = ClutchBrakeShaftModel(ClutchBrakeShaftParams(cb_torque=100.0, cb_delay=0.03))
    write_reference(__file__, model, standard_run(model, lambda k, t: inputs(model.p, t), h, int(round(T / h))))


if __name__ == "__main__":
    main()
