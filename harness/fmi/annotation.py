"""The toolkit's own annotation in a modelDescription.xml (which slave module and class an FMU built by
:mod:`fmus.build` runs, and the motion-input positions it advances itself)."""
from __future__ import annotations

import functools
from pathlib import Path


def toolkit_annotation(unzip_dir: Path):
    """The toolkit's own annotation of an FMU built by fmus.slave.PressSlave (FMI 2.0: VendorAnnotations, tool
    "org.pressdrive"; FMI 3.0: Annotations/Annotation of type "org.pressdrive"; element ``Slave`` with the
    attributes ``module``, ``class`` and ``advancedPositions``), or None for any other FMU.  Read once per extraction folder (its content never changes: a changed FMU is
    extracted into another folder, see :func:`extracted`)."""
    return _annotation(str(unzip_dir))


@functools.lru_cache(maxsize=None)
def _annotation(unzip_dir: str):
    import xml.etree.ElementTree as ET

    try:
        root = ET.parse(Path(unzip_dir) / "modelDescription.xml").getroot()
    except (OSError, ET.ParseError):
        return None
    found = root.find("VendorAnnotations/Tool[@name='org.pressdrive']/Slave")   # FMI 2.0
    if found is None:
        found = root.find("Annotations/Annotation[@type='org.pressdrive']/Slave")  # FMI 3.0
    return found


def advanced_positions(unzip_dir: Path) -> frozenset:
    """Motion-input positions the FMU advances itself over a step with the held speed (from the toolkit's
    annotation; empty for any other FMU)."""
    el = toolkit_annotation(unzip_dir)
    return frozenset((el.get("advancedPositions") or "").split()) if el is not None else frozenset()

