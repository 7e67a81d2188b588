"""Standard run of RackBed (pure physics, in-process); writes reference.csv next to this script.

Default parameters (fidelity 1).  The pinion is prescribed so that the bed makes one cycle 0 -> 0.8 m -> 0
in 1 s: pinion speed (0.4/R)*(2*pi)*sin(2*pi*(t + h/2)) held over each 1 ms step, angle advanced exactly as
the model extrapolates it (phi += w*h), starting at 0.  The forward stroke crosses the printing zone
[0.1, 0.7] m.  Rows: outputs at each step start after the inputs of that step are set, t = 0 ... 1 s.
"""
from __future__ import annotations

import math

from fmus.physics.rack_bed import RackBedModel, RackBedParams
from fmus.reference import standard_run, write_reference


def main(h=1e-3, T=1.0):
    model = RackBedModel(RackBedParams())
    amp, om = 0.4 / model.R, 2.0 * math.pi / T
    held = [0.0, 0.0]   # angle, speed: the angle advanced exactly as the model extrapolates it

    def inputs(k, t):
        held[0] += held[1] * h
        held[1] = amp * om * math.sin(om * (t + 0.5 * h))
        return tuple(held)

    rows = standard_run(model, inputs, h, int(round(T / h)),
                        x0=model.initial_state((0.0, amp * om * math.sin(om * 0.5 * h))))
    write_reference(__file__, model, rows)


if __name__ == "__main__":
    main()
