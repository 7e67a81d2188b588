"""SpringInertia FMU: an inertia driven through a spring-damper from a motion-input flange."""
from ..declaration import Component, Rotational
from ..physics.elements import SpringInertiaModel


class SpringInertia(Component):
    model = SpringInertiaModel
    description = ("Inertia J behind a spring-damper (c, d) driven by the motion of port drive; "
                   "drive.tau = -(c*(drive.phi - phi) + d*(drive.w - w)), the reaction on the driver, is a direct function of the inputs.")
    ports = (Rotational("drive", motion="in", doc="driving flange of the spring"),)
    feedthrough = {"drive.tau": ("drive.phi", "drive.w")}
    advances_position = False  # the textbook benchmark: every input held constant over a step
