"""Standard run of JamesDifferential (default parameters) -> reference.csv, from the pure physics model.

Ring and carrier swing like the rocker and the cam follower of paper B (one 1 s cycle); the sun carries
a load torque.  Inputs are held over each 1 ms step, angles advance with the held speeds."""
from __future__ import annotations

import math

from fmus.physics.differential import JamesDifferentialModel, JamesDifferentialParams
from fmus.reference import standard_run, write_reference


def main():
    m = JamesDifferentialModel(JamesDifferentialParams())
    h, n = 1e-3, 1000
    angles, speeds = [0.0, 0.0], [0.0, 0.0]   # ring, carrier: angles advanced with the held speeds

    def inputs(k, t):
        if k > 0:
            angles[0], angles[1] = angles[0] + speeds[0] * h, angles[1] + speeds[1] * h
        speeds[:] = [-0.5 * math.pi * 2 * math.sin(2 * math.pi * t),   # ring (rocker), paper sign: negative sense
                     0.35 * math.pi * 2 * math.sin(2 * math.pi * t)]   # carrier (cam follower)
        return (angles[0], speeds[0], angles[1], speeds[1], -20.0 - 10.0 * math.sin(4 * math.pi * t))

    write_reference(__file__, m, standard_run(m, inputs, h, n))


if __name__ == "__main__":
    main()
