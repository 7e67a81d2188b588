"""What an FMU of the toolkit carries for the host that imports it, beside its model: the one finishing step of
every FMU the toolkit writes, the components' (``fmus/build.py``) and the drives' (``harness.export.drive_fmu``).

:func:`finish` rewrites the exporter's archive once:

* ``binaries/<platform>/<id>.so`` is the host loader (``fmus/loader``), the exporter's wrapper moves beside it as
  ``<id>_<exporter>.so``, and the binaries of every other platform go: the toolkit builds and tests its loader for
  Linux on x86-64 only (:data:`PLATFORMS`; pythonfmu's stock Windows wrapper, which nothing here can run or test,
  is not shipped);
* ``resources/pressdrive_python.txt``: the Python the loader looks for (:func:`python_config`): the oldest allowed
  version, the builder's libpython, home and site folders (found again on the builder's machine), and for a
  standalone FMU the interpreter it carries (:mod:`fmus.standalone`, under ``binaries/<platform>/python``);
* ``resources/requirements.txt`` (numpy at the toolkit's range, and what else the FMU declares): what
  ``pythonfmu deploy`` installs and what the loader's check imports first;
* ``resources/pressdrive_check.py`` (:mod:`fmus.hostcheck`): the check the loader runs before any model code;
* ``documentation/index.html`` (FMI's entry point of an FMU's documentation): what the FMU is, its parameters,
  inputs and outputs with units, what each kind of host needs, the environment variables, the platforms built
  and tested (:func:`documentation`);
* ``needsExecutionTool`` in the modelDescription: true when the FMU needs a Python on the host's machine, false
  for a standalone FMU (it carries one).
"""
from __future__ import annotations

import html
import os
import re
import shutil
import site
import sys
import sysconfig
import zipfile
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree as ET

HERE = Path(__file__).resolve().parent
MINIMUM_PYTHON = "3.10"        # the oldest Python the FMUs' code runs on (pyproject's requires-python)
NUMPY = "numpy>=1.26,<3"       # the toolkit's numpy range (pyproject's dependency; tests/test_handoff.py)
CHECK = "pressdrive_check.py"  # fmus/hostcheck.py inside an FMU's resources
# per FMI version: the one platform folder the toolkit's loader is built for and the exporter whose wrapper it loads
PLATFORMS = {2: ("linux64", "pythonfmu"), 3: ("x86_64-linux", "pythonfmu3")}
# what the toolkit's suite runs its FMUs in, as the colleague who has never seen it (tests/test_handoff.py)
TESTED_HOSTS = ("FMPy in a virtualenv with nothing but fmpy, Python 3.10, 3.12 and 3.13",
                "OMSimulator 3.0 command line", "the toolkit's own C hosts (FMI 2.0, FMI 3.0)",
                "fmusim of the Modelica Reference-FMUs (where built)", "libcosim (libcosimpy)")


@dataclass(frozen=True)
class Carried:
    """The interpreter a standalone FMU carries (:mod:`fmus.standalone`): its folder beside the loader, its
    libpython's file name, the libraries to load before it, and what it is, in words."""
    folder: str
    soname: str
    preload: tuple[str, ...]
    python: str
    numpy: str
    size: int    # bytes unpacked


def python_config(carried: Carried | None = None) -> str:
    """resources/pressdrive_python.txt (``fmus/loader/pressdrive_python.c`` reads it)."""
    libdir = sysconfig.get_config_var("LIBDIR") or ""
    name = sysconfig.get_config_var("INSTSONAME") or sysconfig.get_config_var("LDLIBRARY") or ""
    paths = [p for p in site.getsitepackages() if Path(p).is_dir()]
    lines = [f"version={sys.version_info.major}.{sys.version_info.minor}", f"minimum={MINIMUM_PYTHON}",
             f"libpython={Path(libdir) / name}", f"home={sys.base_prefix}", f"path={':'.join(paths)}"]
    if carried is not None:
        lines += [f"standalone={carried.folder}", f"soname={carried.soname}", f"preload={' '.join(carried.preload)}"]
    return "\n".join(lines) + "\n"


def requirements(extra: tuple[str, ...] = ()) -> str:
    """resources/requirements.txt: numpy at the toolkit's range and ``extra`` (pip's requirement syntax)."""
    return "".join(f"{r}\n" for r in (NUMPY, *extra))


