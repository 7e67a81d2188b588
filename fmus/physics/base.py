"""Common pieces of the equation layer: parameter declarations and the model interface.

A component is a parameter dataclass plus a :class:`Model` subclass.  Parameters are declared once, with
:func:`param`, carrying default, unit, description and admissible range; the FMU layer registers them from
here and the tests read them from here.  Nothing in this module knows about FMI.
"""
from __future__ import annotations

import math
from dataclasses import MISSING, dataclass, field, fields
from typing import Any, ClassVar, Sequence

import numpy as np

from . import integrate
from .mathns import SCALAR


DIFFERENCE_STEP = 6e-6   # relative step of Model.output_jacobian_by_differences (~ cube root of the float epsilon)


class ParameterError(ValueError):
    """A parameter value that is not physical.  The message names the parameter and the value; ``requirement``
    says what is admissible in words, and where that is a range of the parameter alone, ``low``, ``high``,
    ``low_open`` and ``choices`` give it as data (as :func:`param` declares it; None where there is none)."""

    def __init__(self, name: str, value: Any, requirement: str, *, low: float | None = None,
                 high: float | None = None, low_open: bool = False, choices: Sequence[int] | None = None):
        self.name, self.value, self.requirement = name, value, requirement
        self.low, self.high, self.low_open = low, high, low_open
        self.choices = tuple(choices) if choices is not None else None
        super().__init__(f"parameter {name} = {value!r} is not admissible: {requirement}")


def param(default, unit: str, doc: str, *, low: float | None = None, high: float | None = None,
          low_open: bool = False, choices: Sequence[int] | None = None):
    """Declare one parameter field.

    ``low``/``high`` bound the value (``low_open`` makes the lower bound strict, e.g. lengths > 0);
    ``choices`` lists the admissible values of an Integer parameter.  ``unit`` is an FMI unit name; an
    Integer parameter uses ``unit=""``.
    """
    meta = dict(unit=unit, doc=doc, low=low, high=high, low_open=low_open,
                choices=tuple(choices) if choices is not None else None)
    return field(default=default, metadata=meta)


@dataclass(frozen=True)
class ParamSpec:
    name: str
    default: Any
    unit: str
    doc: str
    is_integer: bool


_SPECS: dict = {}   # Params class -> its ParamSpec tuple (Params.specs)
_BOUNDS: dict = {}  # Params class -> (name, unit, low, high, low_open, choices) per field (Params.validate)


def _bounds(cls) -> tuple:
    """The admissible ranges of a parameter class's fields, read from their metadata once per class."""
    known = _BOUNDS.get(cls)
    if known is None:
        known = _BOUNDS[cls] = tuple((f.name, f.metadata["unit"], f.metadata.get("low"), f.metadata.get("high"),
                                      bool(f.metadata.get("low_open")), f.metadata.get("choices"))
                                     for f in fields(cls))
    return known


@dataclass(frozen=True)
class Params:
    """Base of every parameter dataclass: range checks from the field metadata."""

    def validate(self) -> None:
        for name, unit, low, high, low_open, choices in _bounds(type(self)):
            value = getattr(self, name)
            bounds = dict(low=low, high=high, low_open=low_open, choices=choices)
            if isinstance(value, float) and not math.isfinite(value):
                raise ParameterError(name, value, "must be finite", **bounds)
            if choices is not None and value not in choices:
                raise ParameterError(name, value, f"must be one of {list(choices)}", **bounds)
            if low is not None:
                if low_open and not value > low:
                    raise ParameterError(name, value, f"must be > {low:g} {unit}".rstrip(), **bounds)
                if not low_open and not value >= low:
                    raise ParameterError(name, value, f"must be >= {low:g} {unit}".rstrip(), **bounds)
            if high is not None and not value <= high:
                raise ParameterError(name, value, f"must be <= {high:g} {unit}".rstrip(), **bounds)
        self.check()

    def check(self) -> None:
        """Cross-parameter checks of a component (e.g. Grashof condition); raise ParameterError."""

    @classmethod
    def specs(cls) -> list[ParamSpec]:
        """Every parameter's declaration, in field order (read once per class: a batch builds a model per variant)."""
        known = _SPECS.get(cls)
        if known is None:
            out = []
            for f in fields(cls):
                default = f.default if f.default is not MISSING else f.default_factory()  # type: ignore[misc]
                out.append(ParamSpec(f.name, default, f.metadata["unit"], f.metadata["doc"],
                                     isinstance(default, int) and not isinstance(default, bool)))
            known = _SPECS[cls] = tuple(out)
        return list(known)

    @classmethod
    def from_mapping(cls, values: dict[str, Any]):
        """Build from a mapping, ignoring keys that are not parameters of this component."""
        names = {b[0] for b in _bounds(cls)}
        return cls(**{k: v for k, v in values.items() if k in names})


def last_call(fn):
    """``fn`` with a one-entry memo: a call with the same arguments as the previous one returns the previous
    result.  For a pure function of the inputs that a master asks for twice at one communication point (the
    outputs before and after a feed-through input is set, with the same motion inputs); the memo changes no
    number, and a model that keeps one stays immutable in everything that evolves (the state is in ``x``)."""
    memo = [None, None]

    def call(*args):
        if args != memo[0]:
            memo[0], memo[1] = args, fn(*args)
        return memo[1]
    return call


@dataclass(frozen=True)
class Signal:
    """A named input, output or state of a model, with its unit and meaning."""
    name: str
    unit: str
    doc: str


