"""A refused parameter value as data that crosses the FMU boundary: the contract between the slaves and the hosts.

When a slave cannot build its model from the parameters (:class:`fmus.physics.base.ParameterError`), it logs two
messages before the FMI call fails: one line for people (``<instance> (<Model>): parameter <name> = <value> <unit>
is not admissible: <requirement>``, status error) and one :class:`Refusal` for programs: status ok, log category
:data:`CATEGORY` (declared in the modelDescription's ``LogCategories``), the message the refusal's fields as one
JSON object (:meth:`Refusal.to_message`).  A host recognises a refusal by the category and reads the fields with
:meth:`Refusal.from_message`; it never reads the human line (``harness.fmi`` turns it into
:class:`harness.errors.ParameterRefused`).

This module is part of every FMU's code (``fmus/build.py``: ``RUNTIME``) and imports nothing but the standard
library, so the harness reads it from the installed package while an FMU uses its own copy.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, fields
from typing import Any

CATEGORY = "pressdriveRefusal"
DESCRIPTION = "A refused parameter value: the message is a JSON object (parameter, value, unit, requirement, range)."


@dataclass(frozen=True)
class Refusal:
    """A parameter value a model refused: ``parameter`` and ``value`` as set, its ``unit`` ("" for an Integer),
    ``requirement`` in words (e.g. "must be > 0 kg.m2"), and the admissible range where it is one: ``low`` and
    ``high`` (None: unbounded), ``low_open`` (the lower bound is excluded), ``choices`` (the admissible values of
    an Integer parameter).  A refusal by a condition across parameters (a linkage that cannot be assembled) has
    no range: its bounds are None."""
    parameter: str
    value: Any
    unit: str
    requirement: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    choices: tuple | None = None

    @classmethod
    def of(cls, error, unit: str) -> "Refusal":
        """The refusal a :class:`~fmus.physics.base.ParameterError` states (its range where it has one)."""
        return cls(error.name, error.value, unit, error.requirement, getattr(error, "low", None),
                   getattr(error, "high", None), bool(getattr(error, "low_open", False)),
                   getattr(error, "choices", None))

    def to_message(self) -> str:
        """The log message that carries this refusal across the FMU boundary (one JSON object)."""
        return json.dumps(asdict(self), default=str)

    @classmethod
    def from_message(cls, message: str) -> "Refusal | None":
        """The refusal a message of category :data:`CATEGORY` carries; None if the text is not one (an FMU of
        another tool that happens to use the category name)."""
        try:
            data = json.loads(message)
        except ValueError:
            return None
        names = {f.name for f in fields(cls)}
        if not isinstance(data, dict) or not {"parameter", "value", "unit", "requirement"} <= data.keys():
            return None
        if data.get("choices") is not None:
            data["choices"] = tuple(data["choices"])
        return cls(**{k: v for k, v in data.items() if k in names})

    def sentence(self) -> str:
        """The refusal in words, as the FMU's human log line says it (without the instance)."""
        return f"parameter {self.parameter} = {self.value!r} {self.unit}".rstrip() + \
            f" is not admissible: {self.requirement}"
