"""SSP 1.0 import, the parameter values: ``ssd:ParameterBinding`` (inline or an .ssv file, ``sourceBase`` SSD or
component, ``prefix``), ``ssd:ParameterMapping`` (an .ssm or inline), the values' types, and a Real value given
in another unit than its FMU variable's converted through the unit definitions (the .ssv's ``ssv:Units``, the
.ssd's ``ssd:Units``, the FMU's ``UnitDefinitions``), or refused in one line naming the file, component,
parameter, value and both units (:mod:`harness.ssp.read`'s module docstring).

A part of the reader :class:`harness.ssp.read._Reader` (its ``ssd_path``, ``root_dir``, ``units``, ``label``
and ``fail``).
"""
from __future__ import annotations

import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from harness.errors import SystemDescriptionError
from harness.model import Instance, model_description
from harness.ssp.format import PARAMETER_MAPPING_TYPE, PARAMETER_SET_TYPE
from harness.ssp.values import Mapping, Quantity, Unit, _q, units


class Bindings:
    """Reading a component's or a system's parameter values (module docstring)."""

    def convert(self, value, inst: Instance, pname: str):
        """A parameter value in the unit of the FMU's variable (module docstring); any other value as is."""
        if not isinstance(value, Quantity):
            return value
        md = model_description(inst.fmu)
        var = next((v for v in md.modelVariables if v.name == pname), None)
        if var is None:  # no such variable: the system's validation names it
            return value.value
        target = var.unit or (var.declaredType.unit if var.declaredType is not None else None)
        if value.unit == target:
            return value.value
        fmu_units = {u.name: Unit.from_fmpy(u) for u in md.unitDefinitions}
        src = value.units.get(value.unit) or fmu_units.get(value.unit)
        what = (f"{value.where}: component '{inst.name}', parameter '{pname}' = {value.value!r} {value.unit}")
        if target is None:
            if src is not None and src.scaled:
                raise SystemDescriptionError(f"{what}: the FMU's variable declares no unit, and {value.unit} is a scaled "
                                   f"unit (factor {src.factor!r}, offset {src.offset!r}): cannot apply it")
            return value.value
        dst = fmu_units.get(target) or self.units.get(target)
        if src is None or dst is None:
            missing = value.unit if src is None else target
            raise SystemDescriptionError(f"{what}: the FMU's variable is in {target}, and {missing} has no unit definition "
                               f"(ssc:Unit / UnitDefinitions) to convert with")
        if src.exponents != dst.exponents:
            raise SystemDescriptionError(f"{what}: the FMU's variable is in {target}; {value.unit} ({src.dimension()}) "
                               f"and {target} ({dst.dimension()}) are not the same quantity")
        return (src.factor * value.value + src.offset - dst.offset) / dst.factor

    def _source_text(self, src: str, base: str, owner: str, component_source: Path | None) -> tuple[str, bytes]:
        """(label, bytes) of a ParameterBinding's ``source``.  ``sourceBase="SSD"`` (default): relative to the
        archive root or the .ssd's folder.  ``sourceBase="component"`` (SSP 1.0: resolved against the source
        of the component, so only on an ssd:Component): a path inside the component's FMU archive."""
        if base == "SSD":
            p = self.root_dir / src if (self.root_dir / src).exists() else self.ssd_path.parent / src
            if not p.exists():
                raise self.fail(f"{owner}: parameter values source {src} not found")
            return self.label(p), p.read_bytes()
        if base != "component":
            raise self.fail(f"{owner}: ssd:ParameterBinding sourceBase='{base}' is not 'SSD' or 'component'")
        if component_source is None:
            raise self.fail(f"{owner}: ssd:ParameterBinding sourceBase='component' is only allowed on an "
                            f"ssd:Component (SSP 1.0)")
        inner = src[5:].lstrip("/") if src.startswith("file:") else src.lstrip("/")
        try:
            with zipfile.ZipFile(component_source) as z:
                return f"{self.label(component_source)}!{inner}", z.read(inner)
        except (KeyError, zipfile.BadZipFile, OSError):
            raise self.fail(f"{owner}: parameter values source {src} (sourceBase='component') not found in "
                            f"{component_source.name}") from None

    def parameter_bindings(self, el: ET.Element, owner: str, component_source: Path | None = None) -> dict:
        values: dict = {}
        for b in el.findall(f"{_q('ssd:ParameterBindings')}/{_q('ssd:ParameterBinding')}"):
            prefix = b.get("prefix", "")
            btype = b.get("type", PARAMETER_SET_TYPE)
            if btype != PARAMETER_SET_TYPE:
                raise self.fail(f"{owner}: ssd:ParameterBinding of type '{btype}' is not supported "
                                f"(only {PARAMETER_SET_TYPE})")
            inline = b.find(_q("ssd:ParameterValues"))
            where = self.label(self.ssd_path)
            if b.get("source"):
                p, text = self._source_text(b.get("source"), b.get("sourceBase", "SSD"), owner, component_source)
                where = p
                try:
                    pset = ET.fromstring(text)
                except (ET.ParseError, LookupError, ValueError) as e:  # also a declared encoding Python lacks
                    raise SystemDescriptionError(f"{p}: not well-formed XML ({e})") from None
                if pset.tag != _q("ssv:ParameterSet"):
                    raise SystemDescriptionError(f"{p}: root element is <{pset.tag}>, not ssv:ParameterSet "
                                       f"(referenced by a ParameterBinding of {owner})")
            elif inline is not None:
                pset = inline.find(_q("ssv:ParameterSet"))
                if pset is None:
                    raise self.fail(f"{owner}: ssd:ParameterValues holds no ssv:ParameterSet")
            else:
                continue
            scope = {**self.units, **units(pset, "ssv:Units")}
            found = {p.get("name", ""): self.parameter_value(p, owner, scope, where)
                     for p in pset.findall(f"{_q('ssv:Parameters')}/{_q('ssv:Parameter')}")}
            mapping = b.find(_q("ssd:ParameterMapping"))
            if mapping is not None:
                found = self.parameter_mapping(mapping, owner, component_source).apply(found, self.fail)
            # SSP 1.0 (SystemStructureDescription.xsd, ParameterBinding/@prefix): the prefix is PREPENDED
            # to every name of the parameter source, so a set of bare names can be bound at system level
            # to one element with prefix="Element.".
            for pname, value in found.items():
                values[prefix + pname] = value
        return values

    def parameter_mapping(self, el: ET.Element, owner: str, component_source: Path | None) -> "Mapping":
        """The ssm:ParameterMapping of a binding: referenced (``source``, an .ssm; ``sourceBase`` as for the
        values) or inline."""
        mtype = el.get("type", PARAMETER_MAPPING_TYPE)
        if mtype != PARAMETER_MAPPING_TYPE:
            raise self.fail(f"{owner}: ssd:ParameterMapping of type '{mtype}' is not supported "
                            f"(only {PARAMETER_MAPPING_TYPE})")
        if el.get("source"):
            where, text = self._source_text(el.get("source"), el.get("sourceBase", "SSD"), owner, component_source)
            try:
                root = ET.fromstring(text)
            except (ET.ParseError, LookupError, ValueError) as e:  # also a declared encoding Python lacks
                raise SystemDescriptionError(f"{where}: not well-formed XML ({e})") from None
        else:
            where, root = self.label(self.ssd_path), el.find(_q("ssm:ParameterMapping"))
            if root is None:
                raise self.fail(f"{owner}: ssd:ParameterMapping has neither a source nor an ssm:ParameterMapping")
        if root.tag != _q("ssm:ParameterMapping"):
            raise SystemDescriptionError(f"{where}: root element is <{root.tag}>, not ssm:ParameterMapping "
                               f"(referenced by a ParameterBinding of {owner})")
        return Mapping(root, f"{where} ({owner})")

    def parameter_value(self, p: ET.Element, owner: str, scope: dict, where: str):
        for child in p:
            kind = child.tag.rsplit("}", 1)[-1]
            raw = child.get("value")
            if kind == "Real":
                return Quantity(float(raw), child.get("unit"), scope, where) if child.get("unit") else float(raw)
            if kind in ("Integer", "Enumeration"):
                return int(raw)
            if kind == "Boolean":
                return 1 if raw in ("true", "1") else 0
            if kind == "String":
                return raw if raw is not None else ""
            raise self.fail(f"{owner}: parameter '{p.get('name')}' of type ssv:{kind} is not supported")
        raise self.fail(f"{owner}: parameter '{p.get('name')}' has no value")
