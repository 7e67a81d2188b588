"""Standard run of FlywheelShaft (pure physics, in-process); writes reference.csv next to this script.

Default parameters (fidelity 1, 100 rpm).  Inputs held over each 1 ms step: belt torque pulley.tau = 60 N.m,
mechanism reaction crank.tau = -60 - 40*sin(2*w0*t) N.m (two load pulses per revolution), aux.tau = 0.
Rows: outputs at t = 0 ... 0.5 s.
"""
from __future__ import annotations

import math

from fmus.physics.flywheel_shaft import FlywheelShaftModel, FlywheelShaftParams
from fmus.reference import standard_run, write_reference


def torques(p, t):
    return (60.0, -60.0 - 40.0 * math.sin(2.0 * p.w0 * t), 0.0)


def main(h=1e-3, T=0.5):
    model = FlywheelShaftModel(FlywheelShaftParams())
    write_reference(__file__, model, standard_run(model, lambda k, t: torques(model.p, t), h, int(round(T / h))))


if __name__ == "__main__":
    main()
