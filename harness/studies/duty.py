"""The motor's thermal check over a duty cycle the engineer states: ``python -m harness duty DRIVE
--starts-per-hour N --stops-per-hour N [--running SHARE] [--cooling-at-rest K]``, :func:`duty`.

Three runs of the drive give the pieces (facts: "The motor's thermal duty"): its default run (the steady cycles'
motor torque T_rms, :mod:`harness.reporting.quantities`), its ``startup`` scenario (from rest to its first steady
cycle: the integral of T^2 over that time, t_start) and its ``estop`` scenario (run until settled,
:mod:`harness.run.settling`: the integral of T^2 from the command to settled, t_stop, and the brake's energy per
stop).  Over one hour with N_s starts, N_e stops, the press running a share r of the hour (default: all of it
that the starts and stops leave) and at rest the remainder t_rest, with the motor's cooling at rest K (a
self-ventilated motor cools at about half its running rate at standstill: K = 0.5; 1 for a separately
ventilated one):

    T_eq = sqrt((N_s * int_start T^2 + N_e * int_stop T^2 + t_run * T_rms^2) / (N_s t_start + N_e t_stop + t_run
                + K t_rest)),  t_run = r * 3600 s,  t_rest = 3600 s - N_s t_start - N_e t_stop - t_run,

against the rated torque T_rated = P_rated / w_rated: ``duty_torque_rms_to_rated`` <= 1 for the duty.  The
brake's thermal load is its energy per stop times the stops per hour (``brake_power_mean`` [W]).  The rows are
a :class:`harness.reporting.quantities.Quantities`, so ``--limits`` judges them as a run's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness.errors import SystemDescriptionError

HOUR = 3600.0
NAMES = ("startup_torque_rms", "stop_torque_rms", "motor_torque_rms", "duty_torque_rms", "motor_torque_rated",
         "duty_torque_rms_to_rated", "brake_energy_per_stop", "brake_power_mean")   # the rows, in order


@dataclass(frozen=True)
class Duty:
    """The duty the engineer states: starts and stops per hour, the running share of the hour (None: all the
    starts and stops leave), the cooling at rest."""
    starts: float
    stops: float
    running: float | None = None
    cooling_at_rest: float = 0.5

    def check(self) -> None:
        for name, v in (("--starts-per-hour", self.starts), ("--stops-per-hour", self.stops)):
            if not (math.isfinite(v) and v >= 0):
                raise SystemDescriptionError(f"{name} {v:g}: give a number of events per hour >= 0")
        if self.running is not None and not 0.0 <= self.running <= 1.0:
            raise SystemDescriptionError(f"--running {self.running:g}: give the running share of the hour, 0 to 1")
        if not 0.0 < self.cooling_at_rest <= 1.0:
            raise SystemDescriptionError(f"--cooling-at-rest {self.cooling_at_rest:g}: give the motor's cooling at "
                                         f"rest relative to running, in (0, 1]")


def _square_integral(df, column: str, a: float, b: float) -> tuple[float, float]:
    """(integral of x^2 dt over [a, b] (trapezoidal), b - a)."""
    t = df.index.to_numpy(dtype=float)
    on = (t >= a) & (t <= b)
    x = df[column].to_numpy(dtype=float)[on]
    return float(np.trapezoid(x * x, t[on])), b - a


def duty(system, stated: Duty, **options):
    """The duty cycle's rows (module docstring) as a Quantities table; ``options``: :func:`harness.run.simulate`'s."""
    from harness.reporting.quantities import Quantities, Row, parameter
    from harness.run import load, simulate, simulate_scenario

    system = load(system)
    stated.check()
    spec = system.quantities
    if spec is None or spec.motor is None or not {"startup", "estop"} <= {s.name for s in system.scenarios}:
        raise SystemDescriptionError(f"system {system.name}: a duty needs a motor (QuantitySpec.motor) and the "
                                     f"startup and estop scenarios (systems/__init__.py motor_scenarios)")
    torque = f"{spec.motor}.motor_torque"
    plain = simulate(system, **options)
    rms = plain.attrs["quantities"]["motor_torque_rms"]
    if rms is None:
        raise SystemDescriptionError(f"system {system.name}: its default run gives no steady motor torque "
                                     f"({plain.attrs['quantities'].cycles.reason})")
    up = simulate_scenario(system, "startup", **options)
    steady = up.attrs["quantities"].cycles.steady
    start_sq, t_start = _square_integral(up, torque, float(up.index[0]),
                                         steady[0] if steady is not None else float(up.index[-1]))
    down = simulate_scenario(system, "estop", **options)
    tq = down.attrs["transient"]
    command = down.attrs["stop_command"]
    settle = tq["settle_time"] if tq["settle_time"] is not None else float(down.index[-1]) - command
    stop_sq, t_stop = _square_integral(down, torque, command, command + settle)
    busy = stated.starts * t_start + stated.stops * t_stop
    if busy > HOUR:
        raise SystemDescriptionError(f"{stated.starts:g} starts ({t_start:.3g} s each) and {stated.stops:g} stops "
                                     f"({t_stop:.3g} s each) take {busy:.4g} s: more than an hour")
    t_run = HOUR - busy if stated.running is None else min(stated.running * HOUR, HOUR - busy)
    t_rest = HOUR - busy - t_run
    heat = stated.starts * start_sq + stated.stops * stop_sq + t_run * rms * rms
    t_eq = math.sqrt(heat / (busy + t_run + stated.cooling_at_rest * t_rest))
    rated = float(parameter(system, plain, spec.motor, "P_rated")) / float(parameter(system, plain, spec.motor,
                                                                                      "w_rated"))
    energy = tq["brake_energy"] if "brake_energy" in tq else None
    duty_text = (f"{stated.starts:g} starts and {stated.stops:g} stops per hour, running {t_run / 60:.4g} min, at rest "
                 f"{t_rest / 60:.4g} min (cooling at rest {stated.cooling_at_rest:g})")
    rows = [
        Row("startup_torque_rms", math.sqrt(start_sq / t_start), "N.m", "start-up",
            f"sqrt(mean T^2) of the motor from rest to its first steady cycle ({t_start:.4g} s)"),
        Row("stop_torque_rms", math.sqrt(stop_sq / t_stop) if t_stop > 0 else 0.0, "N.m", "stop",
            f"sqrt(mean T^2) of the motor from the stop command to settled ({t_stop:.4g} s)"),
        Row("motor_torque_rms", rms, "N.m", "steady", "sqrt(mean T^2) of the motor over the steady cycles"),
        Row("duty_torque_rms", t_eq, "N.m", "duty", f"equivalent RMS torque over the hour: {duty_text}"),
        Row("motor_torque_rated", rated, "N.m", "rating", "T_rated = P_rated / w_rated"),
        Row("duty_torque_rms_to_rated", t_eq / rated, "1", "duty", "T_eq / T_rated: <= 1 for this duty"),
        Row("brake_energy_per_stop", energy, "J", "stop", "energy the brake dissipates per stop",
            "" if energy is not None else "the stop's brake energy is not known"),
        Row("brake_power_mean", None if energy is None else energy * stated.stops / HOUR, "W", "duty",
            "the brake's mean thermal load: energy per stop times stops per hour"),
    ]
    assert tuple(r.name for r in rows) == NAMES
    table = Quantities(system.name, rows, None, spec.shaft_name, spec.cycle_name)
    table.heading = lambda: f"{system.name}: the motor's thermal duty, {duty_text}"
    table.runs = {"steady": plain, "startup": up, "estop": down}     # the three runs it was taken from
    return table


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "duty", help="the motor's thermal check over a duty cycle: starts and stops per hour",
        description="Run the drive's default run, its startup and its estop scenarios and combine the motor's "
                    "torque over the hour you state into an equivalent RMS torque against the rated torque, and "
                    "the brake's mean thermal load.")
    p.add_argument("system", help="system name in systems/ (e.g. bed_drive) or a .py file defining SYSTEM")
    p.add_argument("--starts-per-hour", dest="starts", type=float, required=True, metavar="N",
                   help="starts from rest per hour")
    p.add_argument("--stops-per-hour", dest="stops", type=float, required=True, metavar="N",
                   help="emergency stops per hour")
    p.add_argument("--running", type=float, default=None, metavar="SHARE",
                   help="share of the hour the press runs at speed, 0 to 1 (default: all the starts and stops "
                        "leave)")
    p.add_argument("--cooling-at-rest", type=float, default=0.5, metavar="K",
                   help="the motor's cooling at standstill relative to running (default: 0.5, self-ventilated)")
    p.add_argument("--limits", type=Path, default=None, metavar="FILE.yaml",
                   help="judge the duty's rows against limits (as run --limits); exit status 3 when any fails "
                        "(default: no limits)")
    p.add_argument("--out", type=Path, default=None, metavar="FILE.json",
                   help="write the rows as JSON (default: printed only)")
    p.set_defaults(func=_cli)


def _cli(args) -> int:
    from harness.reporting import limits
    from harness.results import check_writable
    from harness.run import RunOptions

    if args.out is not None:
        check_writable(args.out, "--out")
    found = limits.read(args.limits) if args.limits is not None else []
    limits.check_names(found, list(NAMES), f"limits file {args.limits}", "duty")
    stated = Duty(args.starts, args.stops, args.running, args.cooling_at_rest)
    stated.check()
    table = duty(args.system, stated, options=RunOptions(progress=None))
    verdicts = limits.judge(found, [("duty", table)]) if found else []
    limits.mark(table, verdicts, "duty")
    print(table.table())
    if args.out is not None:
        table.write_json(args.out)
        print(f"wrote {args.out}")
    if verdicts:
        print(limits.table(verdicts, f"limits of {args.limits}"))
        if any(not v.passed for v in verdicts):
            return limits.FAILED
    return 0


__all__ = ["Duty", "duty"]
