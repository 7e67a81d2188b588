"""Standard run of RackBed (pure physics, in-process); writes reference.csv next to this script.

Default parameters (fidelity 1).  The pinion is prescribed so that the bed makes one cycle 0 -> 0.8 m -> 0
in 1 s: pinion speed (0.4/R)*(2*pi)*sin(2*pi*(t + h/2)) held over each 1 ms step, angle advanced exactly as
the model extrapolates it (phi += w*h), starting at 0.  The forward stroke crosses the printing zone
[0.1, 0.7] m.  Rows: outputs at each step start after the inputs of that step are set, t = 0 ... 1 s.
"""
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))
from fmus.physics.rack_bed import RackBedModel, RackBedParams  # noqa: E402


def main(h=1e-3, T=1.0):
    model = RackBedModel(RackBedParams())
    amp, om = 0.4 / model.R, 2.0 * math.pi / T
    phi = 0.0
    x = model.initial_state((phi, amp * om * math.sin(om * 0.5 * h)))
    rows = []
    for k in range(int(round(T / h)) + 1):
        t = k * h
        u = (phi, amp * om * math.sin(om * (t + 0.5 * h)))
        rows.append((t, *model.output(t, x, u)))
        x = model.advance(t, h, x, u)
        phi += u[1] * h
    np.savetxt(HERE / "reference.csv", np.array(rows), delimiter=",", fmt="%.12g",
               header=",".join(("time",) + model.outputs), comments="")


if __name__ == "__main__":
    main()
