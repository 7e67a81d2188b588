"""ClutchBrakeShaft FMU: the flywheel shaft with a combined clutch-brake on the main shaft."""
from ..declaration import Component, Input, Output, Rotational
from ..physics.clutch_brake import ClutchBrakeShaftModel


class ClutchBrakeShaft(Component):
    model = ClutchBrakeShaftModel
    description = ("Flywheel + driven pulley on a torsionally compliant main shaft with a combined clutch-brake: "
                   "commanded, after cb_delay the clutch parts the flywheel from the crank side and the brake "
                   "(cb_torque) stops the crank side alone.\n"
                   "Ports pulley, crank and aux are motion outputs; crank and aux carry the same crank-side motion.")
    ports = (Rotational("pulley", motion="out", doc="flywheel / driven belt pulley"),
             Rotational("crank", motion="out", doc="crank-side end of the main shaft"),
             Rotational("aux", motion="out", doc="second take-off on the crank-side end (e.g. cams)"))
    signals = (Input("clutch_brake", "1", "clutch-brake command: >= 0.5 opens the clutch and applies the brake "
                     "(after cb_delay)", start=0.0, min=0.0, max=1.0),
               Output("shaft_torque", "N.m", "torque transmitted by the shaft from the flywheel to the crank side "
                      "(0 while the clutch is open)"),
               Output("shaft_twist", "rad", "elastic shaft twist (0 while the clutch is open)"),
               Output("kinetic_energy", "J", "kinetic energy of both inertias"),
               Output("potential_energy", "J", "elastic energy of the shaft"),
               Output("clutch_brake_torque", "N.m", "torque of the clutch-brake's brake on the crank side (sliding "
                      "friction, or the holding reaction at rest)"))
    # the brake's torque and response time may change during the run; the shaft and inertias stay fixed
    tunable = ("cb_torque", "cb_delay")
    # the holding brake's reaction follows the torques on the crank side at once
    feedthrough = {"clutch_brake_torque": ("crank.tau", "aux.tau", "clutch_brake")}
