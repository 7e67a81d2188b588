"""FlywheelShaft FMU: flywheel + belt pulley on a torsionally compliant main shaft with two crank-side take-offs."""
from ..declaration import Component, Output, Rotational
from ..physics.flywheel_shaft import FlywheelShaftModel


class FlywheelShaft(Component):
    model = FlywheelShaftModel
    description = ("Flywheel + driven pulley on a torsionally compliant main shaft (c = G*pi*d^4/(32*l), damping from "
                   "the loss coefficient psi); fidelity 0: rigid shaft, 1: compliant shaft (2 DOF).\n"
                   "Ports pulley, crank and aux are motion outputs; crank and aux carry the same crank-side motion.")
    ports = (Rotational("pulley", motion="out", doc="flywheel / driven belt pulley"),
             Rotational("crank", motion="out", doc="crank-side end of the main shaft"),
             Rotational("aux", motion="out", doc="second take-off on the crank-side end (e.g. cams)"))
    signals = (Output("shaft_torque", "N.m", "torque transmitted by the shaft from the flywheel to the crank side"),
               Output("shaft_twist", "rad", "shaft twist phi_flywheel - phi_crank"),
               Output("kinetic_energy", "J", "kinetic energy of both inertias"),
               Output("potential_energy", "J", "elastic energy of the shaft"))
    feedthrough = {}
