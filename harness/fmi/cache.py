"""The one cache of FMU archives: model descriptions (per process) and unzipped folders (on disk).

* :func:`model_description`: fmpy's model description of an FMU file, read once per process and modification
  time; every layer (system validation, the FMI wrapper, the studies, the peer runners) asks here.
* FMI 3.0 descriptions are given in FMI 2.0's words (:func:`_as_fmi2_types`): Float64/Float32 variables are
  ``Real``, the eight integer types ``Integer``; Boolean, String and Enumeration keep their names (an array of
  more than one element of a non-numeric type is typed e.g. ``String[3]``, which nothing takes for a scalar;
  numeric arrays become one scalar variable per element, ``y[1]``, ``A[1,2]``: :func:`array_elements`), so system
  validation, coupling and results treat both versions alike.  :func:`native_types` keeps each variable's
  FMI 3.0 type, which the FMI 3.0 wrapper (:mod:`harness.fmi.fmu3`) calls by.
* :func:`terminals`: an FMI 3.0 FMU's terminals (``terminalsAndIcons/terminalsAndIcons.xml``), read once per
  process and modification time, as :class:`Terminal` records.
* :func:`model_exchange_only`: a copy of an FMU that offers both interfaces, without its co-simulation one
  (what an SSP component with ``implementation="ModelExchange"`` asks for), so that every layer runs it as ME.
* :func:`unzipped`: a zip archive (an FMU or an SSP) extracted once into a content-keyed folder under
  :func:`cache_dir`, shared by processes.  Extracted folders are NOT deleted at exit: the FMUs' shared
  libraries (and, for pythonfmu FMUs, the Python modules they loaded) stay in use until the interpreter is
  gone, and removing them in an atexit hook crashes the finalisation.  Keys are path + mtime + size, so the
  cache does not accumulate copies of an unchanged file.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
import warnings
import zipfile
from dataclasses import dataclass
from pathlib import Path

from harness.errors import SystemDescriptionError

_DESCRIPTIONS: dict[tuple[str, float], object] = {}
_NATIVE_TYPES: dict[int, dict[str, str]] = {}   # id(model description) -> variable name -> FMI 3.0 type
_FMI3_AS_FMI2 = {"Float64": "Real", "Float32": "Real", **{t: "Integer" for t in (
    "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64")}}
_UNZIPPED: dict[tuple[str, float, str], Path] = {}


# Who reads a modelDescription.xml: FMPy (the default), or the standard library (harness.fmi.description, FMI 2.0)
# in the copy of the harness a drive FMU carries, which needs nothing of its host but numpy
# (:func:`use_standard_library_reader`, called by harness.export.drive_behaviour).
_OWN_READER: list = []


def use_standard_library_reader() -> None:
    """Read every modelDescription with :func:`harness.fmi.description.read` from now on in this copy of the
    harness (a drive FMU's own: FMPy and lxml need not be there)."""
    from harness.fmi.description import read

    _OWN_READER[:] = [read]


def model_description(path: str | Path):
    """fmpy model description of an FMU file (cached by path and modification time); in a drive FMU's own copy of
    the harness, the standard library's (:func:`use_standard_library_reader`)."""
    if _OWN_READER:
        read_model_description = _OWN_READER[0]
    else:
        from fmpy import read_model_description

    p = Path(path).resolve()
    if not p.is_file():
        raise SystemDescriptionError(f"FMU file {p} does not exist")
    key = (str(p), p.stat().st_mtime)
    if key not in _DESCRIPTIONS:
        try:
            _DESCRIPTIONS[key] = read_model_description(str(p))
        except Exception as e:
            problems = getattr(e, "problems", None)
            if not problems:
                raise SystemDescriptionError(f"{p}: not a readable FMU ({type(e).__name__}: "
                                             f"{e})".splitlines()[0]) from None
            # readable but not valid (e.g. a variable name declared twice): libcosim and Ecos load such FMUs,
            # so does the master, saying so in one line; a variable whose name is not unique cannot be used
            # (harness.fmi.fmu.Instance.var names it)
            said = "; ".join(" ".join(x.split()) for x in problems)
            try:
                md = read_model_description(str(p), validate=False)
            except Exception:  # not even loadable without validation: its problems are the one line
                raise SystemDescriptionError(f"{p.name}: modelDescription.xml is not valid and cannot be loaded "
                                             f"({said})") \
                    from None
            warnings.warn(InvalidModelDescription(
                f"{p.name}: modelDescription.xml is not valid ({'; '.join(' '.join(x.split()) for x in problems)}); "
                f"loaded anyway"), stacklevel=2)
            _DESCRIPTIONS[key] = md
        _as_fmi2_types(_DESCRIPTIONS[key])
    return _DESCRIPTIONS[key]


ELEMENT_REF0 = 0xF0000000   # value references of array elements (:func:`array_elements`) start here


@dataclass(frozen=True)
class ArrayElement:
    """One element of an FMI 3.0 array variable, a scalar variable of its own to every layer: ``array`` the
    array's value reference, ``index`` the element's place in its row-major values, ``size`` their number."""
    array: int
    index: int
    size: int


_ELEMENTS: dict[int, dict[int, ArrayElement]] = {}   # id(model description) -> element value reference -> element


def _element_names(name: str, shape: tuple) -> list[str]:
    """``y[1]``, ``y[2]``...; ``A[1,1]``, ``A[1,2]``... (1-based, row-major as FMI 3.0 stores arrays)."""
    import itertools

    return [f"{name}[{','.join(str(i + 1) for i in idx)}]" for idx in itertools.product(*(range(n) for n in shape))]


def _expand_arrays(md, native: dict) -> None:
    """Replace each numeric FMI 3.0 array of more than one element by one scalar variable per element (named
    by :func:`_element_names`, start values split, value references from :data:`ELEMENT_REF0`), in the model
    variables and in the outputs' dependencies, so that every layer connects, sets and records elements."""
    import copy

    elements, by_array, out = {}, {}, []
    for v in md.modelVariables:
        shape = tuple(int(n) for n in (getattr(v, "shape", None) or ()))
        kind = native[v.name]
        if not shape or shape == (1,) * len(shape) or kind not in _FMI3_AS_FMI2:
            out.append(v)
            continue
        names = _element_names(v.name, shape)
        starts = str(v.start).split() if v.start is not None else None
        if starts is not None and len(starts) != len(names):
            starts = None
        copies = []
        for i, n in enumerate(names):
            e = copy.copy(v)
            e.name, e.shape, e.dimensions, e.dimensionValueReferences = n, (), [], []
            e.start = starts[i] if starts is not None else None
            e.valueReference = ELEMENT_REF0 + len(elements)
            e.type = _FMI3_AS_FMI2[kind]
            elements[e.valueReference] = ArrayElement(v.valueReference, i, len(names))
            native[n] = kind
            copies.append(e)
        by_array[id(v)] = copies
        out.extend(copies)
    if not elements:
        return
    md.modelVariables[:] = out

    def expanded(variables):
        return None if variables is None else [e for d in variables for e in by_array.get(id(d), [d])]

    for unknowns in (md.outputs, md.initialUnknowns, md.derivatives):
        new = []
        for u in unknowns:
            for e in by_array.get(id(u.variable), [u.variable]):
                c = copy.copy(u)
                c.variable, c.dependencies = e, expanded(u.dependencies)
                new.append(c)
        unknowns[:] = new
    _ELEMENTS[id(md)] = elements


def array_elements(md) -> dict[int, ArrayElement]:
    """Element value reference -> :class:`ArrayElement` of an FMI 3.0 description read by
    :func:`model_description` (empty if it has no arrays)."""
    return _ELEMENTS.get(id(md), {})


def _as_fmi2_types(md) -> None:
    """Rename an FMI 3.0 description's variable types to FMI 2.0's (module docstring); keep the originals;
    numeric arrays become one scalar per element (:func:`_expand_arrays`)."""
    if not str(md.fmiVersion).startswith("3"):
        return
    native = {}
    for v in md.modelVariables:
        native[v.name] = v.type
    _NATIVE_TYPES[id(md)] = native
    _expand_arrays(md, native)
    for v in md.modelVariables:
        shape = tuple(int(n) for n in (getattr(v, "shape", None) or ()))
        if shape and shape != (1,) * len(shape):  # an array keeps a type of its own: never taken for a scalar
            v.type = f"{v.type}[{'x'.join(map(str, shape))}]"
        elif v.valueReference < ELEMENT_REF0:
            v.type = _FMI3_AS_FMI2.get(v.type, v.type)


def native_types(md) -> dict[str, str]:
    """Variable name -> FMI 3.0 type (Float64, Int32, UInt8, Boolean, Binary, Clock...) of an FMI 3.0
    description read by :func:`model_description`; empty for FMI 1.0 and 2.0."""
    return _NATIVE_TYPES.get(id(md), {})


@dataclass(frozen=True)
class Terminal:
    """One FMI 3.0 terminal (fmi3TerminalsAndIcons: Terminal): ``kind`` its terminalKind, ``matching`` its
    matchingRule (plug, bus or sequence), ``members`` its TerminalMemberVariables as (memberName,
    variableName, variableKind) in order; ``unsupported`` names what it holds besides (nested terminals,
    stream members), which a host that connects it must refuse."""
    name: str
    kind: str
    matching: str
    members: tuple
    unsupported: str = ""


_TERMINALS: dict[tuple[str, float], dict[str, Terminal]] = {}
_TERMINAL_PARTS = {"TerminalMemberVariable", "Annotations", "TerminalGraphicalRepresentation"}  # all else: unsupported


def terminals(path: str | Path) -> dict[str, Terminal]:
    """Terminal name -> :class:`Terminal` of the top-level terminals an FMU declares in
    ``terminalsAndIcons/terminalsAndIcons.xml`` (FMI 3.0, section 2.4.9); empty for an FMU without that file
    (FMI 1.0 and 2.0 have none).  An unreadable file is a one-line :class:`SystemDescriptionError` naming the FMU."""
    from xml.etree import ElementTree as ET

    p = Path(path).resolve()
    key = (str(p), p.stat().st_mtime)
    if key not in _TERMINALS:
        try:
            with zipfile.ZipFile(p) as z:
                text = z.read("terminalsAndIcons/terminalsAndIcons.xml")
        except KeyError:
            _TERMINALS[key] = {}
            return _TERMINALS[key]
        except (zipfile.BadZipFile, OSError) as e:
            raise SystemDescriptionError(f"{p}: not a readable FMU ({e})") from None
        try:
            root = ET.fromstring(text)
        except ET.ParseError as e:
            raise SystemDescriptionError(f"{p}!terminalsAndIcons/terminalsAndIcons.xml: not well-formed XML "
                                         f"({e})") from None
        out = {}
        for t in root.findall("Terminals/Terminal"):
            others = sorted({c.tag for c in t} - _TERMINAL_PARTS)
            out[t.get("name", "")] = Terminal(
                t.get("name", ""), t.get("terminalKind", ""), t.get("matchingRule", ""),
                tuple((m.get("memberName", ""), m.get("variableName", ""), m.get("variableKind", ""))
                      for m in t.findall("TerminalMemberVariable")),
                ", ".join(others))
        _TERMINALS[key] = out
    return _TERMINALS[key]


class InvalidModelDescription(UserWarning):
    """An FMU's modelDescription.xml fails fmpy's validation but can be read (the master loads it anyway)."""


def cache_dir() -> Path:
    """$PRESSDRIVE_CACHE/fmus, else <temp>/pressdrive_fmu_cache."""
    env = os.environ.get("PRESSDRIVE_CACHE")
    return Path(env) / "fmus" if env else Path(tempfile.gettempdir()) / "pressdrive_fmu_cache"


def unzipped(path: str | Path, kind: str = "") -> Path:
    """The folder holding the extracted archive ``path`` (extracted at most once; ``kind`` a sub-folder of
    the cache, e.g. ``"_ssp"``).  Safe against other processes extracting the same file at the same time."""
    p = Path(path).resolve()
    st = p.stat()
    key = (str(p), st.st_mtime, kind)
    hit = _UNZIPPED.get(key)
    if hit is None:
        digest = hashlib.sha1(f"{p}|{st.st_mtime_ns}|{st.st_size}".encode()).hexdigest()[:16]
        root = cache_dir() / kind if kind else cache_dir()
        hit = root / f"{p.stem}_{digest}"
        if not (hit / ".complete").is_file():
            root.mkdir(parents=True, exist_ok=True)
            tmp = Path(tempfile.mkdtemp(prefix=f".{p.stem}_", dir=root))
            try:
                with zipfile.ZipFile(p) as z:
                    z.extractall(tmp)
            except BaseException:
                shutil.rmtree(tmp, ignore_errors=True)
                raise
            (tmp / ".complete").write_text("ok")
            try:
                os.replace(tmp, hit)  # atomic; another process may have won the race
            except OSError:
                shutil.rmtree(tmp, ignore_errors=True)
        _UNZIPPED[key] = hit
    return hit


def model_exchange_only(path: str | Path) -> Path:
    """A copy of the FMU ``path`` whose modelDescription.xml has no ``CoSimulation`` element (everything else
    byte for byte), made once per content under :func:`cache_dir` ``/_me``, with the FMU's own file name:
    :func:`harness.fmi.open_instance` then runs it through its Model Exchange interface
    (:mod:`harness.fmi.me`).  An FMU without a ModelExchange element is refused."""
    import re

    p = Path(path).resolve()
    md = model_description(p)
    if md.modelExchange is None:
        raise SystemDescriptionError(f"{p}: the FMU has no Model Exchange interface (FMI {md.fmiVersion})")
    st = p.stat()
    digest = hashlib.sha1(f"{p}|{st.st_mtime_ns}|{st.st_size}".encode()).hexdigest()[:16]
    out = cache_dir() / "_me" / digest / p.name
    if not out.is_file():
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = out.with_name(f".{p.name}.{os.getpid()}")
        with zipfile.ZipFile(p) as zin, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                data = zin.read(item.filename)
                if item.filename == "modelDescription.xml":
                    data, n = re.subn(rb"<CoSimulation\b[^>]*/>", b"", data, count=1)  # self-closing
                    if not n:
                        data = re.sub(rb"<CoSimulation\b.*?</CoSimulation>", b"", data, count=1, flags=re.S)
                zout.writestr(item, data)
        os.replace(tmp, out)
    return out
