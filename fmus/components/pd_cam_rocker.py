"""CamRocker FMU: cam-corrected rocker (slotted rocker with groove, or disc cam with oscillating follower)."""
from ..declaration import Component, Output, Rotational
from ..physics.cam_rocker import CamRockerModel


class CamRocker(Component):
    model = CamRockerModel
    description = ("Cam-corrected rocker driven by a crank: slotted rocker whose kulisa follows a law of periodic motion "
                   "(LCSM, groove synthesised from the law) or disc cam with oscillating roller follower; rigid, elastic "
                   "elastic with pin clearance and impacts, or (slotted rocker) with seed 000's two clearances, stone pin and roller in the groove.")
    ports = (Rotational("crank", motion="in", doc="driving crank (cam shaft)"),
             Rotational("rocker", motion="out", doc="output rocker (kulisa / cam follower)"))
    signals = (Output("pressure_angle", "rad", "pressure angle at the stone (LCSM, conrod vs groove) or at the cam"),
               Output("stone_radius", "m", "stone radius |O2B| (LCSM) or roller-centre distance from the cam centre"),
               Output("pin_force", "N", "stone-pin contact force magnitude at the communication point (fidelity 2, 3; 0 separated)"),
               Output("in_contact", "1", "1 while the stone-pin clearance is closed (fidelity 2, 3)"),
               Output("impact_count", "1", "number of stone-pin impacts so far (fidelity 2, 3)"),
               Output("groove_force", "N", "roller-groove contact force magnitude at the communication point (fidelity 3; 0 separated)"),
               Output("groove_contact", "1", "1 while the roller touches a groove wall (fidelity 3)"),
               Output("groove_impact_count", "1", "number of roller-groove impacts so far (fidelity 3)"))
    feedthrough = {"rocker.phi": ("crank.phi", "crank.w"), "rocker.w": ("crank.phi", "crank.w"),
                   "crank.tau": ("crank.phi", "crank.w", "rocker.tau"),
                   "pressure_angle": ("crank.phi",), "stone_radius": ("crank.phi",),
                   "pin_force": ("crank.phi", "crank.w"), "groove_force": ("crank.phi", "crank.w")}
