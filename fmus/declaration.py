"""The declaration of a component FMU: what ``fmus/components/pd_<name>.py`` writes, with no FMI in it.

A declaration is one class deriving from :class:`Component`, naming its model (:mod:`fmus.physics`), its ports
and signals and the feed-through of its outputs::

    from ..declaration import Component, Rotational
    from ..physics.elements import InertiaModel

    class Inertia(Component):
        model = InertiaModel
        description = "Rigid inertia J ..."
        ports = (Rotational("flange", motion="out", doc="flange of the inertia"),)

The build (:mod:`fmus.build`) makes each FMU variant from it by composition, never by editing its source: the
FMU's module defines ``class Inertia(<declaration>, PressSlave)`` with the base slave of the variant (FMI 2.0
:mod:`fmus.slave`, FMI 3.0 :mod:`fmus.slave3`, FMI 3.0 model exchange :mod:`fmus.slave3_me`); each of those
modules' ``fmu_class`` makes the same class in process.  The declaration imports its package relatively, so the
same file works in the developer's ``fmus`` and in the private copy each FMU packs.  The port convention is
described in :mod:`fmus.slave`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from .physics.base import Model
from .units import check_unit

_ROT = (("phi", "rad", "angle"), ("w", "rad/s", "angular velocity"), ("tau", "N.m", "torque"))
_TRA = (("s", "m", "position"), ("v", "m/s", "velocity"), ("f", "N", "force"))


@dataclass(frozen=True)
class Port:
    """A mechanical power port: motion one way, effort the other."""
    name: str
    motion: str  # "in": motion variables are inputs, effort is an output; "out": the reverse
    doc: str
    translational: bool = False

    def __post_init__(self):
        if self.motion not in ("in", "out"):
            raise ValueError(f"port {self.name}: motion must be 'in' or 'out', got {self.motion!r}")

    def variables(self) -> list["Variable"]:
        (p, pu, pd), (v, vu, vd), (e, eu, ed) = _TRA if self.translational else _ROT
        motion_c, effort_c = ("input", "output") if self.motion == "in" else ("output", "input")
        effort_doc = ("reaction this component exerts on the driving flange" if self.motion == "in"
                      else "torque/force the connected part exerts on this flange")
        return [Variable(f"{self.name}.{p}", motion_c, pu, f"{self.doc}: {pd} (motion {self.motion})"),
                Variable(f"{self.name}.{v}", motion_c, vu, f"{self.doc}: {vd} (motion {self.motion})"),
                Variable(f"{self.name}.{e}", effort_c, eu, f"{self.doc}: {ed}, {effort_doc}")]


def Rotational(name: str, motion: str, doc: str) -> Port:
    return Port(name, motion, doc, translational=False)


def Translational(name: str, motion: str, doc: str) -> Port:
    return Port(name, motion, doc, translational=True)


@dataclass(frozen=True)
class Variable:
    name: str
    causality: str  # "input" | "output"
    unit: str
    doc: str
    start: float = 0.0
    min: float | None = None   # the range an input's value must lie in (modelDescription min/max; None: open)
    max: float | None = None


def Input(name: str, unit: str, doc: str, start: float = 0.0, min: float | None = None,
          max: float | None = None) -> Variable:
    return Variable(name, "input", unit, doc, start, min, max)


def Output(name: str, unit: str, doc: str) -> Variable:
    return Variable(name, "output", unit, doc)


class Component:
    """Base of every declaration (module docstring): the class attributes below, and what follows from them."""

    model: ClassVar[type[Model]]
    description: ClassVar[str] = ""
    ports: ClassVar[tuple[Port, ...]] = ()
    signals: ClassVar[tuple[Variable, ...]] = ()
    feedthrough: ClassVar[dict[str, tuple[str, ...]]] = {}
    # parameters that may change during the run (FMI variability "tunable", set between communication steps: a
    # brake's torque, a load torque): only those whose new value the model takes on from the present state, never
    # one that sizes the state or the geometry (those stay "fixed"; setting one after initialisation is refused)
    tunable: ClassVar[tuple[str, ...]] = ()
    # motion-input ports whose position the model advances over a step with the held velocity input
    # (phi(t) = port.phi + port.w*(t - t0)); declared in the modelDescription (tool "org.pressdrive": FMI 2.0's
    # VendorAnnotations, FMI 3.0's Annotations) so a master hands these positions over at the step start, not
    # extrapolated
    advances_position: ClassVar[bool] = True
    author = "press-drive toolkit"
    license = "MIT"
    version = "0.1.0"

    @classmethod
    def interface(cls) -> list[Variable]:
        """All inputs and outputs, checked against the model's own names."""
        io = [v for port in cls.ports for v in port.variables()] + list(cls.signals)
        for v in io:
            check_unit(v.unit)
        ins = {v.name for v in io if v.causality == "input"}
        outs = {v.name for v in io if v.causality == "output"}
        if ins != set(cls.model.inputs) or outs != set(cls.model.outputs):
            raise TypeError(f"{cls.__name__}: declared inputs/outputs {sorted(ins)} / {sorted(outs)} differ "
                            f"from model {cls.model.__name__}: {sorted(cls.model.inputs)} / {sorted(cls.model.outputs)}")
        for out, deps in cls.feedthrough.items():
            if out not in outs or not set(deps) <= ins:
                raise TypeError(f"{cls.__name__}: feedthrough entry {out}: {deps} names unknown variables")
        # order inputs and outputs as the model expects them
        order = {n: i for i, n in enumerate(cls.model.inputs + cls.model.outputs)}
        return sorted(io, key=lambda v: (v.causality != "input", order[v.name]))

    @classmethod
    def _port_positions(cls) -> list[str | None]:
        """Per port, the name of its position input if the model advances it over a step, else None."""
        return [f"{port.name}.{'s' if port.translational else 'phi'}"
                if port.motion == "in" and cls.advances_position else None for port in cls.ports]
