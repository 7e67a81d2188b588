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
