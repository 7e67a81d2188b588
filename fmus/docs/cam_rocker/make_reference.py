"""Standard run of the CamRocker equations (fmus.physics.cam_rocker) -> reference.csv.

LCSM defaults (seed 001 geometry, law K0), fidelity 2 (clearance 20 um), crank at 150 rpm, no load,
communication step 1 ms, 0.8 s (two crank turns).  Run:  python fmus/docs/cam_rocker/make_reference.py
"""
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
from fmus.physics.cam_rocker import CamRockerModel, CamRockerParams  # noqa: E402


def main() -> None:
    m = CamRockerModel(CamRockerParams(fidelity=2, clearance=20e-6))
    w, h, n = 2 * math.pi * 150 / 60, 1e-3, 800
    u = [0.0, w, 0.0]
    x = m.initial_state(u)
    rows = [[0.0, *m.output(0.0, x, u)]]
    for k in range(n):
        x = m.advance(k * h, h, x, [w * k * h, w, 0.0])
        t = (k + 1) * h
        rows.append([t, *m.output(t, x, [w * t, w, 0.0])])
    header = "time," + ",".join(m.outputs)
    np.savetxt(Path(__file__).with_name("reference.csv"), np.array(rows), delimiter=",", header=header,
               comments="", fmt="%.10g")


if __name__ == "__main__":
    main()
