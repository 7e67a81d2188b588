"""ConveyorLoad FMU: the trimming section's load on the belt conveyors' drive shaft (seed 003, second article)."""
from ..declaration import Component, Output, Rotational
from ..physics.conveyor import ConveyorLoadModel


class ConveyorLoad(Component):
    model = ConveyorLoadModel
    description = ("Transport load of a non-stop book-block trimmer (Topolnytskyi): blocks at a pitch past two stationary "
                   "knives; the transport force is the cutting work w*h per unit of travel of the block edge inside the "
                   "cutting zone, plus F0; moment F*r/eta on the drive shaft.")
    ports = (Rotational("shaft", motion="in", doc="drive shaft of the belt conveyors"),)
    signals = (Output("transport_force", "N", "transport force of the blocks through the trimming section"),
               Output("blocks_cut", "1", "number of blocks with edge inside the cutting zone"))
    # the stack's cutting work and the conveyor's own resistance may change during the run (another paper, a
    # jammed guide); the geometry and the number of knives stay fixed
    tunable = ("w_cut", "F0")
    feedthrough = {"shaft.tau": ("shaft.phi",), "transport_force": ("shaft.phi",), "blocks_cut": ("shaft.phi",)}
