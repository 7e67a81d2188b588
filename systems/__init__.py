"""The complete press drives of the seeds (and the two-inertia coupling benchmark), as data.

Each module defines ``SYSTEM = System(...)``: instances (an FMU model name from build_fmus.py and parameter
values with their units in comments and their source in the seeds), power bonds, connections, the default
experiment, and the scenes that may be asked of it.  No stepping code lives here.
"""


def motor_inputs(motor: str = "motor") -> dict[str, str]:
    """The free inputs of a drive's MotorBelt instance ``motor``, with why their start values are right: the
    scenarios (start-up, speed change, emergency stop) drive them; a plain run keeps the motor on the rated
    supply with the brake released."""
    return {f"{motor}.supply": "the motor's supply frequency over its rated value: 1 (rated) unless a scenario "
                               "changes the press speed or switches the motor off",
            f"{motor}.brake": "the rotor brake's command: 0 (released) unless a scenario stops the drive"}


def motor_scenarios(system, rest: dict, *, motor: str = "motor", change_at: float = 1.5, stop_time: float = 3.0,
                    watch: str | None = None, accuracy: dict | None = None) -> list:
    """The transients every drive with a MotorBelt ships (harness.scenarios), for its instance ``motor``:

    * ``startup``: from rest (``rest``: the parameters that put the drive's parts at rest, the motor's
      ``w_start`` = 0 added), the motor on its rated supply;
    * ``speed_change``: the supply ramped from its rated frequency to 80 % over 0.5 s at ``change_at``;
    * ``estop``: at ``change_at`` the motor switched off and its brake commanded: a spring-applied brake of
      twice the motor's rated torque (P_rated/w_rated; brake motors carry 1.5-2.5 times), taking hold 50 ms
      after the command (the order of a spring-applied brake's engage time).

    A motor declared as an ideal speed source (fidelity 0) runs at fidelity 1 (the Kloss curve with the rotor's
    inertia) in them: a transient needs the motor's own dynamics.  ``accuracy``: scenario name -> the
    :class:`harness.specs.Requirement` its question needs (``Scenario.accuracy``, ``study accuracy --scenario``)."""
    from dataclasses import replace

    from fmus.physics.motor_belt import MotorBeltParams
    from harness.specs import Change, Scenario

    values = {**{s.name: s.default for s in MotorBeltParams.specs()}, **system.instance(motor).parameters}
    rated = values["P_rated"] / values["w_rated"]                   # N.m at the rotor
    dynamic = (((f"{motor}.fidelity", 1),) if values["fidelity"] == 0 else ())
    brake = ((f"{motor}.holding_torque", 2.0 * rated), (f"{motor}.brake_delay", 0.05))
    at_rest = tuple(rest.items()) + ((f"{motor}.w_start", 0.0),)
    accuracy = dict(accuracy or {})
    scenarios = [
        Scenario("startup", "How long does the drive take from rest to speed, and what peak torques does the "
                 "start-up put on the motor, the shafts and the joints?", "startup", stop_time,
                 parameters=dynamic + at_rest),
        Scenario("speed_change", "What happens when the press is slowed to 80 % through the motor's supply "
                 "frequency (a 0.5 s ramp)?", "speed_change", stop_time + 1.0,
                 (Change(change_at, f"{motor}.supply", 0.8, ramp=0.5),), parameters=dynamic),
        Scenario("estop", "How long and how far does the drive run on after an emergency stop (motor off, the "
                 "rotor brake at twice rated torque after 50 ms), and what loads does the stop put on the parts?",
                 "stop", stop_time, (Change(change_at, f"{motor}.supply", 0.0),
                                     Change(change_at, f"{motor}.brake", 1.0)), parameters=dynamic + brake,
                 watch=watch),
    ]
    unknown = sorted(set(accuracy) - {sc.name for sc in scenarios})
    if unknown:
        raise ValueError(f"system {system.name}: accuracy declared for no scenario {unknown[0]!r} "
                         f"(its scenarios: {', '.join(sc.name for sc in scenarios)})")
    return [replace(sc, accuracy=tuple(accuracy.get(sc.name, ()))) for sc in scenarios]


def jam(system, variable: str, torque: float, *, at: float = 1.0, stop_time: float = 2.0, motor: str = "motor"):
    """A jam: a load torque ``torque`` [N.m] stepped onto the free input ``variable`` at ``at`` (harness.scenarios),
    the motor at fidelity 1 or above (its speed can drop)."""
    from harness.specs import Change, Scenario

    dynamic = (((f"{motor}.fidelity", 1),) if system.instance(motor).parameters.get("fidelity", 1) == 0 else ())
    return Scenario("jam", f"What does a jam, a sudden load of {abs(torque):.4g} N.m on {variable}, do to the "
                    f"drive's speed and loads?", "load", stop_time, (Change(at, variable, torque),),
                    parameters=dynamic)
