"""Inertia FMU: a rigid rotating mass with optional ground spring, damper and drive torque."""
from ..declaration import Component, Rotational
from ..physics.elements import InertiaModel


class Inertia(Component):
    model = InertiaModel
    description = ("Rigid inertia J with optional spring/damper to the frame and constant drive torque. "
                   "Port flange: motion out (phi, w outputs), torque in.")
    ports = (Rotational("flange", motion="out", doc="flange of the inertia"),)
    # the external drive torque and the damping to the frame may change during the run; J, the spring and the
    # initial motion stay fixed
    tunable = ("tau_drive", "d_ground")