class Model:
    """Interface every component model implements (inputs are held constant over a call of advance).

    Class attributes:
      ``Params``   the parameter dataclass;
      ``inputs``   input names, the order of the ``u`` sequence passed to every method;
      ``outputs``  output names, the order of the sequence returned by :meth:`output`;
      ``states``   :class:`Signal` entries naming the continuous state vector ``x``;
      ``max_substep`` the largest internal integration step [s] (``inf``: one step per call).

    Instances are immutable after construction: everything that evolves lives in ``x``, so saving ``x``
    (and the time) saves the component.
    """

    Params: ClassVar[type[Params]]
    inputs: ClassVar[tuple[str, ...]] = ()
    outputs: ClassVar[tuple[str, ...]] = ()
    states: ClassVar[tuple[Signal, ...]] = ()
    # the event indicators of the model's switches (a clearance closing or opening), for a host that integrates
    # derivatives() itself (FMI 3.0 model exchange, fmus.slave3_me): event_indicators gives their values (a switch
    # is a sign change), at_event the memory update at a located one
    switches: ClassVar[tuple[Signal, ...]] = ()
    # whether the inputs set memory at once, so that a host that integrates derivatives() must call
    # advance(t, 0.0, x, u) when an input changes (a brake's timer restarted by a released command)
    input_memory: ClassVar[bool] = False
    # the math the equations take their functions from: ``math`` for this one variant (fmus.physics.mathns); a batch
    # of variants calls the same methods on a view whose ``m`` is the vector namespace (fmus.physics.variants)
    m: ClassVar = SCALAR
    # the batch form of the model (a subclass of fmus.physics.variants.Vectorised), None: each variant's scalar model
    Batch: ClassVar = None

    def __new__(cls, *args, **kwargs):
        self = super().__new__(cls)
        self.m = cls.m      # the instance's own: Python reads it faster than the class's (mathns._as_module)
        return self

    def __init__(self, p: Params):
        p.validate()
        self.p = p
        self.max_substep = self.substep_limit()

    # -- what a component implements -------------------------------------------------------------------
    def substep_limit(self) -> float:
        """Largest stable/accurate internal step for these parameters [s]."""
        return math.inf

    def initial_state(self, u: Sequence[float]) -> np.ndarray:
        return np.zeros(len(self.states))

    def derivatives(self, t: float, x: np.ndarray, u: Sequence[float], t0: float) -> np.ndarray:
        """dx/dt at time t inside a step that began at t0 (inputs ``u`` were given at t0)."""
        return np.zeros(len(self.states))

    def output(self, t: float, x: np.ndarray, u: Sequence[float]) -> Sequence[float]:
        raise NotImplementedError

    def output_jacobian(self, t: float, x: np.ndarray, u: Sequence[float]) -> np.ndarray:
        """d output(t, x, u) / d u: the direct feed-through block D (outputs x inputs, in the orders of
        ``outputs`` and ``inputs``) at the state ``x``, from the component's own equations.  It is what the FMU
        answers to fmi2GetDirectionalDerivative / fmi3GetDirectionalDerivative (co-simulation: partial derivatives
        of the outputs with respect to the inputs at the current time).  A component that implements it declares
        ``providesDirectionalDerivative``; one that does not keeps its FMU without (:meth:`provides_output_jacobian`).
        At a switch of a piecewise law (a contact closing, a saturation) it gives the one-sided derivative of the
        branch the output itself takes."""
        raise NotImplementedError(f"{type(self).__name__} declares no output Jacobian")

    def ode_form(self) -> str | None:
        """None when :meth:`derivatives` is the model at these parameters, for every state: integrating it (with
        :meth:`at_event` at the sign changes of :meth:`event_indicators`) is what :meth:`advance` approximates, so
        a host may integrate it (FMI 3.0 model exchange, fmus.slave3_me).
        Otherwise one line saying why not (a state that is a step quantity, contact memory updated only inside
        ``advance``).  Default: a model without states, or with derivatives of its own."""
        if not self.states or type(self).derivatives is not Model.derivatives:
            return None
        return f"{type(self).__name__} gives no derivatives (its advance is its only form)"

    def event_indicators(self, t: float, x: np.ndarray, u: Sequence[float]) -> Sequence[float]:
        """The values of ``switches`` at (t, x, u) (inputs at t: no position extrapolated, ``t0 = t``)."""
        return ()

    def at_event(self, t: float, x: np.ndarray, u: Sequence[float]) -> np.ndarray:
        """The state after a switch located at (t, x, u): the memory ``advance`` updates at that switch."""
        return x

    @classmethod
    def provides_output_jacobian(cls) -> bool:
        return cls.output_jacobian is not Model.output_jacobian

    def output_jacobian_by_differences(self, t: float, x: np.ndarray, u: Sequence[float]) -> np.ndarray:
        """:meth:`output_jacobian` by central differences of :meth:`output` in each input (step
        ``DIFFERENCE_STEP * max(1, |u_j|)``, truncation and rounding both ~1e-10 relative).  No component answers
        with it: each differentiates its own equations; the tests check those closed forms against it."""
        u = [float(v) for v in u]
        D = np.zeros((len(self.outputs), len(u)))
        for j, uj in enumerate(u):
            step = DIFFERENCE_STEP * max(1.0, abs(uj))
            up, um = list(u), list(u)
            up[j], um[j] = uj + step, uj - step
            D[:, j] = (np.asarray(self.output(t, x, up), dtype=float)
                       - np.asarray(self.output(t, x, um), dtype=float)) / (up[j] - um[j])
        return D

    # -- provided ----------------------------------------------------------------------------------------
    def advance(self, t0: float, h: float, x: np.ndarray, u: Sequence[float]) -> np.ndarray:
        """State at t0 + h.  Default: classical Runge-Kutta on equal sub-steps no larger than max_substep."""
        if len(x) == 0:
            return x
        return integrate.rk4(self.derivatives, t0, h, x, u, self.max_substep)
