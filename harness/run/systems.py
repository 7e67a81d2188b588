"""Finding a system (:mod:`harness.run`): :func:`load` from a name in ``systems/``, a .py file, an .ssp/.ssd
or a bare .fmu; :func:`system_names` and :func:`declared` over ``systems/``."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

from harness.errors import SystemDescriptionError
from harness.model import System, model_description


def load(x) -> System:
    """A :class:`System` from a module name in ``systems/`` (its ``SYSTEM``; ``"bed_drive"``, also written
    ``"bed_drive.py"`` or ``"systems/bed_drive.py"``), the path of any Python file that defines ``SYSTEM``, an
    .ssp/.ssd file or an SSP unpacked into a folder (holding SystemStructure.ssd), OSP's OspSystemStructure.xml
    (or a folder holding one: :mod:`harness.osp`), a bare .fmu (run alone,
    :func:`_fmu_system`), or itself.  Anything else is a :class:`~harness.errors.SystemDescriptionError` in one
    line naming what was given and the known systems (with the closest name when it looks misspelt)."""
    if isinstance(x, System):
        return x
    s = str(x)
    if s.lower().endswith((".ssp", ".ssd")) or (Path(s) / "SystemStructure.ssd").is_file():
        from harness.ssp import load_ssp

        return load_ssp(s)
    if s.lower().endswith(".xml") or (Path(s) / "OspSystemStructure.xml").is_file():
        from harness.osp import is_osp_structure, load_osp

        if is_osp_structure(s) or not Path(s).exists():
            return load_osp(s)
        raise SystemDescriptionError(f"{s}: an .xml system must be an OspSystemStructure (its root element is not); "
                                     f"{_known_systems()}")
    if s.lower().endswith(".py"):
        return _load_file(Path(s))
    if s.lower().endswith(".fmu"):
        return _fmu_system(Path(s))
    name = s[len("systems."):] if s.startswith("systems.") else s
    if not name.isidentifier():  # a file of another kind, a folder, a path: no module name at all
        raise SystemDescriptionError(f"system {s!r} is neither a system name nor a .py, .ssp, .ssd or "
                                     f"OspSystemStructure.xml file; "
                                     f"{_known_systems()}")
    try:
        module = importlib.import_module(f"systems.{name}")
    except ModuleNotFoundError as e:
        if e.name in (f"systems.{name}", "systems"):
            raise SystemDescriptionError(f"unknown system {s!r}{_close_match(name)}; {_known_systems()}") from None
        raise
    return _system_of(module, f"systems/{name}.py")


def _fmu_system(path: Path) -> System:
    """One FMU run alone, as ``fmpy.simulate_fmu`` runs it: one instance named after the model (``.`` made
    ``_``), the FMU's DefaultExperiment as the default experiment (no step there: the run asks for one)."""
    from harness.model import Experiment, Instance as Component  # the declaration of the one instance

    if not path.is_file():
        raise SystemDescriptionError(f"{path}: no such FMU file")
    md = model_description(path)
    name = (md.modelName or path.stem).replace(".", "_")
    de = md.defaultExperiment
    experiment = None
    if de is not None and de.stopTime is not None:
        experiment = Experiment(stop_time=float(de.stopTime), step=float(de.stepSize) if de.stepSize else None,
                                start_time=float(de.startTime or 0.0))
    return System(name, [Component(name, path)], experiment=experiment)


def _load_file(path: Path) -> System:
    """The ``SYSTEM`` of a Python file: a shipped one by its module (``systems/x.py`` or just ``x.py``, so it
    is the same object as ``load("x")``), any other by its path."""
    import importlib.util

    shipped = Path(importlib.import_module("systems").__path__[0]).resolve()
    if path.is_file() and path.resolve().parent != shipped:
        module_name = f"_pressdrive_system_{path.stem}"
        spec = importlib.util.spec_from_file_location(module_name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[module_name] = module  # dataclasses defined in the file look their module up here
        try:
            spec.loader.exec_module(module)
        except Exception:
            sys.modules.pop(module_name, None)
            raise
        return _system_of(module, str(path))
    if path.stem in system_names() and (path.is_file() or len(path.parts) == 1 or path.parent.name == "systems"):
        return load(path.stem)
    raise SystemDescriptionError(f"system file {str(path)!r} does not exist{_close_match(path.stem)}; "
                                 f"{_known_systems()}")


def _system_of(module, where: str) -> System:
    system = getattr(module, "SYSTEM", None)
    if not isinstance(system, System):
        raise SystemDescriptionError(f"system module {where} defines no SYSTEM = System(...)")
    return system


def _known_systems() -> str:
    return ("known systems: " + ", ".join(system_names()) + " (or a .py file defining SYSTEM, .ssp/.ssd, or an "
            "OspSystemStructure.xml)")


def _close_match(name: str) -> str:
    import difflib

    close = difflib.get_close_matches(name, system_names(), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def system_names() -> list[str]:
    """The names of the system modules in ``systems/`` (each defines ``SYSTEM``), sorted."""
    import pkgutil

    import systems

    return sorted(m.name for m in pkgutil.iter_modules(systems.__path__) if not m.ispkg)


def declared(spec: str) -> dict:
    """System name -> its ``spec`` field (``"precision"`` or ``"stability"``), for every system in ``systems/``
    that declares one."""
    out = {}
    for name in system_names():
        value = getattr(load(name), spec)
        if value is not None:
            out[name] = value
    return out
