"""RackBed FMU: pinion and rack driving the flat bed of a flat-bed press."""
from ..declaration import Component, Output, Rotational
from ..physics.rack_bed import RackBedModel

class RackBed(Component):
    model = RackBedModel
    description = ("Pinion + rack driving the flat bed (mass m_T) against guideway friction and a printing load; "
                   "fidelity 0: rigid mesh (bed follows the pinion), 1: elastic rack mesh (bed has its own state).\n"
                   "pinion.tau = -R * mesh_force, the reaction of the rack on the pinion.")
    ports = (Rotational("pinion", motion="in", doc="pinion z6 on the sun-gear shaft"),)
    signals = (Output("bed.s", "m", "bed position"),
               Output("bed.v", "m/s", "bed velocity"),
               Output("bed.a", "m/s2", "bed acceleration"),
               Output("mesh_force", "N", "force of the pinion on the rack, positive forward"))
    # an end stop (a jam) appears while the press runs: its stiffness and damping may be set during the run
    tunable = ("stop_stiffness", "stop_damping")
    # union over the levels: fidelity 0 takes s and v from the inputs, fidelity 1 has a and F from the mesh
    feedthrough = {"pinion.tau": ("pinion.phi", "pinion.w"), "mesh_force": ("pinion.phi", "pinion.w"),
                   "bed.a": ("pinion.phi", "pinion.w"), "bed.s": ("pinion.phi",), "bed.v": ("pinion.w",)}
