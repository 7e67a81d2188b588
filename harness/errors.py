"""Exceptions of the co-simulation master.  Every message is one line naming what failed and where."""
from __future__ import annotations


def single_line(text) -> str:
    """``text`` with its line breaks written as ``\\n`` (a name or value a user wrote may hold one): every
    message of the toolkit stays one line."""
    return str(text).replace("\r", "\\r").replace("\n", "\\n")


class HarnessError(Exception):
    """Base of every error raised by the harness (its message is one line: :func:`single_line`)."""

    def __init__(self, *args):
        if args and isinstance(args[0], str):
            args = (single_line(args[0].strip()),) + args[1:]
        super().__init__(*args)


class SystemDescriptionError(HarnessError, ValueError):
    """A system that cannot be simulated as described: unknown instance or variable, a variable connected
    twice, causality or unit mismatch, an unknown parameter, an unknown master/extrapolation/step control."""


SystemError_ = SystemDescriptionError  # the former name (deprecated; it read as a shadowed builtin): the same class


class AlgebraicLoopError(SystemDescriptionError):
    """Direct feed-through around a cycle of connections that the chosen master cannot solve.

    ``loops`` lists every loop as the sorted ``Instance.variable`` names in it."""

    def __init__(self, message: str, loops: list[list[str]]):
        super().__init__(message)
        self.loops = loops


class FMUError(HarnessError):
    """An FMI call that did not return fmi2OK/fmi2Warning (or returned a non-finite value).

    Carries ``instance``, ``function`` (the FMI call), ``time`` [s], ``status`` (FMI status code, or None)
    and ``log`` (the last error message the FMU logged, if any)."""

    def __init__(self, instance: str, function: str, time: float | None, status: int | None,
                 log: str = "", detail: str = ""):
        self.instance, self.function, self.time, self.status, self.log = instance, function, time, status, log
        label = {1: "warning", 2: "discard", 3: "error", 4: "fatal", 5: "pending"}.get(status, str(status))
        where = f" at t = {time:.9g} s" if time is not None else ""
        text = f"instance {instance}: {function} failed{where}"
        if status is not None:
            text += f" with status {label}"
        if detail:
            text += f": {detail}"
        if log:
            text += f": {log}"
        super().__init__(" ".join(text.split()))


class StepDiscarded(FMUError):
    """fmi2DoStep returned fmi2Discard (the FMU could not complete the step; a variable-step master may retry
    with a smaller step after a rollback)."""


class ParameterRefused(FMUError):
    """An FMU refused a parameter value: the failed FMI call, and as data ``refusal`` (a
    :class:`fmus.refusal.Refusal`: ``parameter``, ``value``, ``unit``, ``requirement`` and the admissible range),
    which the FMU logged under its own category (:data:`fmus.refusal.CATEGORY`), not read from message text."""

    def __init__(self, instance: str, function: str, time: float | None, status: int | None,
                 log: str = "", detail: str = "", refusal=None):
        super().__init__(instance, function, time, status, log, detail)
        self.refusal = refusal


class SimulationError(HarnessError):
    """A run that stopped before its end.  ``partial`` is the result DataFrame up to the last good
    communication point (``partial.attrs["complete"]`` is False); ``time``, ``instance`` and ``variable``
    say where it failed (each may be None)."""

    def __init__(self, message: str, partial=None, time: float | None = None, instance: str | None = None,
                 variable: str | None = None):
        super().__init__(message)
        self.partial, self.time, self.instance, self.variable = partial, time, instance, variable


class SingularCoupling(SimulationError):
    """The ``jacobian`` master's interface Jacobian is singular at a step: its Newton correction of the held
    inputs has no unique solution, so the step cannot be coupled by that scheme (a condition of the coupling at
    that step, not a crash).  The message names the time and the power bond (or connection) whose held values
    span the singular direction; ``bond`` holds its label."""

    def __init__(self, message: str, time: float | None = None, bond: str | None = None):
        super().__init__(message, time=time)
        self.bond = bond


class BlowUp(SimulationError):
    """An output became non-finite or exceeded the master's blow-up limit: the run diverged faster than the
    divergence detector could judge it (or a model failed)."""


class Terminated(KeyboardInterrupt):
    """SIGTERM (``kill``, ``timeout``) turned into an interrupt by the command line (``python -m harness``
    installs the handler), so a run or study keeps its finished work on it exactly as on Ctrl-C."""

    status = 143
    signal = "SIGTERM"


def interruption(e: BaseException) -> tuple[int, str]:
    """(exit status, words) of an interrupt, also one that a run or study re-raised with the status it carries
    (:class:`RunInterrupted`, ``StudyInterrupted``): 143 and "terminated (SIGTERM)" after SIGTERM, else 130 and
    "interrupted (Ctrl-C)"."""
    status = int(getattr(e, "status", 130))
    return status, "terminated (SIGTERM)" if status == 143 else "interrupted (Ctrl-C)"
