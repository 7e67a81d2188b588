"""What may be asked of a system, declared with it in ``systems/<name>.py`` (pure data, no stepping code).

* :class:`Scene`: a question answered with the coarsest model that still answers it
  (:mod:`harness.studies.scenes`);
* :class:`PrecisionSpec`: the quantity and default grid of the work-precision study
  (:mod:`harness.studies.precision`);
* :class:`StabilitySpec`: the coupling parameter and defaults of a press drive's stability map
  (:mod:`harness.studies.stability`);
* :class:`ChartSpec`: what the run chart shows -- the signals with their meaning, the parts of the machine
  cycle to shade (:class:`Zone`) and the main shaft's angle for the chart over one cycle
  (:mod:`harness.reporting.charts`);
* :class:`QuantitySpec`: the engineering quantities of the drive over its steady machine cycles -- its main
  shaft, its motor, the loads of its parts (:class:`Load`) and its own questions (:class:`Answer`)
  (:mod:`harness.reporting.quantities`).

They are fields of :class:`harness.model.System` (``scenes``, ``precision``, ``stability``, ``chart``,
``quantities``), so adding a drive touches one file.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable


def load_file(path, what: str):
    """The data of a YAML (or, by its suffix, JSON) file a user hands in (a scenario, limits), refused in one line
    naming ``what`` and the file when it is missing or cannot be read."""
    import json
    from pathlib import Path

    from harness.errors import SystemDescriptionError

    path = Path(path)
    if not path.is_file():
        raise SystemDescriptionError(f"{what} {path} does not exist")
    try:
        if path.suffix.lower() == ".json":
            return json.loads(path.read_text())
        import yaml

        return yaml.safe_load(path.read_text())
    except Exception as e:  # a malformed file: one line naming it
        raise SystemDescriptionError(f"{what} {path}: cannot be read ({type(e).__name__}: "
                                     f"{str(e).splitlines()[0]})") from None


@dataclass
class Scene:
    name: str
    question: str
    quantity: str                 # harness.reporting.qoi expression
    tolerance: float              # admissible |error| of the quantity (absolute, in its own unit) ...
    relative: bool = True         # ... or relative to the full model's value when True
    stop_time: float | None = None
    window: tuple[float, float] | None = None  # documented time window (use window() in the quantity)
    unit: str = ""
    step: float | None = None     # the full model's communication step (default: the system's experiment)


@dataclass(frozen=True)
class PrecisionSpec:
    """What the precision study of a system compares and its default grid.

    ``quantity``: the result column of the quantity of interest (``label``, ``unit`` for the chart);
    ``columns``: further columns compared (reported in the CSV); ``stop_time`` [s]: the study's default run
    length (short: a study must stay cheap); ``steps`` [s]: default fixed communication steps;
    ``tolerances``: default tolerances of the variable-step controllers; ``t_start`` [s]: start of the
    compared window (0: everything)."""
    quantity: str
    label: str
    unit: str
    stop_time: float
    steps: tuple[float, ...]
    columns: tuple[str, ...] = ()
    tolerances: tuple[float, ...] = (1e-2, 1e-3, 1e-4)
    t_start: float = 0.0

    @property
    def compared(self) -> list[str]:
        return [self.quantity] + [c for c in self.columns if c != self.quantity]


@dataclass(frozen=True)
class StabilitySpec:
    """Defaults of the stability map of one press drive: the swept parameter (the stiffness that couples two
    FMUs), its values, the physical run length [s] and an estimate of the stiffest coupled mode [rad/s] from
    the parameters (``omega(p)`` with ``p("inst.param") -> value``; a LOWER estimate lengthens the runs)."""
    sweep: str
    values: tuple
    quick_values: tuple
    duration: float
    omega: Callable
    doc: str


@dataclass(frozen=True)
class Panel:
    """One panel of the run chart: ``title`` says the signal and its meaning in the press's words (``"Bed
    position s"``; the chart adds the unit), ``columns`` are the result columns drawn in it (several share a
    unit, e.g. torques; ``labels`` name them in the legend, default the column names).  ``cycle``: drawn
    over one machine cycle against the crank angle too."""
    title: str
    columns: tuple[str, ...]
    labels: tuple[str, ...] = ()
    cycle: bool = True


@dataclass(frozen=True)
class Zone:
    """A part of the machine cycle shaded on the charts (the printing zone, a dwell): the samples where
    ``where`` holds, a :mod:`harness.reporting.qoi` expression with one truth value per sample, e.g.
    ``between(r["bed.bed.s"], 0.08, 0.24) & (r["bed.bed.v"] > 0)``.  Declared from the system's own
    numbers, so the shading moves with them."""
    label: str
    where: str


@dataclass(frozen=True)
class ChartSpec:
    """What the run chart of a system shows (``run ... --plot DIR``).  ``crank_angle``: the result column of
    the main shaft's angle [rad], cumulative; with it a second chart draws the ``cycle`` panels over the
    last complete revolution against the crank angle in degrees, counted from ``cycle_origin`` [rad] (what
    that angle is: ``origin_name``, e.g. "start of the working stroke"), as the seeds draw them; a machine
    cycle other than one revolution (``cycle_angle`` [rad]) is drawn in machine degrees, 360 per cycle.  Without
    panels the chart falls back to the speed and effort of every power bond."""
    panels: tuple[Panel, ...] = ()
    zones: tuple[Zone, ...] = ()
    crank_angle: str | None = None
    cycle_origin: float = 0.0
    origin_name: str = ""
    cycle_angle: float = 2 * math.pi   # rad of crank_angle per machine cycle (the trimmer: one block pitch)


@dataclass(frozen=True)
class Requirement:
    """One accuracy a press engineer states for a drive, checked against the monolithic reference
    (:mod:`harness.studies.accuracy`).

    ``quantity``: a :mod:`harness.reporting.qoi` expression.  One value per sample (``r["bed.bed.s"]``): compared sample by
    sample at the run's communication points (the reference interpolated there), only where ``where`` (a
    per-sample qoi expression, evaluated on the reference) holds; error = max |run - reference|.  Any other
    value (a scalar such as ``peak(...)``, or a list of event instants): compared as it is, element by
    element, on the reference's own fine grid; a list of another length fails, saying both.  ``relative``:
    ``tolerance`` is relative to max |reference| over what is compared."""
    name: str
    quantity: str
    tolerance: float
    unit: str
    relative: bool = False
    where: str | None = None


@dataclass(frozen=True)
class AccuracySpec:
    """The accuracy a drive must meet, in the engineer's terms (``requirements``), over ``stop_time`` [s]
    of its default experiment; the reference is sampled every ``reference_step`` [s].

    ``sampled_host_step`` [s]: the largest step of the ladder 0.5, 0.2, 0.1, 0.05 ms (where it divides the stop
    time) at which a host that reads outputs right after ``fmi2DoStep`` and holds them over the next step
    (libcosim, Ecos, FMPy's ``simulate_ssp``; the harness's ``jacobi-sampled`` with hold) meets the
    requirements; measured, recorded by the drive, checked by tests/test_host_accuracy.py.  The SSP export
    declares it as the OSP step such hosts take (:func:`harness.ssp.export_ssp`); None: the experiment's."""
    requirements: tuple[Requirement, ...]
    stop_time: float
    reference_step: float = 1e-4
    sampled_host_step: float | None = None


