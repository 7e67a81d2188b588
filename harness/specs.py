"""What may be asked of a system, declared with it in ``systems/<name>.py`` (pure data, no stepping code).

* :class:`Scene`: a question answered with the coarsest model that still answers it
  (:mod:`harness.studies.scenes`);
* :class:`PrecisionSpec`: the quantity and default grid of the work-precision study
  (:mod:`harness.studies.precision`);
* :class:`StabilitySpec`: the coupling parameter and defaults of a press drive's stability map
  (:mod:`harness.studies.stability`).

They are fields of :class:`harness.model.System` (``scenes``, ``precision``, ``stability``), so adding a drive
touches one file.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


@dataclass
class Scene:
    name: str
    question: str
    quantity: str                 # harness.qoi expression
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
