"""Standard run of GearSectors (default parameters) -> reference.csv, from the pure physics model.

Main shaft at a constant 60 rpm over one machine cycle (1 s), no cylinder or bed load force."""
import csv
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
from fmus.physics.gear_sectors import GearSectorsModel, GearSectorsParams  # noqa: E402


def main():
    m = GearSectorsModel(GearSectorsParams())
    h, n, w = 1e-3, 1000, 2 * math.pi
    rows = []
    x = None
    for i in range(n + 1):
        t = i * h
        u = (w * t, w, 0.0, 0.0)
        x = m.initial_state(u) if x is None else x
        rows.append([t, *m.output(t, x, u)])
        x = m.advance(t, h, x, u)
    out = Path(__file__).with_name("reference.csv")
    with out.open("w", newline="") as f:
        wr = csv.writer(f)
        wr.writerow(["time", *m.outputs])
        wr.writerows([f"{v:.12g}" for v in r] for r in rows)


if __name__ == "__main__":
    main()
