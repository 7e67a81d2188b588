"""SSP parameter values as SSP 1.0 defines them: units (ssc:Unit) and parameter mappings (ssm:ParameterMapping).

Used by the SSP import (:mod:`harness.ssp`):

* :class:`Unit` is SSP's and FMI's unit model (exponents of the SI base units, ``factor``, ``offset``);
  :func:`units` reads the ssc:Unit elements of an .ssd or .ssv; a Real value written with a unit is a
  :class:`Quantity` until the importer knows its FMU variable and converts it.
* :class:`Mapping` is one ssm:ParameterMapping: it renames a binding's values and transforms them.
* :func:`value_table` reads an integer or boolean mapping transformation, of a parameter mapping or of a
  connection.
"""
from __future__ import annotations

from xml.etree import ElementTree as ET


# the one table of the SSP namespaces, with the OSP and toolkit annotation ones: harness.ssp reads and writes by it
NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "ssm": "http://ssp-standard.org/SSP1/SystemStructureParameterMapping",
    "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
    "pd": "https://pressdrive.example/ssp-annotations",
}


def _q(tag: str) -> str:
    """``"ssd:System"`` as ElementTree's ``{namespace}System``."""
    prefix, name = tag.split(":")
    return f"{{{NS[prefix]}}}{name}"


BASE = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")


class Unit:
    """A unit as SSP 1.0 (ssc:BaseUnit) and FMI 2.0/3.0 (BaseUnit) define it: the exponents of the SI base
    units and the affine map to them, value_SI = factor * value + offset."""

    __slots__ = ("exponents", "factor", "offset")

    def __init__(self, exponents: tuple, factor: float = 1.0, offset: float = 0.0):
        self.exponents, self.factor, self.offset = tuple(exponents), float(factor), float(offset)

    @classmethod
    def from_xml(cls, base: ET.Element | None) -> "Unit":
        if base is None:  # a unit without a BaseUnit: dimensionless, as in FMI
            return cls((0,) * len(BASE))
        return cls([int(base.get(k, "0")) for k in BASE], float(base.get("factor", "1")),
                   float(base.get("offset", "0")))

    @classmethod
    def from_fmpy(cls, unit) -> "Unit":
        b = unit.baseUnit
        if b is None:
            return cls((0,) * len(BASE))
        return cls([int(getattr(b, k) or 0) for k in BASE], b.factor, b.offset)

    @property
    def scaled(self) -> bool:
        return self.factor != 1.0 or self.offset != 0.0

    def dimension(self) -> str:
        return ".".join(f"{k}{e if e != 1 else ''}" for k, e in zip(BASE, self.exponents) if e) or "1"


def units(parent: ET.Element | None, tag: str) -> dict[str, Unit]:
    """name -> unit of the ssc:Unit elements under ``parent``'s ``tag`` (ssd:Units or ssv:Units)."""
    out = {}
    if parent is not None:
        for u in parent.findall(f"{_q(tag)}/{_q('ssc:Unit')}"):
            out[u.get("name")] = Unit.from_xml(u.find(_q("ssc:BaseUnit")))
    return out


class Quantity:
    """A Real parameter value given with a unit, converted once its component's FMU is known
    (:meth:`harness.ssp._Reader.convert`).  ``units``: the definitions that were in scope where it was
    written (the .ssv's own over the .ssd's); ``where``: the file it came from, for messages."""

    __slots__ = ("value", "unit", "units", "where")

    def __init__(self, value: float, unit: str, units: dict, where: str):
        self.value, self.unit, self.units, self.where = value, unit, units, where


def _bool(text: str | None) -> int:
    if text in ("true", "1"):
        return 1
    if text in ("false", "0"):
        return 0
    raise ValueError(text)


VALUE_TABLES = ("IntegerMappingTransformation", "BooleanMappingTransformation")


