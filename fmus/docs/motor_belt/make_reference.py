"""Standard run of MotorBelt (pure physics, in-process); writes reference.csv next to this script.

Default parameters (fidelity 1).  The driven pulley is prescribed: speed w_n*(1 - 0.02*sin(2*pi*5*t)) with
w_n = w_rated*d_motor_pulley/d_driven_pulley, held over each 1 ms communication step, angle advanced
exactly as the model extrapolates it (phi += w*h), starting at 0.  Rows: outputs at each step start after
the inputs of that step are set, t = 0 ... 0.5 s.
"""
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))
from fmus.physics.motor_belt import MotorBeltModel, MotorBeltParams  # noqa: E402


def pulley_speed(p, t):
    return p.w_rated * p.d_motor_pulley / p.d_driven_pulley * (1.0 - 0.02 * math.sin(2.0 * math.pi * 5.0 * t))


def main(h=1e-3, T=0.5):
    model = MotorBeltModel(MotorBeltParams())
    phi = 0.0
    x = model.initial_state((phi, pulley_speed(model.p, 0.0)))
    rows = []
    for k in range(int(round(T / h)) + 1):
        t = k * h
        u = (phi, pulley_speed(model.p, t))
        rows.append((t, *model.output(t, x, u)))
        x = model.advance(t, h, x, u)
        phi += u[1] * h
    np.savetxt(HERE / "reference.csv", np.array(rows), delimiter=",", fmt="%.12g",
               header=",".join(("time",) + model.outputs), comments="")


if __name__ == "__main__":
    main()
