"""Standard run of GearSectors (default parameters) -> reference.csv, from the pure physics model.

Main shaft at a constant 60 rpm over one machine cycle (1 s), no cylinder or bed load force."""
from __future__ import annotations

import math

from fmus.physics.gear_sectors import GearSectorsModel, GearSectorsParams
from fmus.reference import standard_run, write_reference


def main():
    m = GearSectorsModel(GearSectorsParams())
    h, n, w = 1e-3, 1000, 2 * math.pi
    write_reference(__file__, m, standard_run(m, lambda k, t: (w * t, w, 0.0, 0.0), h, n))


if __name__ == "__main__":
    main()
