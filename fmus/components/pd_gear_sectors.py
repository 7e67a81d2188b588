"""GearSectors FMU: printing-cylinder drive by eccentric round gear sectors plus the bed slider-crank (seed 002)."""
from ..declaration import Component, Output, Rotational, Translational
from ..physics.gear_sectors import GearSectorsModel


class GearSectors(Component):
    model = GearSectorsModel
    description = ("Flat-bed press: main shaft drives the printing cylinder by a 4-phase law (uniform, eccentric-sector "
                   "acceleration, synchronous with the bed, sector braking) and the bed by a slider-crank with skat.")
    ports = (Rotational("crank", motion="in", doc="main shaft (crank OA, driving sectors)"),
             Rotational("cylinder", motion="out", doc="printing cylinder"),
             Translational("bed", motion="out", doc="bed (taler)"))
    signals = (Output("sync_error", "m", "cylinder surface minus bed displacement since point 2, printing phase only"),
               Output("phase", "1", "1 acceleration 1-2, 2 synchronous 2-3, 3 braking 3-4, 4 uniform 4-1"),
               Output("mesh_force", "N", "tangential tooth force of the gearing on the cylinder at its pitch "
                                         "circle D_C/2 (+: driving it forward)"))
    feedthrough = {"crank.tau": ("crank.phi", "crank.w", "cylinder.tau", "bed.f"),
                   "cylinder.phi": ("crank.phi",), "cylinder.w": ("crank.phi", "crank.w"),
                   "bed.s": ("crank.phi",), "bed.v": ("crank.phi", "crank.w"),
                   "sync_error": ("crank.phi",), "phase": ("crank.phi",),
                   "mesh_force": ("crank.phi", "crank.w", "cylinder.tau")}
