"""ParallelShafts FMU: seed 003's knife drive shafts -- two identical shafts in parallel from a drive end and a
belt-driven flywheel to the knife."""
from ..declaration import Component, Output, Rotational
from ..physics.parallel_shafts import ParallelShaftsModel


class ParallelShafts(Component):
    model = ParallelShaftsModel
    description = ("Two identical shafts (c1 = G*pi*d^4/(32*l) each; in parallel C_red = G*pi*d^4/(16*l)) from the drive "
                   "end and from a flywheel J1 fed by a V-belt to the knife inertia J_red (seed 003, Fig. 3); "
                   "fidelity 0: eq. (11), shaft ends turn alike; 1: eq. (10) with the driven shaft and the belt.\n"
                   "Ports pulley, crank and aux are motion outputs; crank and aux carry the knife's motion.")
    ports = (Rotational("pulley", motion="out", doc="drive end of the driving shaft (flywheel + belt pulley)"),
             Rotational("crank", motion="out", doc="the cranks and the knife (both shafts' ends)"),
             Rotational("aux", motion="out", doc="second take-off on the knife node"))
    signals = (Output("shaft_torque", "N.m", "torque both shafts deliver to the knife"),
               Output("shaft_twist", "rad", "twist of the driving shaft phi0 - phi1 (the seed's -dphi)"),
               Output("driven_twist", "rad", "twist of the driven shaft phi2 - phi1 (the seed's -dphi2)"),
               Output("belt_twist", "rad", "flywheel J1 against the drive end, phi2 - phi0 (the seed's dphi1)"),
               Output("kinetic_energy", "J", "kinetic energy of the three inertias"),
               Output("potential_energy", "J", "elastic energy of the shafts and the belt"),
               Output("dissipation", "W", "power dissipated in the shafts and the belt"))
    # an end stop on the knife (a jam) appears while the press runs: its stiffness and damping may be set during it
    tunable = ("stop_stiffness", "stop_damping")
    feedthrough = {}