@dataclass(frozen=True)
class Load:
    """A load one part of the drive carries (a joint, contact, mesh, rack or shaft): ``column`` is its result
    column, ``what`` says what it is in the press's words.  Reported as ``<name>_peak`` (max |x|, static
    sizing) and ``<name>_range`` (max - min, fatigue) over the steady cycles and ``<name>_startup_peak`` over
    the start-up (:mod:`harness.reporting.quantities`)."""
    name: str
    column: str
    what: str
    slope: float = 5.0    # Wohler slope m of its damage-equivalent range (5: machined shafts)


@dataclass(frozen=True)
class Shaft:
    """A solid round shaft whose torque is the :class:`Load` ``load``: its shear stress tau = 16 T / (pi d^3)
    [MPa], peak and damage-equivalent, from the diameter the instance parameter ``diameter``
    (``"Instance.parameter"`` [m]) holds; ``share``: the share of the load's torque one shaft carries (0.5 for
    two equal shafts in parallel)."""
    load: str
    diameter: str
    share: float = 1.0


@dataclass(frozen=True)
class Belt:
    """A belt whose torque on a pulley is the :class:`Load` ``load``; the pulley's pitch diameter is the instance
    parameter ``diameter`` (``"Instance.parameter"`` [m]).  Its transmittable torque on that pulley
    T = F_1 (1 - exp(-mu' beta)) r (Euler-Eytelwein, :func:`harness.reporting.fatigue.belt_capacity`):
    ``tight_force`` F_1 [N] the allowable tight-side force of the belt(s), ``mu`` the friction coefficient,
    ``wrap`` beta [deg] on the pulley that slips first, ``groove`` the V-groove's angle [deg] (0: flat belt);
    ``source`` says where the numbers come from."""
    load: str
    diameter: str
    tight_force: float
    mu: float
    wrap: float
    groove: float = 0.0
    source: str = ""


