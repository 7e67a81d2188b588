"""Standard run of JamesDifferential (default parameters) -> reference.csv, from the pure physics model.

Ring and carrier swing like the rocker and the cam follower of paper B (one 1 s cycle); the sun carries
a load torque.  Inputs are held over each 1 ms step, angles advance with the held speeds."""
import csv
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
from fmus.physics.differential import JamesDifferentialModel, JamesDifferentialParams  # noqa: E402


def main():
    m = JamesDifferentialModel(JamesDifferentialParams())
    h, n = 1e-3, 1000
    phr = phc = 0.0
    rows = []
    x = None
    for i in range(n + 1):
        t = i * h
        wr = -0.5 * math.pi * 2 * math.sin(2 * math.pi * t)   # ring (rocker), paper sign: negative sense
        wc = 0.35 * math.pi * 2 * math.sin(2 * math.pi * t)   # carrier (cam follower)
        u = (phr, wr, phc, wc, -20.0 - 10.0 * math.sin(4 * math.pi * t))
        x = m.initial_state(u) if x is None else x
        rows.append([t, *m.output(t, x, u)])
        x = m.advance(t, h, x, u)
        phr, phc = phr + wr * h, phc + wc * h
    out = Path(__file__).with_name("reference.csv")
    with out.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time", *m.outputs])
        w.writerows([f"{v:.12g}" for v in r] for r in rows)


if __name__ == "__main__":
    main()