def value_table(transform: ET.Element) -> dict:
    """``{source: target}`` of an ssc:IntegerMappingTransformation (integers, for Integer and Enumeration
    values) or ssc:BooleanMappingTransformation (booleans as 1/0): its ssc:MapEntry pairs, which SSP 1.0
    (SystemStructureCommon.xsd, GTransformationChoice) defines for parameter mappings and connections alike.
    A ValueError says which transformation has an entry that is not such a pair, or none at all."""
    kind = transform.tag.rsplit("}", 1)[-1]
    parse = int if kind == "IntegerMappingTransformation" else _bool
    words = "integers" if parse is int else "booleans"
    try:
        table = {parse(m.get("source")): parse(m.get("target")) for m in transform.findall(_q("ssc:MapEntry"))}
    except (TypeError, ValueError):
        raise ValueError(f"ssc:{kind} has an ssc:MapEntry that is not a pair of {words}") from None
    if not table:
        raise ValueError(f"ssc:{kind} has no ssc:MapEntry (SSP 1.0 requires at least one)")
    return table


class Mapping:
    """An SSP 1.0 parameter mapping (ssm:ParameterMapping): each ssm:MappingEntry gives the value of the
    parameter set's ``source`` to ``target`` (one source may feed several targets), through its
    transformation if it has one: ssc:LinearTransformation (factor x value + offset, on the number as written,
    in its unit), ssc:IntegerMappingTransformation and ssc:BooleanMappingTransformation (their ssc:MapEntry
    pairs; a value without an entry is refused: the mapping does not say what it becomes).  The value keeps
    its unit, converted to the target's as any other (:meth:`harness.ssp._Reader.convert`), unless the entry says
    ``suppressUnitConversion="true"``.  A mapped source no longer applies under its own name; a parameter
    the mapping does not name applies under its own name."""

    def __init__(self, root: ET.Element, where: str):
        self.where = where
        self.entries = []
        for e in root.findall(_q("ssm:MappingEntry")):
            transforms = [t for t in e if t.tag.rsplit("}", 1)[-1] != "Annotations"]
            self.entries.append((e.get("source", ""), e.get("target", ""), transforms[0] if transforms else None,
                                 e.get("suppressUnitConversion") in ("true", "1")))

    def apply(self, values: dict, fail) -> dict:
        out = dict(values)
        sources, targets = set(), set()
        for source, target, transform, suppress in self.entries:
            what = f"{self.where}: mapping entry '{source}' -> '{target}'"
            if not target:
                raise fail(f"{what} has no target")
            if source not in values:
                raise fail(f"{what}: the parameter set has no parameter '{source}'")
            out[target] = self._transformed(values[source], transform, suppress, what, fail)
            sources.add(source)
            targets.add(target)
        for source in sources - targets:
            del out[source]
        return out

    @staticmethod
    def _transformed(value, transform, suppress: bool, what: str, fail):
        quantity = value if isinstance(value, Quantity) else None
        number = quantity.value if quantity is not None else value
        if transform is not None:
            kind = transform.tag.rsplit("}", 1)[-1]
            if kind == "LinearTransformation":
                if isinstance(number, str):
                    raise fail(f"{what}: ssc:LinearTransformation of the String value {number!r}")
                number = float(transform.get("factor", "1")) * number + float(transform.get("offset", "0"))
            elif kind in VALUE_TABLES:
                try:
                    table = value_table(transform)
                except ValueError as e:
                    raise fail(f"{what}: {e}") from None
                if isinstance(number, float) or number not in table:
                    raise fail(f"{what}: ssc:{kind} has no ssc:MapEntry for the value {number!r} "
                               f"(entries for {sorted(table)})")
                number = table[number]
            else:
                raise fail(f"{what}: ssc:{kind} is not supported (Linear, IntegerMapping and BooleanMapping are)")
        if quantity is None or suppress:
            return number
        return Quantity(number, quantity.unit, quantity.units, quantity.where)


__all__ = ["BASE", "Mapping", "NS", "Quantity", "Unit", "VALUE_TABLES", "units", "value_table"]
