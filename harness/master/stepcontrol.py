"""Communication step-size control: small strategy objects, chosen by name (:data:`STEP_CONTROLS`).

Each strategy implements ``advance(master, t_ns, h_ns, stop_ns) -> (t_new_ns, h_next_ns)``: take one
ACCEPTED communication step from ``t_ns`` (possibly after rejected attempts rolled back with FMU state) and
propose the next step; its ``step_ns`` is the first step.  Times are integer nanoseconds.  It is called by the
one run loop, :meth:`harness.master.Master.run`, and takes steps only through ``master.step``.

``FixedStep`` (default)   every step the same (the last one shortened to land on the stop time).
``StepDoubling``          Richardson extrapolation error estimate as in PyFMI's Master: one step of h and two
                          of h/2 from the same state; ``err = RMS((y_2 - y_1) / (atol + rtol*|y_2|))`` over
                          the coupling outputs; accepted when ``err <= 1`` (keeping the two half steps);
                          ``h_new = h * min(max_factor, max(min_factor, safety * err**(-1/(p+2))))`` with
                          ``p`` the coupling order (1 with zero-order hold, 2 with midpoint extrapolation).
``Ecco``                  energy-conservation step control of libcosim for power bonds (no rollback): per bond
                          the energy residual ``|P_out - P_in| * h`` normalised by ``atol + rtol*|P|*h`` (``|P|``
                          the mean of the two powers), RMS over bonds, then a PI controller
                          ``h_new = h * safety * err**-(kI+kP) * err_prev**kP`` (kP = 0.2, kI = 0.15,
                          safety 0.99), the change limited to [0.2, 1.5] per step and h to [min_step, max_step].

Variable steps need ``canHandleVariableCommunicationStepSize`` of every FMU (checked by :func:`step_control`);
step doubling needs ``canGetAndSetFMUstate`` as well.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from harness.errors import SimulationError, StepDiscarded, SystemDescriptionError

from harness.master.clock import NS


@dataclass
class StepOptions:
    """Options of the variable-step controllers (seconds).  None: defaults derived from the nominal step
    (min_step = step/1000, max_step = 100*step) and the controller (safety, factor limits).  ``atol`` is
    the absolute error scale (outputs for step doubling, energy [J] for ECCO); ``rtol`` defaults to the run's
    tolerance (1e-4 if none)."""
    min_step: float | None = None
    max_step: float | None = None
    safety: float | None = None
    min_factor: float | None = None
    max_factor: float | None = None
    atol: float | None = None
    rtol: float | None = None
    kP: float = 0.2
    kI: float = 0.15


def _ns(seconds: float) -> int:
    return max(1, int(round(seconds * NS)))


class FixedStep:
    name = "none"
    variable = False
    rejected = 0
    max_accepted_error = 0.0

    def __init__(self, step_ns: int, tolerance=None, options: StepOptions | None = None, order: int = 1):
        self.step_ns = step_ns

    def advance(self, master, t_ns: int, h_ns: int, stop_ns: int):
        h = min(self.step_ns, stop_ns - t_ns)
        master.step(t_ns, h)
        return t_ns + h, self.step_ns


class _Variable:
    variable = True
    defaults: dict = {}

    def __init__(self, step_ns: int, tolerance=None, options: StepOptions | None = None, order: int = 1):
        self.step_ns = step_ns  # the first step proposed
        o = options or StepOptions()
        d = self.defaults
        self.min_ns = _ns(o.min_step) if o.min_step is not None else max(2, step_ns // 1000)
        self.max_ns = _ns(o.max_step) if o.max_step is not None else step_ns * 100
        self.safety = o.safety if o.safety is not None else d["safety"]
        self.min_factor = o.min_factor if o.min_factor is not None else d["min_factor"]
        self.max_factor = o.max_factor if o.max_factor is not None else d["max_factor"]
        self.rtol = o.rtol if o.rtol is not None else (tolerance if tolerance is not None else 1e-4)
        self.atol = o.atol if o.atol is not None else self.rtol
        self.kP, self.kI = o.kP, o.kI
        self.order = order
        for name in ("rtol", "atol", "safety", "min_factor", "max_factor"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and value > 0 and math.isfinite(value)):
                raise SystemDescriptionError(f"step control {self.name}: {name} = {value!r} must be > 0")
        if not self.min_ns <= self.max_ns:
            raise SystemDescriptionError(f"step control {self.name}: min_step = {self.min_ns / NS:g} s exceeds "
                               f"max_step = {self.max_ns / NS:g} s")
        self.accepted = 0
        self.rejected = 0
        self.max_accepted_error = 0.0

    def _clamp(self, h_ns: float) -> int:
        return int(min(self.max_ns, max(self.min_ns, h_ns)))

    def restart(self) -> None:
        """A time event (an input stepped): the error history before it says nothing of the steps after it."""


class StepDoubling(_Variable):
    name = "richardson"
    needs_state = True
    defaults = dict(safety=0.9, min_factor=0.2, max_factor=6.0)

    def error(self, y1: np.ndarray, y2: np.ndarray) -> float:
        if y1.size == 0:
            return 0.0
        return float(np.sqrt(np.mean(((y2 - y1) / (self.atol + self.rtol * np.abs(y2))) ** 2)))

    def advance(self, master, t_ns, h_ns, stop_ns):
        idx = master.coupling_signals()
        h_ns = self._clamp(h_ns)
        while True:
            h = min(h_ns, stop_ns - t_ns)
            h -= h % 2 if h > 1 else 0  # two equal integer half steps
            if h <= 0:
                h = stop_ns - t_ns
            master.snapshot("richardson")
            try:
                master.step(t_ns, h)
                y1 = master.y[idx].copy()
                master.restore("richardson")
                half = h // 2
                master.step(t_ns, half)
                master.step(t_ns + half, h - half)
                y2 = master.y[idx]
                err = self.error(y1, y2)
            except (StepDiscarded, SimulationError) as e:
                if h <= self.min_ns:
                    raise
                master.restore("richardson")
                self.rejected += 1
                h_ns = self._clamp(h * self.min_factor)
                _ = e
                continue
            factor = self.max_factor if err == 0.0 else min(
                self.max_factor, max(self.min_factor, self.safety * err ** (-1.0 / (self.order + 2))))
            if err <= 1.0 or h <= self.min_ns:
                self.accepted += 1
                self.max_accepted_error = max(self.max_accepted_error, err)
                return t_ns + h, self._clamp(h * factor)
            self.rejected += 1
            master.restore("richardson")
            h_ns = self._clamp(h * factor)


class Ecco(_Variable):
    name = "ecco"
    needs_state = False
    defaults = dict(safety=0.99, min_factor=0.2, max_factor=1.5)

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.prev_err = 1.0

    def restart(self) -> None:
        self.prev_err = 1.0   # the PI controller's memory of the last error

    def error(self, master, h: float) -> float:
        p = master.bond_power
        if p.shape[1] == 0:
            return 0.0
        residual = np.abs(p[0] - p[1]) * h
        scale = self.atol + self.rtol * 0.5 * (np.abs(p[0]) + np.abs(p[1])) * h
        return float(np.sqrt(np.mean((residual / scale) ** 2)))

    def advance(self, master, t_ns, h_ns, stop_ns):
        h = min(self._clamp(h_ns), stop_ns - t_ns)
        master.step(t_ns, h)
        err = max(self.error(master, h / NS), 1e-12)
        factor = self.safety * err ** (-(self.kI + self.kP)) * self.prev_err ** self.kP
        factor = min(self.max_factor, max(self.min_factor, factor))
        self.prev_err = err
        self.accepted += 1
        self.max_accepted_error = max(self.max_accepted_error, err)
        return t_ns + h, self._clamp(h * factor)


STEP_CONTROLS = {"none": FixedStep, "fixed": FixedStep, "richardson": StepDoubling,
                 "step-doubling": StepDoubling, "ecco": Ecco}


def step_control(name, master, step_ns: int, tolerance=None, options: StepOptions | None = None):
    """The step-control strategy ``name`` for ``master`` (capabilities of its FMUs checked)."""
    key = "none" if name is None else str(name).strip().lower()
    if key not in STEP_CONTROLS:
        raise SystemDescriptionError(f"step_control = {name!r} is not admissible: must be one of none, richardson, ecco")
    cls = STEP_CONTROLS[key]
    if cls.variable:
        for it in master.insts:
            if not it.fmu.can_vary_step:
                raise SystemDescriptionError(f"step_control = {key!r} needs variable communication steps, but instance "
                                   f"{it.name} does not declare canHandleVariableCommunicationStepSize")
            if cls.needs_state and not it.fmu.can_get_set_state:
                raise SystemDescriptionError(f"step_control = {key!r} needs rollback, but instance {it.name} does not "
                                   f"declare canGetAndSetFMUstate")
        if key == "ecco" and not master.bond_labels:
            raise SystemDescriptionError("step_control = 'ecco' needs at least one power bond in the system")
    order = 2 if master.extrapolation.order >= 1 else 1
    return cls(step_ns, tolerance, options, order)
