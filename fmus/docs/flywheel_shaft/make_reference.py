"""Standard run of FlywheelShaft (pure physics, in-process); writes reference.csv next to this script.

Default parameters (fidelity 1, 100 rpm).  Inputs held over each 1 ms step: belt torque pulley.tau = 60 N.m,
mechanism reaction crank.tau = -60 - 40*sin(2*w0*t) N.m (two load pulses per revolution), aux.tau = 0.
Rows: outputs at t = 0 ... 0.5 s.
"""
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))
from fmus.physics.flywheel_shaft import FlywheelShaftModel, FlywheelShaftParams  # noqa: E402


def torques(p, t):
    return (60.0, -60.0 - 40.0 * math.sin(2.0 * p.w0 * t), 0.0)


def main(h=1e-3, T=0.5):
    model = FlywheelShaftModel(FlywheelShaftParams())
    x = model.initial_state(torques(model.p, 0.0))
    rows = []
    for k in range(int(round(T / h)) + 1):
        t = k * h
        u = torques(model.p, t)
        rows.append((t, *model.output(t, x, u)))
        x = model.advance(t, h, x, u)
    np.savetxt(HERE / "reference.csv", np.array(rows), delimiter=",", fmt="%.12g",
               header=",".join(("time",) + model.outputs), comments="")


if __name__ == "__main__":
    main()
