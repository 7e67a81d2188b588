"""KnifeLoad FMU: cutting load of the spine-processing knife on its crank drive (seed 003)."""
from ..declaration import Component, Output, Rotational
from ..physics.knife import KnifeLoadModel


class KnifeLoad(Component):
    model = KnifeLoadModel
    description = ("Knife cutting load (Poliudov & Knysh): feed force polynomial through 4 samples, entry ramp, "
                   "disturbance moment 0.5 R F (cos beta + f sin beta sin(gamma + alpha3)) over crank angles [phi_s, pi].")
    ports = (Rotational("knife", motion="in", doc="crank driving the knife"),)
    signals = (Output("feed_force", "N", "feed force F_T of the book block (eq. 6)"),
               Output("cutting", "1", "1 while the knife is in the block, else 0"))
    # the cutting force of the material (its samples) and the knife's friction may change during the run (a
    # harder block, a blunt knife); the geometry and the cutting period stay fixed
    tunable = ("F_T1", "F_T2", "F_T3", "F_T4", "f")
    feedthrough = {"knife.tau": ("knife.phi",), "feed_force": ("knife.phi",), "cutting": ("knife.phi",)}