def _variables(root: ET.Element) -> list[dict]:
    """Every variable of a modelDescription (FMI 2.0 or 3.0) as name, type, causality, variability, start, unit,
    description."""
    out = []
    for v in root.find("ModelVariables"):
        if v.tag == "ScalarVariable":   # FMI 2.0: the type is the child
            t = next(iter(v), None)
            kind, attrs = (t.tag, t.attrib) if t is not None else ("", {})
        else:
            kind, attrs = v.tag, v.attrib
        out.append({"name": v.get("name", ""), "type": kind, "causality": v.get("causality", "local"),
                    "variability": v.get("variability", ""), "start": attrs.get("start", v.get("start", "")),
                    "unit": attrs.get("unit", v.get("unit", "")), "description": v.get("description", "")})
    return out


def _table(rows: list[dict], keys: tuple[str, ...]) -> str:
    head = "".join(f"<th>{html.escape(k)}</th>" for k in keys)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(r.get(k, '')))}</td>" for k in keys) + "</tr>"
                   for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>\n"


def documentation(model_description: bytes, fmi_version: int, carried: Carried | None = None,
                  extra: tuple[str, ...] = (), others: tuple[str, ...] = ()) -> str:
    """documentation/index.html of an FMU: what it is (its modelDescription's name, description and interfaces),
    its variables with units, what each kind of host needs, the environment variables and the platforms.
    ``extra``: requirements beyond numpy; ``others``: other files of documentation/ to link."""
    root = ET.fromstring(model_description)
    name, description = root.get("modelName", ""), root.get("description", "")
    kinds = [k for k in ("CoSimulation", "ModelExchange") if root.find(k) is not None]
    platform, exporter = PLATFORMS[fmi_version]
    variables = _variables(root)
    groups = [("Parameters", lambda v: v["causality"] in ("parameter", "calculatedParameter")),
              ("Inputs", lambda v: v["causality"] == "input"), ("Outputs", lambda v: v["causality"] == "output")]
    needs = requirements(extra).split()
    if carried is None:
        no_python = (f"a Python {MINIMUM_PYTHON} or newer with {', '.join(needs)} on the machine: the loader finds "
                     f"a libpython3.x.so.1.0 on the library path by itself, or set PRESSDRIVE_LIBPYTHON to it and "
                     f"PRESSDRIVE_PYTHONPATH to the site-packages folder with numpy (or ask for this FMU exported "
                     f"with --standalone)")
    else:
        no_python = (f"nothing: the FMU carries {carried.python} and {carried.numpy} "
                     f"({carried.size / 1e6:.0f} MB unpacked, in binaries/{platform}/{carried.folder})")
    hosts = [{"host": "Python host (FMPy, PyFMI, libcosimpy, ...)",
              "needs": f"Python {MINIMUM_PYTHON} or newer with {', '.join(needs)} in the host's environment "
                       f"(pip install -r resources/requirements.txt, or pythonfmu deploy {name}.fmu); the FMU "
                       f"carries the rest of its code, {exporter} included"
                       + ("; the host's Python runs it, not the one the FMU carries" if carried else "")},
             {"host": "host without Python (OMSimulator, fmusim, Dymola, Simulink, HIL rigs)", "needs": no_python}]
    env = [{"variable": "PRESSDRIVE_LIBPYTHON", "meaning": "the libpython3.x.so.1.0 to run (hosts without Python; "
                                                          "not read by a standalone FMU)"},
           {"variable": "PRESSDRIVE_PYTHONHOME", "meaning": "that Python's home (its prefix), if not its own"},
           {"variable": "PRESSDRIVE_PYTHONPATH", "meaning": "site-packages folders (':'-separated) to add, e.g. "
                                                           "the one with numpy"},
           {"variable": "PRESSDRIVE_CACHE", "meaning": "where a drive FMU unpacks its member FMUs (default: the "
                                                       "temporary folder)"}]
    platforms = [{"platform": f"{platform} (Linux, x86-64, glibc)", "binary": "built: the toolkit's loader in "
                  f"front of {exporter}'s wrapper", "tested": "; ".join(TESTED_HOSTS)}]
    platforms += [{"platform": p, "binary": "not built", "tested": "no"} for p in
                  (("win64", "darwin64") if fmi_version == 2 else ("x86_64-windows", "x86_64-darwin", "aarch64-linux"))]
    parts = [f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{html.escape(name)}</title>"
             "<style>body{font-family:sans-serif;max-width:70em}td,th{border:1px solid #ccc;padding:2px 6px;"
             "text-align:left}table{border-collapse:collapse}</style></head><body>\n",
             f"<h1>{html.escape(name)}</h1>\n<p>{html.escape(description)}</p>\n",
             f"<p>FMI {root.get('fmiVersion', '')} {' and '.join(kinds)} FMU written by the pressdrive toolkit "
             f"with {exporter}; its model runs in Python.</p>\n"]
    for title, keep in groups:
        rows = [v for v in variables if keep(v)]
        if rows:
            parts.append(f"<h2>{title}</h2>\n" + _table(rows, ("name", "type", "start", "unit", "description")))
    parts += ["<h2>What a host needs</h2>\n", _table(hosts, ("host", "needs")),
              "<p>Anything missing is one error line through the host's FMI logger from the instantiation (whether "
              "or not debug logging is on), naming it and how to supply it; the host is never taken down.</p>\n",
              "<h2>Environment variables</h2>\n", _table(env, ("variable", "meaning")),
              "<h2>Platforms</h2>\n", _table(platforms, ("platform", "binary", "tested"))]
    if others:
        parts.append("<h2>More</h2>\n<ul>" + "".join(f'<li><a href="{html.escape(o)}">{html.escape(o)}</a></li>'
                                                     for o in others) + "</ul>\n")
    parts.append("</body></html>\n")
    return "".join(parts)


