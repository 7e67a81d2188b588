"""FourBar FMU: crank-rocker four-bar, rigid, with an elastic coupler, or with a clearance joint (seeds 000, 004)."""
from ..declaration import Component, Output, Rotational
from ..physics.fourbar import FourBarModel


class FourBar(Component):
    model = FourBarModel
    description = ("Crank-rocker four-bar: crank motion in, rocker motion out; fidelity 0 rigid closed-form "
                   "kinematics, 1 elastic coupler, 2 elastic coupler with a clearance joint and impacts.\n"
                   "crank.tau is the torque the linkage exerts on the crank (a driven load gives crank.tau < 0); "
                   "rocker.tau is the load torque on the rocker.  See documentation/index.md.")
    ports = (Rotational("crank", motion="in", doc="crank O2A, angle from the frame line O2->O5, CCW"),
             Rotational("rocker", motion="out", doc="rocker O5D, absolute angle from the frame line, CCW"))
    signals = (Output("transmission_angle", "rad", "angle at the rocker pin D between D->A and D->O5 (0..pi)"),
               Output("joint_force", "N", "coupler axial force, tension positive"),
               Output("contact_force", "N", "contact force in the clearance joint at the communication point (0 while separated)"),
               Output("in_contact", "1", "1 while the clearance joint is closed (always 1 at fidelity 0, 1)"),
               Output("impact_count", "1", "number of contact onsets in the clearance joint so far"),
               Output("last_impact_speed", "m/s", "approach speed at the last contact onset"),
               Output("rebound_speed", "m/s", "separation speed at the end of the last contact"))
    feedthrough = {
        "crank.tau": ("crank.phi", "crank.w", "rocker.tau"),
        "rocker.phi": ("crank.phi", "crank.w"),
        "rocker.w": ("crank.phi", "crank.w"),
        "transmission_angle": ("crank.phi",),
        "joint_force": ("crank.phi", "crank.w", "rocker.tau"),
        "contact_force": ("crank.phi", "crank.w"),
        "in_contact": ("crank.phi",),
    }
