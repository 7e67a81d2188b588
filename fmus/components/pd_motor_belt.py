"""MotorBelt FMU: asynchronous motor driving the flywheel pulley through a V-belt."""
from ..declaration import Component, Output, Rotational
from ..physics.motor_belt import MotorBeltModel

class MotorBelt(Component):
    model = MotorBeltModel
    description = ("Asynchronous motor + V-belt driving a pulley; fidelity 0: ideal speed source + elastic belt, "
                   "1: Kloss characteristic with rotor inertia + elastic belt, 2: level 1 + belt creep.\n"
                   "pulley.tau = belt force * driven pulley radius, > 0 when the belt drives the pulley.")
    ports = (Rotational("pulley", motion="in", doc="driven pulley (on the flywheel shaft)"),)
    signals = (Output("motor_speed", "rad/s", "rotor angular velocity"),
               Output("motor_torque", "N.m", "electromagnetic torque of the motor (fidelity 0: torque the ideal source delivers)"),
               Output("power_electrical", "W", "electrical input power (air-gap power / efficiency)"),
               Output("power_mechanical", "W", "mechanical power motor_torque * motor_speed"),
               Output("belt_torque", "N.m", "torque with which the belt loads the motor shaft (belt force * motor pulley radius)"))
    # fidelity 0: the ideal source delivers the belt torque, so motor torque and powers follow the inputs too
    feedthrough = {"pulley.tau": ("pulley.phi", "pulley.w"), "belt_torque": ("pulley.phi", "pulley.w"),
                   "motor_torque": ("pulley.phi", "pulley.w"), "power_electrical": ("pulley.phi", "pulley.w"),
                   "power_mechanical": ("pulley.phi", "pulley.w")}
