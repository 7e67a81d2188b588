"""Standard run of KnifeLoad (default parameters) -> reference.csv, from the pure physics model.

Crank at the nominal speed omega = (pi - phi_s)/T_cut = 62.83 rad/s (10 plunges/s), block arriving at
t = 0 (entry ramp over T_entry = 0.164 s), 0.4 s sampled every 0.2 ms."""
import csv
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
from fmus.physics.knife import KnifeLoadModel, KnifeLoadParams  # noqa: E402


def main():
    p = KnifeLoadParams()
    m = KnifeLoadModel(p)
    w = (math.pi - p.phi_s) / p.T_cut
    h, n = 2e-4, 2000
    rows = [[i * h, *m.output(i * h, (), (w * i * h, w))] for i in range(n + 1)]
    out = Path(__file__).with_name("reference.csv")
    with out.open("w", newline="") as f:
        wr = csv.writer(f)
        wr.writerow(["time", *m.outputs])
        wr.writerows([f"{v:.12g}" for v in r] for r in rows)


if __name__ == "__main__":
    main()
