"""Standard run of ConveyorLoad (pure physics, in-process); writes reference.csv next to this script.

Default parameters (the article's Fig. 1 block 320 mm x 36 mm at 500 mm pitch, 1200 mm tool).  Input: the drive
shaft turning at 1.8/r rad/s (belt speed 1.8 m/s), its angle integrated exactly, held over 1 ms steps.  Rows:
outputs at t = 0 ... 1 s (3.6 pitches).
"""
from __future__ import annotations

from fmus.physics.conveyor import ConveyorLoadModel, ConveyorLoadParams
from fmus.reference import standard_run, write_reference


def main(h=1e-3, T=1.0, speed=1.8):
    model = ConveyorLoadModel(ConveyorLoadParams())
    w = speed / model.p.r_pulley
    write_reference(__file__, model, standard_run(model, lambda k, t: (w * t, w), h, int(round(T / h))))


if __name__ == "__main__":
    main()
