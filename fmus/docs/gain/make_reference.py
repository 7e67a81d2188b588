"""Standard run of Gain (pure model, in-process); writes reference.csv next to this script.

Default parameters.  Input u = sin(2*pi*t) sampled every 10 ms and held over each step, t = 0 ... 1 s.
"""
from __future__ import annotations

import math

from fmus.physics.testing import GainModel, GainParams
from fmus.reference import standard_run, write_reference


def main(h=1e-2, T=1.0):
    model = GainModel(GainParams())
    rows = standard_run(model, lambda k, t: (math.sin(2.0 * math.pi * t),), h, int(round(T / h)))
    write_reference(__file__, model, rows)


if __name__ == "__main__":
    main()
