"""Standard run of MotorBelt (pure physics, in-process); writes reference.csv next to this script.

Default parameters (fidelity 1).  The driven pulley is prescribed: speed w_n*(1 - 0.02*sin(2*pi*5*t)) with
w_n = w_rated*d_motor_pulley/d_driven_pulley, held over each 1 ms communication step, angle advanced
exactly as the model extrapolates it (phi += w*h), starting at 0.  The supply steps from its rated frequency to
90 % of it at t = 0.25 s (a speed change); the brake stays released.  Rows: outputs at each step start after
the inputs of that step are set, t = 0 ... 0.5 s.
"""
from __future__ import annotations

import math

from fmus.physics.motor_belt import MotorBeltModel, MotorBeltParams
from fmus.reference import standard_run, write_reference


def pulley_speed(p, t):
    return p.w_rated * p.d_motor_pulley / p.d_driven_pulley * (1.0 - 0.02 * math.sin(2.0 * math.pi * 5.0 * t))


def supply(t):
    return 1.0 if t < 0.25 else 0.9


def main(h=1e-3, T=0.5):
    model = MotorBeltModel(MotorBeltParams())
    held = [0.0, 0.0]   # angle, speed: the angle advanced exactly as the model extrapolates it

    def inputs(k, t):
        held[0] += held[1] * h
        held[1] = pulley_speed(model.p, t)
        return (*held, supply(t), 0.0)

    rows = standard_run(model, inputs, h, int(round(T / h)),
                        x0=model.initial_state((0.0, pulley_speed(model.p, 0.0), supply(0.0), 0.0)))
    write_reference(__file__, model, rows)


if __name__ == "__main__":
    main()
