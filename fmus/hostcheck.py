"""What an FMU of the toolkit needs from the Python that runs it, checked before any of its model code runs.

The build packs this file into every FMU as ``resources/pressdrive_check.py`` (:mod:`fmus.packaging`).  The host
loader (``fmus/loader/pressdrive_python.c``) runs it in the Python it found (the host's own, FMPy's for example;
one the loader started in a host without Python; or the interpreter a ``--standalone`` FMU carries) in a
namespace of its own (``runpy.run_path``) and calls :func:`check` with the FMU's resources folder, before the
exporter's wrapper imports anything.  :func:`check` returns ``""`` when the FMU can run, else one line naming
what is missing and how to supply it, which the loader logs through the host's FMI logger and then fails the
instantiation.  It checks, in order:

* every requirement of ``resources/requirements.txt`` (``numpy>=1.26,<3``; the FMU carries the rest of its code,
  pythonfmu included) imports, at an allowed version;
* the FMU's own module (``resources/slavemodule.txt``) imports, as the wrapper will import it (the resources
  folder first on ``sys.path``), so a Python too old for its syntax, or anything else its code needs, is one line
  here instead of an exception inside the wrapper.

Standard library only, and no syntax newer than the oldest Python the loader lets through.
"""
from __future__ import annotations

import importlib
import os
import re
import sys

_SPEC = re.compile(r"^\s*([A-Za-z0-9_.\-]+)\s*((?:[<>=!]=?\s*[0-9][0-9A-Za-z.]*\s*,?\s*)*)$")
_CLAUSE = re.compile(r"([<>=!]=?)\s*([0-9][0-9A-Za-z.]*)")
# a distribution whose module has another name (every requirement the toolkit writes imports as its own name)
_MODULE = {"pyyaml": "yaml"}


def requirements(resources: str) -> list:
    """(distribution, module, [(operator, version)]) for each line of ``requirements.txt`` (comments and blank
    lines skipped; a line this reader does not understand is a requirement on the name alone)."""
    out = []
    path = os.path.join(resources, "requirements.txt")
    if not os.path.isfile(path):
        return out
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.split("#", 1)[0].split(";", 1)[0].strip()
            if not line:
                continue
            m = _SPEC.match(line)
            name = m.group(1) if m else re.split(r"[<>=!~\[ ]", line, 1)[0]
            clauses = _CLAUSE.findall(m.group(2)) if m else []
            out.append((name, _MODULE.get(name.lower(), name.lower().replace("-", "_")), clauses))
    return out


def _number(text: str) -> tuple:
    """The leading numeric release of a version: '2.4.6' -> (2, 4, 6), '1.26.0rc1' -> (1, 26, 0)."""
    parts = []
    for piece in str(text).split("."):
        digits = re.match(r"\d+", piece)
        if not digits:
            break
        parts.append(int(digits.group()))
        if digits.group() != piece:
            break
    return tuple(parts)


def _allows(version: str, clauses) -> bool:
    have = _number(version)
    for op, want in clauses:
        w = _number(want)
        n = max(len(have), len(w))
        a, b = have + (0,) * (n - len(have)), w + (0,) * (n - len(w))
        ok = {"<": a < b, "<=": a <= b, ">": a > b, ">=": a >= b, "==": a == b, "!=": a != b}.get(op, True)
        if not ok:
            return False
    return True


def _python() -> str:
    """This Python in words, for the messages."""
    v = sys.version_info
    return f"Python {v.major}.{v.minor}.{v.micro} at {sys.prefix}"


def _how(resources: str, what: str) -> str:
    """How to supply ``what`` to the Python that runs the FMU, by who started that Python."""
    root = os.path.dirname(os.path.abspath(resources))
    if os.path.abspath(sys.prefix).startswith(root + os.sep):
        return "this FMU's own Python lacks it: export the FMU again with --standalone"
    if "_pressdrive_embedded" in sys.modules:   # started by an FMU's loader in a host without Python
        return (f"set PRESSDRIVE_PYTHONPATH to a site-packages folder of this Python that has {what} "
                f"(PRESSDRIVE_LIBPYTHON chooses the Python), or use this FMU exported with --standalone")
    exe = sys.executable or "python"
    return f"install it into the Python that runs the host: {exe} -m pip install '{what}'"


def check(resources: str) -> str:
    """"" when the FMU can run in this Python, else one line naming what is missing and how to supply it (module
    docstring)."""
    for dist, module, clauses in requirements(resources):
        wanted = dist + ",".join(op + v for op, v in clauses)
        try:
            mod = importlib.import_module(module)
        except Exception as e:   # ImportError, or a broken installation raising anything else
            return (f"this FMU needs {wanted}, which does not import in {_python()} "
                    f"({type(e).__name__}: {' '.join(str(e).split())}): {_how(resources, wanted)}")
        version = getattr(mod, "__version__", None)
        if version is not None and clauses and not _allows(version, clauses):
            return (f"this FMU needs {wanted}; {_python()} has {dist} {version}: {_how(resources, wanted)}")
    try:
        with open(os.path.join(resources, "slavemodule.txt"), encoding="utf-8") as f:
            module = f.readline().strip()
    except OSError as e:
        return f"this FMU is incomplete: resources/slavemodule.txt cannot be read ({e})"
    if resources not in sys.path:
        sys.path.insert(0, resources)   # where pythonfmu's wrapper puts it, before it imports the same module
    try:
        importlib.import_module(module)
    except Exception as e:
        return (f"this FMU's code does not import in {_python()}: {type(e).__name__}: "
                f"{' '.join(str(e).split())}")
    return ""
