"""JamesDifferential FMU: planetary differential (ring, carrier in; sun out) of the taler drive, seed 004."""
from ..declaration import Component, Output, Rotational
from ..physics.differential import JamesDifferentialModel


class JamesDifferential(Component):
    model = JamesDifferentialModel
    description = ("James planetary differential: ring z3 and carrier b drive the sun z5 by "
                   "(w_sun - w_c)/(w_ring - w_c) = -z_ring/z_sun; fidelity 0 rigid, 1 compliant mesh with sun inertia.")
    ports = (Rotational("ring", motion="in", doc="internal ring gear z3 (four-bar rocker)"),
             Rotational("carrier", motion="in", doc="carrier b (cam follower)"),
             Rotational("sun", motion="out", doc="sun gear z5 (bed pinion shaft)"))
    signals = (Output("power_ring", "W", "power flowing into the differential through the ring"),
               Output("power_carrier", "W", "power flowing into the differential through the carrier"),
               Output("power_sun", "W", "power delivered by the sun to its load"),
               Output("planet_speed", "rad/s", "absolute angular velocity of the planets (eq. 13)"),
               Output("mesh_torque", "N.m", "torque of the gear set on the sun shaft (reduced mesh torque)"))
    _all = ("ring.phi", "ring.w", "carrier.phi", "carrier.w", "sun.tau")
    feedthrough = {"ring.tau": _all, "carrier.tau": _all, "power_ring": _all, "power_carrier": _all,
                   "mesh_torque": _all,
                   "sun.phi": ("ring.phi", "carrier.phi"), "sun.w": ("ring.w", "carrier.w"),
                   "power_sun": ("ring.w", "carrier.w", "sun.tau"),
                   "planet_speed": ("ring.w", "carrier.w")}
