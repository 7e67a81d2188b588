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
                    watch: str | None = None, overrun: tuple[float, str] | None = None,
                    accuracy: dict | None = None) -> list:
    """The transients every drive with a MotorBelt ships (harness.scenarios), for its instance ``motor``:

    * ``startup``: from rest (``rest``: the parameters that put the drive's parts at rest, the motor's
      ``w_start`` = 0 added), the motor on its rated supply;
    * ``speed_change``: the supply ramped from its rated frequency to 80 % over 0.5 s at ``change_at``;
    * ``estop``: at ``change_at`` the motor switched off and its brake commanded: a spring-applied brake of
      twice the motor's rated torque (P_rated/w_rated; brake motors carry 1.5-2.5 times), taking hold 50 ms
      after the command (the order of a spring-applied brake's engage time).

    A motor declared as an ideal speed source (fidelity 0) runs at fidelity 1 (the Kloss curve with the rotor's
    inertia) in them: a transient needs the motor's own dynamics.  Each declares the accuracy its question needs
    (``Scenario.accuracy``, ``study accuracy --scenario``; :func:`startup_accuracy`, :func:`speed_change_accuracy`,
    :func:`stop_accuracy`; ``overrun``: the tolerance and unit of the ``watch`` column's overrun in a stop);
    ``accuracy``: scenario name -> the :class:`harness.specs.Requirement` that replace a scenario's."""
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
    declared = {"startup": startup_accuracy(), "speed_change": speed_change_accuracy(),
                "estop": stop_accuracy(watch, overrun)}
    accuracy = {**declared, **accuracy}
    unknown = sorted(set(accuracy) - {sc.name for sc in scenarios})
    if unknown:
        raise ValueError(f"system {system.name}: accuracy declared for no scenario {unknown[0]!r} "
                         f"(its scenarios: {', '.join(sc.name for sc in scenarios)})")
    return [replace(sc, accuracy=tuple(accuracy.get(sc.name, ()))) for sc in scenarios]


# -- the accuracy each transient's question needs (against the monolithic reference through the same events) -----
# An engineer's tolerances, from what each number is used for (../shared/reference/press-engineering-facts.md):
# a time to speed or a stopping time feeds the motor's start class and the guard's interlock to a few percent or
# a couple of milliseconds; a stopping angle positions the tool to 0.5 %; a new press rate is read in sheets per
# hour to 0.2 %; peak torques size the motor (overload margin 0.8 T_max), shafts, couplings and the belt, to 2 %;
# a jam's speed drop (the motor's pull-out margin) to 0.2 percentage points of speed.
PEAK = 0.02        # relative tolerance of a peak motor, shaft or belt torque
STOP_TIME = 2e-3   # s: the stopping time
RATE = 2e-3        # relative tolerance of a speed the run ends at


def _peaks(*names: str) -> tuple:
    from harness.specs import Requirement

    what = {"motor_torque_peak": "peak motor torque", "shaft_torque_peak": "peak main-shaft torque",
            "belt_torque_peak": "peak belt torque"}
    return tuple(Requirement(what[n], n, PEAK, "N.m", relative=True) for n in names)


def startup_accuracy() -> tuple:
    """A start-up's: the time to 95 % of speed to 2 %, the peak motor and main-shaft torque on the way up to 2 %."""
    from harness.specs import Requirement

    return (Requirement("time to 95 % speed", "time_to_speed", 0.02, "s", relative=True),
            *_peaks("motor_torque_peak", "shaft_torque_peak"))


def speed_change_accuracy() -> tuple:
    """A speed change's: the new speed (the press rate) to 0.2 %, the peak motor and main-shaft torque from the
    change on to 2 %."""
    from harness.specs import Requirement

    return (Requirement("speed after the change", "speed_after", RATE, "rpm", relative=True),
            *_peaks("motor_torque_peak", "shaft_torque_peak"))


