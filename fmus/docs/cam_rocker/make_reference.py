"""Standard run of the CamRocker equations (fmus.physics.cam_rocker) -> reference.csv.

LCSM defaults (seed 001 geometry, law K0), fidelity 2 (clearance 20 um), crank at 150 rpm, no load,
communication step 1 ms, 0.8 s (two crank turns).  Run:  python -m fmus.docs.cam_rocker.make_reference
"""
from __future__ import annotations

import math

from fmus.physics.cam_rocker import CamRockerModel, CamRockerParams
from fmus.reference import standard_run, write_reference


def main() -> None:
    m = CamRockerModel(CamRockerParams(fidelity=2, clearance=20e-6))
    w, h, n = 2 * math.pi * 150 / 60, 1e-3, 800
    write_reference(__file__, m, standard_run(m, lambda k, t: [w * k * h, w, 0.0], h, n), fmt="%.10g")


if __name__ == "__main__":
    main()
