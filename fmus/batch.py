"""N variants of one toolkit component run as its FMU runs each one: :class:`Batch`, the batch form of the base
slave's behaviour (:class:`fmus.slave_core.PressBehaviour`) for a master that steps many variants of a system at
once (:mod:`harness.master.batch`).

It keeps what the slave keeps, with a variant axis: the inputs as set (inputs x variants) and whether each was set
since the last step, the states (states x variants), the outputs and whether they are stale, the time and the last
step; and it does what the slave does with them: an output is computed with a motion-input position held over the
last step advanced by its held speed (``_inputs_now``), an input outside its declared range or not finite fails
the variant, a state that becomes non-finite fails the variant.  A failed variant is reported, not raised: the
others go on (:meth:`Batch.step` returns the failures).  The physics is the model's batch
(:mod:`fmus.physics.variants`): its vectorised form where it has one, else each variant's scalar model.

Not part of any FMU (``fmus/build.py`` bundles the runtime files it lists).
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from .declaration import Component
from .physics.base import ParameterError
from .physics.variants import Variants, batch_of, finite_columns, structure
from .refusal import Refusal


def typed_parameters(declaration: type[Component], given: dict) -> dict:
    """The model's parameters as its FMU holds them after ``given`` are set (defaults, then each given value in
    the FMI type of its parameter: an Integer that is not whole is refused in one line)."""
    specs = declaration.model.Params.specs()
    par = {s.name: s.default for s in specs}
    integer = {s.name for s in specs if s.is_integer}
    for name, value in given.items():
        if name not in par:
            raise KeyError(f"{declaration.__name__} has no parameter {name!r}")
        if name in integer:
            iv = int(value)
            if iv != value:
                raise ValueError(f"{name} = {value!r} is not an integer")
            par[name] = iv
        else:
            par[name] = float(value)
    return par


def build_model(declaration: type[Component], given: dict):
    """(model, None) of one variant, or (None, the one-line refusal its FMU gives: ``parameter ... is not
    admissible: ...``)."""
    cls = declaration.model
    try:
        par = typed_parameters(declaration, given)
    except (KeyError, ValueError) as e:
        return None, str(e).strip("'\"")
    try:
        return cls(cls.Params.from_mapping(par)), None
    except ParameterError as e:
        unit = next((s.unit for s in cls.Params.specs() if s.name == e.name), "")
        return None, Refusal.of(e, unit).sentence()


def model_structure(model) -> tuple:
    """The integer parameters of a built model: variants differing in them go to separate batches."""
    return structure(model)


class Batch:
    """The variants ``models`` (built by :func:`build_model`, one structure) of the component ``declaration`` named
    ``name`` in its system (module docstring).  ``vectorise``: use the model's vectorised form where it has one."""

    def __init__(self, declaration: type[Component], name: str, models: Sequence, vectorise: bool = True):
        self.declaration, self.name = declaration, name
        cls = declaration.model
        io = declaration.interface()
        self.input_names = [v.name for v in io if v.causality == "input"]
        self.output_names = list(cls.outputs)
        self.in_index = {n: i for i, n in enumerate(self.input_names)}
        self.out_index = {n: i for i, n in enumerate(self.output_names)}
        self.physics: Variants = batch_of(models, vectorise)
        n = len(models)
        self.U = np.array([[v.start] * n for v in io if v.causality == "input"], dtype=float).reshape(-1, n)
        self.X = np.zeros((len(cls.states), n))
        self.Y = np.zeros((len(self.output_names), n))
        self.fresh = [True] * len(self.input_names)
        self.advanced = [(self.input_names.index(pos),
                          self.input_names.index(f"{port.name}.{'v' if port.translational else 'w'}"))
                         for port, pos in zip(declaration.ports, declaration._port_positions()) if pos is not None]
        self.ranges = [(i, v.name, v.min, v.max) for i, v in enumerate(v for v in io if v.causality == "input")
                       if v.min is not None or v.max is not None]
        self.rows: list[int] | None = None     # the outputs read (None: all), set by the master
        self._checked = False                  # every input checked once (then: those set since)
        self._initial: tuple | None = None     # (inputs, states) of the last initial state, in initialisation
        self.time = 0.0
        self.last_step = 0.0
        self.initialised = False
        self.stale = True

    @property
    def n(self) -> int:
        return self.U.shape[1]

    @property
    def form(self) -> str:
        """How the physics is stepped: ``"vectorised"`` or ``"scalar loop"``."""
        from .physics.variants import ScalarLoop

        return "scalar loop" if isinstance(self.physics, ScalarLoop) else "vectorised"

    # -- values ------------------------------------------------------------------------------------------------
    def set_inputs(self, idx: Sequence[int], values: np.ndarray) -> None:
        """Inputs ``idx`` (positions in the model's inputs) take ``values`` (len(idx) x variants)."""
        if not len(idx):
            return
        self.U[idx] = values
        for i in idx:
            self.fresh[i] = True
        self.stale = True

    def outputs(self, idx: Sequence[int]) -> np.ndarray:
        """Outputs ``idx`` (positions in the model's outputs) x variants, computed once per change."""
        if self.stale:
            if not self.initialised:
                self.X = self._initial_state()
            self.Y = self.physics.output(self.time, self.X, self.inputs_now(), self.rows)
            self.stale = False
        return self.Y[idx]

    def _initial_state(self) -> np.ndarray:
        """The model's initial state for the present inputs (the slave computes it at every refresh in
        initialisation; the same inputs give the same state, so it is kept while they stay)."""
        if self._initial is None or not np.array_equal(self._initial[0], self.U):
            self._initial = (self.U.copy(), self.physics.initial_state(self.U))
        return self._initial[1]

    def inputs_now(self) -> np.ndarray:
        """The inputs as the model saw them at the present time (``PressBehaviour._inputs_now``)."""
        if not (self.initialised and self.advanced):
            return self.U
        U = self.U
        held = [(ip, iw) for ip, iw in self.advanced if not self.fresh[ip]]
        if not held:
            return U
        U = U.copy()
        h = self.last_step
        for ip, iw in held:
            U[ip] = U[ip] + U[iw] * h
        return U

    # -- life cycle ----------------------------------------------------------------------------------------------
    def setup(self, t: float) -> None:
        self.time = float(t)

    def check_inputs(self) -> list[tuple[int, str]]:
        """(variant, one line) of every variant with an input outside its declared range or not finite (the slave's
        check; an input not set since the last check holds a value already checked)."""
        U = self.U
        fresh = [i for i, f in enumerate(self.fresh) if f] if self._checked else list(range(len(self.fresh)))
        self._checked = True
        if not fresh:
            return []
        sub = U[fresh]
        ranged = [r for r in self.ranges if r[0] in fresh]
        if np.isfinite(sub).all() and all(((lo is None or (U[i] >= lo).all()) and (hi is None or (U[i] <= hi).all()))
                                          for i, _, lo, hi in ranged):
            return []
        bad: dict[int, str] = {}
        for i, name, lo, hi in self.ranges:
            out = np.zeros(U.shape[1], dtype=bool)
            if lo is not None:
                out |= U[i] < lo
            if hi is not None:
                out |= U[i] > hi
            for k in np.flatnonzero(out).tolist():
                bad.setdefault(k, f"input {name} = {float(U[i, k])!r} at t = {self.time:.9g} s is outside its declared "
                                  f"range [{'-inf' if lo is None else f'{lo:g}'}, {'inf' if hi is None else f'{hi:g}'}]")
        finite = np.isfinite(U).all(axis=0) if U.size else np.ones(U.shape[1], dtype=bool)
        for k in np.flatnonzero(~finite).tolist():
            i = int(np.argmin(np.isfinite(U[:, k])))
            bad.setdefault(k, f"input {self.input_names[i]} = {float(U[i, k])!r} at t = {self.time:.9g} s is not "
                              f"finite")
        return sorted(bad.items())

    def exit_initialization(self) -> list[tuple[int, str]]:
        failed = self.check_inputs()
        self.X = self._initial_state()
        self.initialised = True
        self.stale = True
        return failed

    def step(self, t: float, h: float) -> list[tuple[int, str]]:
        """``do_step(t, h)`` of every variant; returns (variant, one line) of those that failed."""
        failed = dict(self.check_inputs())
        X = self.physics.advance(t, h, self.X, self.U)    # (numpy's warnings are off for the batch's run)
        ok = finite_columns(X)
        for k in np.flatnonzero(~ok).tolist():
            if k not in failed:
                j = int(np.argmin(np.isfinite(X[:, k])))
                failed[k] = (f"state {self.declaration.model.states[j].name} became non-finite in the step from "
                             f"t = {t:.9g} s, h = {h:.3g} s")
        self.X = X
        self.last_step = h
        self.fresh = [False] * len(self.input_names)
        self.time = t + h
        self.stale = True
        return sorted(failed.items())

    def keep(self, idx: np.ndarray) -> None:
        """Only the variants ``idx`` (positions, in order) go on."""
        self.U, self.X, self.Y = self.U[:, idx], self.X[:, idx], self.Y[:, idx]
        self.physics = self.physics.take(idx)


__all__ = ["Batch", "build_model", "typed_parameters", "model_structure", "math"]
