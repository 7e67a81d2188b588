"""Standard run of SpringInertia (pure model, in-process); writes reference.csv next to this script.

Default parameters (J = 0.01 kg.m2, c = 100 N.m/rad, d = 0); the drive turns at 2 rad/s from angle 0, its
angle and speed held over each 1 ms step (the benchmark holds every input); t = 0 ... 1 s.
"""
from __future__ import annotations

from fmus.physics.elements import SpringInertiaModel, SpringInertiaParams
from fmus.reference import standard_run, write_reference


def main(h=1e-3, T=1.0, w=2.0):
    model = SpringInertiaModel(SpringInertiaParams())
    rows = standard_run(model, lambda k, t: (w * t, w), h, int(round(T / h)), x0=model.initial_state((0.0, w)))
    write_reference(__file__, model, rows)


if __name__ == "__main__":
    main()
