"""MotorBelt FMU: asynchronous motor driving the flywheel pulley through a V-belt."""
from ..declaration import Component, Input, Output, Rotational
from ..physics.motor_belt import MotorBeltModel

class MotorBelt(Component):
    model = MotorBeltModel
    description = ("Asynchronous motor + V-belt driving a pulley; fidelity 0: ideal speed source + elastic belt, "
                   "1: Kloss characteristic with rotor inertia + elastic belt, 2: level 1 + belt creep.\n"
                   "pulley.tau = belt force * driven pulley radius, > 0 when the belt drives the pulley.")
    ports = (Rotational("pulley", motion="in", doc="driven pulley (on the flywheel shaft)"),)
    # the supply's range: off to 1.5 times the rated frequency (a converter keeps the flux, the model's premise,
    # up to where its voltage runs out; a 400 V motor in delta on a 400 V converter reaches 87 Hz = 1.74x)
    signals = (Input("supply", "1", "supply frequency over its rated value (1: rated; 0: the motor is off)", start=1.0,
                     min=0.0, max=1.5),
               Input("brake", "1", "brake command: >= 0.5 applies the rotor brake (after brake_delay)", start=0.0,
                     min=0.0, max=1.0),
               Output("motor_speed", "rad/s", "rotor angular velocity"),
               Output("motor_torque", "N.m", "electromagnetic torque of the motor (fidelity 0: torque the ideal source delivers)"),
               Output("power_electrical", "W", "electrical input power (air-gap power / efficiency)"),
               Output("power_mechanical", "W", "mechanical power motor_torque * motor_speed"),
               Output("belt_torque", "N.m", "torque with which the belt loads the motor shaft (belt force * motor pulley radius)"),
               Output("brake_torque", "N.m", "torque of the rotor brake on the rotor (sliding friction, or the holding reaction at rest)"))
    # fidelity 0: the ideal source delivers the belt torque, so motor torque and powers follow the pulley's motion;
    # at fidelities 1, 2 they follow the supply at once (its slip speed); the brake's torque follows its command
    # and, holding at rest, the belt
    # the brake's holding torque and engage time may change during the run (a weaker brake, a later one); the
    # drive's geometry, inertia, belt and motor rating stay fixed
    tunable = ("holding_torque", "brake_delay")
    feedthrough = {"pulley.tau": ("pulley.phi", "pulley.w"), "belt_torque": ("pulley.phi", "pulley.w"),
                   "motor_torque": ("pulley.phi", "pulley.w", "supply"),
                   "power_electrical": ("pulley.phi", "pulley.w", "supply"),
                   "power_mechanical": ("pulley.phi", "pulley.w", "supply"),
                   "brake_torque": ("pulley.phi", "pulley.w", "supply", "brake")}
