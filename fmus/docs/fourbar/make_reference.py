"""Standard run of the FourBar physics model -> reference.csv (run: python -m fmus.docs.fourbar.make_reference).

Fidelity 2 with the default (seed 004 x 0.1 m) linkage and a 20 um clearance, the crank driven at a constant
15 rad/s from crank.phi = 0.3 rad, a constant load torque rocker.tau = -0.5 N.m, communication step 1 ms, 0.5 s.
"""
from __future__ import annotations

from fmus.physics.fourbar import FourBarModel, FourBarParams
from fmus.reference import standard_run, write_reference


def main() -> None:
    model = FourBarModel(FourBarParams(fidelity=2, clearance=2e-5))
    w, tau, phi0, h, n = 15.0, -0.5, 0.3, 1e-3, 500
    write_reference(__file__, model, standard_run(model, lambda k, t: [phi0 + w * k * h, w, tau], h, n))


if __name__ == "__main__":
    main()
