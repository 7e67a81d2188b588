"""TorqueLoad FMU: generic torque load of a rotating link (constant + Coulomb + viscous + spring)."""
from ..declaration import Component, Rotational
from ..physics.loads import TorqueLoadModel


class TorqueLoad(Component):
    model = TorqueLoadModel
    description = ("Torque load on a driven flange: flange.tau = -(T_const + T_coulomb*tanh(w/w_reg) + d*w + "
                   "c*(phi - phi_ref)); fidelity 0 (static law) only.")
    ports = (Rotational("flange", motion="in", doc="driven flange of the loaded link"),)
    # the load's torques may change during the run (a load put on or taken off); the spring stays fixed
    tunable = ("T_const", "T_coulomb", "d")
    feedthrough = {"flange.tau": ("flange.phi", "flange.w")}