def stop_accuracy(watch: str | None = None, overrun: tuple[float, str] | None = None) -> tuple:
    """An emergency stop's: the stopping time to 2 ms, the stopping angle to 0.5 %, the peak main-shaft and belt
    torque of the stop to 2 % (a brake on the motor holds the drive through the belt), and, where the drive has a
    tool (``watch``), its overrun to ``overrun`` = (tolerance, unit)."""
    from harness.specs import Requirement

    out = (Requirement("stopping time", "stopping_time", STOP_TIME, "s"),
           Requirement("stopping angle", "stopping_angle", 5e-3, "deg", relative=True),
           *_peaks("shaft_torque_peak", "belt_torque_peak"))
    if watch is not None and overrun is not None:
        out += (Requirement(f"overrun of {watch}", "overrun", overrun[0], overrun[1]),)
    return out


def jam_accuracy() -> tuple:
    """A jam's: the speed drop to 0.2 percentage points, the peak motor and main-shaft torque after it to 2 %."""
    from harness.specs import Requirement

    return (Requirement("speed drop", "speed_drop", 0.2, "%"), *_peaks("motor_torque_peak", "shaft_torque_peak"))


def blocked_jam_accuracy(load: str = "stop_torque", held: bool = True) -> tuple:
    """A blocking jam's (:func:`blocking_jam`): the time to the first standstill to 2 ms (as a stopping time), the
    stop's peak ``load`` (``stop_torque`` or ``stop_force``) and, where the drive comes to rest (``held``), its
    load on the blocked drive, the peak motor, main-shaft and belt torque in the jam, each to 2 %."""
    from harness.specs import Requirement

    unit = "N.m" if load == "stop_torque" else "N"
    return (Requirement("time to the first standstill", "time_to_block", STOP_TIME, "s"),
            Requirement("peak load of the stop", f"{load}_peak", PEAK, unit, relative=True),
            *((Requirement("load of the stop on the blocked drive", f"{load}_held", PEAK, unit, relative=True),)
              if held else ()),
            *_peaks("motor_torque_peak", "shaft_torque_peak", "belt_torque_peak"))


def blocking_jam(system, instance: str, position: float, stiffness: float, damping: float, *, at: float,
                 stop_time: float, what: str, catch: int = 1, motor: str = "motor", accuracy: tuple | None = None,
                 settle_limit: float | None = None):
    """A jam that blocks the tool (``kind: jam``, :mod:`harness.reporting.jams`): at ``at`` an end stop appears in
    the path of instance ``instance``'s tool at ``position`` (its ``stop_stiffness`` set by a change; its
    position, ``damping`` and ``catch`` set up as parameters: :class:`fmus.physics.contact.EndStop`), ``what``
    saying what it is; the motor at fidelity 1 or above.  The run goes on until the drive has settled at rest, up
    to ``settle_limit`` [s] (None: four times ``stop_time``)."""
    from harness.specs import Change, Scenario

    dynamic = (((f"{motor}.fidelity", 1),) if system.instance(motor).parameters.get("fidelity", 1) == 0 else ())
    kind = "caught and held" if catch else "an end stop that cannot pull"
    return Scenario("jam", f"What does a jam that blocks the tool ({what}: {kind}) do to the drive: how fast is it "
                    f"blocked, what peak loads does it put on the parts, is the motor overloaded?", "jam", stop_time,
                    (Change(at, f"{instance}.stop_stiffness", stiffness),),
                    parameters=dynamic + ((f"{instance}.stop_position", position),
                                          (f"{instance}.stop_damping", damping), (f"{instance}.stop_catch", catch)),
                    accuracy=accuracy if accuracy is not None else blocked_jam_accuracy(), settle_limit=settle_limit)


def jam(system, variable: str, torque: float, *, at: float = 1.0, stop_time: float = 2.0, motor: str = "motor"):
    """A jam: a load torque ``torque`` [N.m] stepped onto the free input ``variable`` at ``at`` (harness.scenarios),
    the motor at fidelity 1 or above (its speed can drop)."""
    from harness.specs import Change, Scenario

    dynamic = (((f"{motor}.fidelity", 1),) if system.instance(motor).parameters.get("fidelity", 1) == 0 else ())
    return Scenario("jam", f"What does a jam, a sudden load of {abs(torque):.4g} N.m on {variable}, do to the "
                    f"drive's speed and loads?", "load", stop_time, (Change(at, variable, torque),),
                    parameters=dynamic, accuracy=jam_accuracy())