def _execution_tool(model_description: bytes, needed: bool) -> bytes:
    """``needsExecutionTool`` of every interface element set to ``needed``."""
    value = b"true" if needed else b"false"

    def fix(m: re.Match) -> bytes:
        attrs = re.sub(rb'\s+needsExecutionTool="[^"]*"', b"", m.group(2))
        return m.group(1) + b' needsExecutionTool="' + value + b'"' + attrs

    return re.sub(rb"(<(?:CoSimulation|ModelExchange))(\b[^>]*)", fix, model_description)


def finish(fmu: Path, fmi_version: int, loader: Path | None, carried: Carried | None = None,
           runtime: Path | None = None, extra: tuple[str, ...] = ()) -> None:
    """Rewrite the exporter's archive ``fmu`` as the FMU the toolkit ships (module docstring).  ``loader``: the host
    loader compiled for this FMI version (None where none is built: the exporter's binaries stay as they are);
    ``carried`` and ``runtime`` (an archive holding ``binaries/<platform>/<folder>/...``): a standalone FMU's
    interpreter (:mod:`fmus.standalone`); ``extra``: requirements beyond numpy."""
    platform, exporter = PLATFORMS[fmi_version]
    tmp = fmu.with_suffix(".fmu.part")
    if runtime is not None:
        shutil.copyfile(runtime, tmp)    # the interpreter's files, compressed once per build, then the FMU's own
    with zipfile.ZipFile(fmu) as zin, zipfile.ZipFile(tmp, "a" if runtime else "w", zipfile.ZIP_DEFLATED) as zout:
        names = zin.namelist()
        if loader is not None:
            wrapper = [n for n in names if n.startswith(f"binaries/{platform}/") and n.endswith(".so")]
            if len(wrapper) != 1:
                raise RuntimeError(f"{fmu.name}: expected one binaries/{platform}/*.so, found {wrapper}")
        docs = sorted(n.removeprefix("documentation/") for n in names
                      if n.startswith("documentation/") and not n.endswith("/"))
        for n in names:
            data = zin.read(n)
            if loader is not None and n.startswith("binaries/") and not n.startswith(f"binaries/{platform}/"):
                continue   # another platform's stock wrapper: nothing here builds or tests a loader for it
            if loader is not None and n == wrapper[0]:
                zout.writestr(n.removesuffix(".so") + f"_{exporter}.so", data)
                zout.write(loader, n)
            elif n == "modelDescription.xml":
                md = _execution_tool(data, carried is None)
                zout.writestr(zin.getinfo(n), md)
            elif n != "documentation/index.html":
                zout.writestr(zin.getinfo(n), data)
                if carried is not None and n.startswith("resources/") and n.endswith(".py"):
                    from fmus.standalone import compiled, compiled_name   # the carried Python's own .pyc

                    zout.writestr(compiled_name(n), compiled(data, n.removeprefix("resources/")))
        zout.writestr("resources/pressdrive_python.txt", python_config(carried))
        zout.writestr("resources/requirements.txt", requirements(extra))
        zout.write(HERE / "hostcheck.py", f"resources/{CHECK}")
        zout.writestr("documentation/index.html", documentation(md, fmi_version, carried, extra, tuple(docs)))
    os.replace(tmp, fmu)
