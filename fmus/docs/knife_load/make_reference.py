"""Standard run of KnifeLoad (default parameters) -> reference.csv, from the pure physics model.

Crank at the nominal speed omega = (pi - phi_s)/T_cut = 62.83 rad/s (10 plunges/s), block arriving at
t = 0 (entry ramp over T_entry = 0.164 s), 0.4 s sampled every 0.2 ms."""
from __future__ import annotations

import math

from fmus.physics.knife import KnifeLoadModel, KnifeLoadParams
from fmus.reference import standard_run, write_reference


def main():
    p = KnifeLoadParams()
    m = KnifeLoadModel(p)
    w = (math.pi - p.phi_s) / p.T_cut
    h, n = 2e-4, 2000
    write_reference(__file__, m, standard_run(m, lambda k, t: (w * k * h, w), h, n))


if __name__ == "__main__":
    main()