@dataclass(frozen=True)
class Answer:
    """A drive's own question, answered over its steady cycles (:mod:`harness.reporting.quantities`).  ``kind``:

    * ``peak`` (max |x|), ``max``, ``min``, ``mean`` (time mean), ``rms``, ``range`` (max - min) of
      ``columns[0]`` over the steady samples where ``where`` holds (a :mod:`harness.reporting.qoi` expression with
      one truth value per sample; None: all);
    * ``fluctuation``: per steady cycle (max - min) / (time mean) of the speed ``columns[0]`` where
      ``where`` holds (the spread of a speed through a zone), the largest over the cycles;
    * ``register``: per steady cycle, over the stretch where ``where`` holds, the largest |x - x_u| of the
      position ``columns[0]`` against uniform motion x_u (the straight line through the stretch's first and
      last samples: the stretch's mean speed), the largest over the cycles;
    * ``angles``: the crank angles [deg from the cycle origin] at which the counter ``columns[0]`` rises, in
      the last steady cycle;
    * ``impacts``: for each rise of the counter ``columns[0]`` in the last steady cycle, the peak |force| of
      ``columns[1]`` until the contact flag ``columns[2]`` drops to 0 (or the next rise, or the cycle's end).

    The value is shown in ``unit``: the column's value times ``scale`` (1e6 for m -> um; 100 for a ratio in
    %)."""
    name: str
    kind: str
    columns: tuple[str, ...]
    unit: str
    what: str
    where: str | None = None
    scale: float = 1.0


@dataclass(frozen=True)
class QuantitySpec:
    """The engineering quantities of a drive, printed after every run (:mod:`harness.reporting.quantities`).

    The machine cycle is ``cycle_angle`` [rad] of the main shaft's cumulative angle ``shaft_angle``, counted
    from ``cycle_origin`` [rad] (``cycle_name`` says what one cycle is: "revolution of the main shaft", "block
    pitch"); ``shaft_speed`` is the main shaft's speed column [rad/s] and ``shaft_name`` says which shaft and
    which side of its compliance that is.  A cycle is steady when its mean speed is within ``settle``
    (relative) of the cycle before's and every later cycle's is too; what comes before is the start-up.

    ``motor``: the MotorBelt instance whose torque, electrical power and rating are reported (None: none);
    ``loads``: every joint, contact, mesh, rack and shaft load; ``answers``: the drive's own questions;
    ``shafts``: the shear stress of the shafts among the loads; ``belts``: the belts' transmittable torque and
    slip margin."""
    shaft_angle: str
    shaft_speed: str
    shaft_name: str
    cycle_origin: float = 0.0
    cycle_angle: float = 2 * math.pi
    cycle_name: str = "revolution of the main shaft"
    motor: str | None = None
    loads: tuple[Load, ...] = ()
    answers: tuple[Answer, ...] = ()
    settle: float = 1e-3
    shafts: tuple[Shaft, ...] = ()
    belts: tuple[Belt, ...] = ()
    brakes: tuple[tuple[str, str, str, str], ...] = ()   # (name, torque column, speed column, what): a stop's
    # brakes whose energy it reports (harness.reporting.stops); empty: the motor's rotor brake


@dataclass(frozen=True)
class Change:
    """A time event of a :class:`Scenario`: at ``time`` [s] the free input ``variable`` (``Instance.input``)
    steps to ``value``, or, with ``ramp`` > 0 [s], moves to it linearly over [time, time + ramp]."""
    time: float
    variable: str
    value: float
    ramp: float = 0.0


@dataclass(frozen=True)
class Scenario:
    """A transient a drive is sized by (start-up, speed change, emergency stop, jam), run by
    :mod:`harness.scenarios`: ``parameters`` (``Instance.parameter`` -> value) set the drive up for it (from
    rest, a brake's torque), ``changes`` drive its free inputs over time, ``stop_time`` [s] is its run.
    ``kind`` names what the transient quantities measure: ``startup`` (from rest to speed), ``speed_change``,
    ``stop`` (an emergency stop from the first change on), ``load`` (a load step) or ``jam`` (the tool runs into
    an end stop the scenario sets, :mod:`harness.reporting.jams`); ``watch``: the tool's position column (the bed,
    the knife) whose overrun a stop reports.  A stop or a jam runs past ``stop_time`` until the drive has settled
at rest (``settle_hold`` [s]), up to ``settle_limit`` [s] (:mod:`harness.run.settling`).
``accuracy``: what the
    scenario's question needs against the monolithic reference (``study accuracy DRIVE --scenario NAME``,
    :func:`harness.studies.accuracy.search_scenario`): :class:`Requirement` whose ``quantity`` is a transient
    quantity's name (``stopping_time``, ``shaft_torque_peak``: compared as a number) or a qoi expression."""
    name: str
    question: str
    kind: str
    stop_time: float
    changes: tuple[Change, ...] = ()
    parameters: tuple[tuple[str, float], ...] = ()
    watch: str | None = None
    accuracy: tuple[Requirement, ...] = ()
    settle_hold: float | None = None     # s: a stop is settled after this long at rest (None: 0.25 s)
    settle_limit: float | None = None    # s: a stop's run goes on to at most this (None: 4 x stop_time)

    KINDS = ("startup", "speed_change", "stop", "load", "jam")
