"""The interpreter a standalone FMU carries (``--standalone``): the builder's Python and numpy, trimmed to what the
FMU imports, for hosts without Python on machines without Python (OMSimulator's command line, fmusim, ...).

An FMU built so has, beside its code, ``binaries/<platform>/python``: the builder's libpython (stripped of its debug
symbols), the standard-library modules the FMU's code imports (module-level imports, also those inside its
functions, and what they import in turn), numpy (the subpackages the code imports, without tests, headers and
build tools) with the libraries of its wheel, and the libraries the carried extension modules need beyond the C
library (libffi, zlib, ...: loaded first by the loader, so the machine need not have them).  The host loader
starts it isolated with that folder as its home (``fmus/loader/pressdrive_pyconfig.c``), so the FMU computes with
the builder's Python and numpy: its results are the builder's.  In a host that runs Python itself (FMPy) the
host's Python runs the FMU, as for any other FMU of the toolkit.

What the FMU imports is measured (:func:`imported_files`): a fresh builder's Python runs the FMU's check
(``fmus/hostcheck.py``, which imports the FMU's module), imports the modules of a drive FMU's members and every
standard-library module that an ``import`` statement of the FMU's Python files names, and reports the files of
every module then loaded.  The interpreter's files are compressed once per build and content (:func:`runtime`,
cached under ``build/standalone``); each FMU starts from a copy of that archive.

Refused (one line, :func:`unavailable`): a builder's Python without a shared libpython or without its headers
(the loader's PyConfig is compiled against them).
"""
from __future__ import annotations

import ast
import hashlib
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from pathlib import Path

from .packaging import PLATFORMS, Carried

ROOT = Path(__file__).resolve().parents[1]
FOLDER = "python"     # binaries/<platform>/python
LAYOUT = 2            # what an archive of build/standalone holds (part of its key: a changed layout makes new ones)
# the C library's own libraries: every Linux machine has them, in the version of its C library
SYSTEM = ("libc.so", "libm.so", "libpthread.so", "libdl.so", "librt.so", "libutil.so", "ld-linux", "linux-vdso",
          "libgcc_s.so", "libstdc++.so")
# parts of numpy an FMU never runs (where a module of the FMU imports one of them, it still goes in): its tests,
# its build tools, its typing stubs and the SIMD test module
NUMPY_SKIPPED = {"tests", "f2py", "distutils", "_pyinstaller", "typing", "testing"}
NUMPY_SKIPPED_FILES = {"_simd"}
_ANALYSE = r'''
import glob, json, os, runpy, sys, tempfile, zipfile
from xml.etree import ElementTree as ET
resources, check = sys.argv[1], sys.argv[2]
names = json.loads(sys.stdin.read())
kept = []
message = runpy.run_path(check)["check"](resources)
for member in sorted(glob.glob(os.path.join(resources, "members", "*.fmu"))):
    kept.append(tempfile.TemporaryDirectory(prefix="pressdrive_member_"))
    with zipfile.ZipFile(member) as z:
        z.extractall(kept[-1].name)
    own = os.path.join(kept[-1].name, "resources")
    sys.path.insert(0, own)
    with open(os.path.join(own, "slavemodule.txt")) as f:
        __import__(f.readline().strip())
for name in names:
    try:
        __import__(name)
    except Exception:
        pass
# the slave run as its wrapper runs it, a few calls of each kind, whatever they answer: what it imports lazily
root = ET.parse(os.path.join(os.path.dirname(resources), "modelDescription.xml")).getroot()
de = root.find("DefaultExperiment")
h = float(de.get("stepSize", "1e-3")) if de is not None else 1e-3
with open(os.path.join(resources, "slavemodule.txt")) as f:
    module = sys.modules[f.readline().strip()]
try:
    slave = getattr(module, root.get("modelName"))(instance_name="analysis", resources=resources, logger=None,
                                                   visible=False)
except Exception:
    slave = None
calls = [] if slave is None else [lambda: slave.setup_experiment(0.0), slave.enter_initialization_mode,
                                  slave.exit_initialization_mode]
calls += [] if slave is None else [lambda: [v.getter() for v in slave.vars.values() if v.getter is not None],
                                   lambda: slave.do_step(0.0, h), lambda: slave.do_step(h, h),
                                   slave._get_fmu_state, slave.terminate]
for call in calls:
    try:
        call()
    except Exception:
        pass
files = {n: getattr(m, "__file__", None) for n, m in list(sys.modules.items())}
print(json.dumps({"message": message, "files": files}))
'''


def unavailable() -> str | None:
    """Why this Python cannot be carried in an FMU, or None."""
    lib = Path(sysconfig.get_config_var("LIBDIR") or "") / (sysconfig.get_config_var("INSTSONAME") or "")
    include = Path(sysconfig.get_paths()["include"])
    if not sysconfig.get_config_var("Py_ENABLE_SHARED") or not lib.is_file():
        return (f"a standalone FMU carries the builder's libpython, and this Python ({sys.base_prefix}) has none "
                f"(it was built without --enable-shared): build with a shared Python, e.g. pyenv with "
                f"PYTHON_CONFIGURE_OPTS=--enable-shared, or Debian's python3 with libpython3-dev")
    if not (include / "Python.h").is_file():
        return (f"a standalone FMU's loader is compiled against the headers of the Python it carries, and "
                f"{include}/Python.h is missing: install them (Debian: libpython{sys.version_info.major}."
                f"{sys.version_info.minor}-dev)")
    return None


def include_dir() -> Path:
    """The headers of the carried Python (for fmus/loader/pressdrive_pyconfig.c)."""
    return Path(sysconfig.get_paths()["include"])


def _named_imports(resources: Path) -> list[str]:
    """The standard-library modules an ``import`` statement of the FMU's Python files names (at any depth of the
    file: inside functions too), and the members' files of a drive FMU."""
    sources = [p.read_bytes() for p in resources.rglob("*.py")]
    for member in sorted(resources.glob("members/*.fmu")):
        with zipfile.ZipFile(member) as z:
            sources += [z.read(n) for n in z.namelist() if n.startswith("resources/") and n.endswith(".py")]
    names = set()
    for text in sources:
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.Import):
                names.update(a.name for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names.add(node.module)
    return sorted(n for n in names if n.split(".")[0] in sys.stdlib_module_names)


def imported_files(resources: Path) -> dict[str, str]:
    """Module name -> file of every module a fresh builder's Python loads to run the FMU whose resources are
    ``resources`` (module docstring); built-in modules have no file and are left out."""
    here = Path(__file__).resolve().parent
    r = subprocess.run([sys.executable, "-c", _ANALYSE, str(resources), str(here / "hostcheck.py")],
                       input=json.dumps(_named_imports(resources)), capture_output=True, text=True, timeout=600,
                       env={k: v for k, v in os.environ.items() if not k.startswith("PYTHON")})
    if r.returncode != 0:
        raise RuntimeError(f"the FMU's code does not import in the builder's Python: "
                           f"{(r.stderr.strip().splitlines() or ['exit ' + str(r.returncode)])[-1]}")
    out = json.loads(r.stdout.strip().splitlines()[-1])
    if out["message"]:
        raise RuntimeError(f"the FMU's check fails in the builder's Python: {out['message']}")
    return {n: f for n, f in out["files"].items() if f}


def _needed_libraries(files: list[Path]) -> list[Path]:
    """The shared libraries these extension modules need beyond the C library's (resolved by ldd), in an order in
    which each comes after the ones it needs."""
    found: dict[str, Path] = {}
    deps: dict[str, set[str]] = {}
    todo = list(files)
    while todo:
        f = todo.pop()
        r = subprocess.run(["ldd", str(f)], capture_output=True, text=True)
        mine = set()
        for line in r.stdout.splitlines():
            parts = line.split("=>")
            if len(parts) != 2 or not parts[1].strip().startswith("/"):
                continue
            name, path = parts[0].strip(), Path(parts[1].split("(")[0].strip())
            if name.startswith(SYSTEM) or "numpy.libs" in str(path):
                continue
            mine.add(name)
            if name not in found:
                found[name] = path
                todo.append(path)
        deps[f.name] = mine
    order: list[str] = []

    def visit(name: str, seen: set):
        if name in order or name in seen:
            return
        seen.add(name)
        for d in sorted(deps.get(found[name].name, ())):
            visit(d, seen)
        order.append(name)

    for name in sorted(found):
        visit(name, set())
    return [found[n] for n in order]


def _numpy_files(files: dict[str, str]) -> list[tuple[Path, str]]:
    """(file, path under site-packages) of numpy (:data:`NUMPY_SKIPPED` left out, unless the FMU imports it) and
    its wheel's libraries."""
    import numpy

    top = Path(numpy.__file__).resolve().parent
    site_dir = top.parent
    imported = {Path(f).resolve() for n, f in files.items() if n.split(".")[0] == "numpy"}
    # numpy whole but for its tests and tools: it imports its subpackages on first use of an attribute
    # (np.ctypeslib, np.random, ...), which no import statement of the FMU's code names
    out = [(f, str(f.relative_to(site_dir))) for f in sorted(top.rglob("*"))
           if f.is_file() and f.suffix in (".py", ".so") and f.name.split(".")[0] not in NUMPY_SKIPPED_FILES]
    libs = site_dir / "numpy.libs"
    if libs.is_dir():
        out += [(f, str(f.relative_to(site_dir))) for f in sorted(libs.iterdir()) if f.is_file()]
    return [(f, rel) for f, rel in out if f in imported or not (set(Path(rel).parts) & NUMPY_SKIPPED)]


def runtime(fmi_version: int, files: dict[str, str], cache: Path | None = None) -> tuple[Carried, Path]:
    """The carried interpreter for an FMU that loads ``files`` (:func:`imported_files`): what it is and an archive
    of its files under ``binaries/<platform>/python`` (made once per content, in ``cache``)."""
    import numpy

    reason = unavailable()
    if reason:
        raise RuntimeError(reason)
    platform = PLATFORMS[fmi_version][0]
    stdlib = Path(sysconfig.get_paths()["stdlib"]).resolve()
    version = f"{sys.version_info.major}.{sys.version_info.minor}"
    libpython = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("INSTSONAME")
    chosen: list[tuple[Path, str]] = []
    for name, f in sorted(files.items()):
        p = Path(f).resolve()
        if p.is_relative_to(stdlib) and "site-packages" not in p.parts:
            chosen.append((p, f"lib/python{version}/{p.relative_to(stdlib)}"))
    # every codec: the interpreter looks one up by the name of the machine's locale (the file system's encoding)
    chosen += [(f, f"lib/python{version}/encodings/{f.name}") for f in sorted((stdlib / "encodings").glob("*.py"))]
    chosen += [(f, f"lib/python{version}/site-packages/{rel}") for f, rel in _numpy_files(files)]
    chosen = sorted(set(chosen), key=lambda x: x[1])
    extensions = [f for f, _ in chosen if f.suffix == ".so"]
    libraries = _needed_libraries(extensions)
    key = hashlib.sha1(f"{LAYOUT}|{platform}|{sys.version}|{numpy.__version__}|{libpython}".encode())
    for f, rel in chosen + [(p, p.name) for p in libraries]:
        key.update(f"{rel}|{f.stat().st_size}|{f.stat().st_mtime_ns}".encode())
    cache = cache or _cache_dir()
    archive = cache / f"python{version}-{platform}-{key.hexdigest()[:16]}.zip"
    prefix = f"binaries/{platform}/{FOLDER}"
    if not archive.is_file():
        cache.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(prefix="pressdrive_standalone_") as tmp:
            stripped = Path(tmp) / libpython.name
            _stripped_copy(libpython, stripped)
            part = archive.with_name(f".{archive.name}.{os.getpid()}")
            with zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as z:
                z.write(stripped, f"{prefix}/lib/{libpython.name}")
                for f, rel in chosen:
                    z.write(f, f"{prefix}/{rel}")
                    if f.suffix == ".py":
                        z.writestr(f"{prefix}/{compiled_name(rel)}", compiled(f.read_bytes(), rel))
                for p in libraries:
                    z.write(p, f"{prefix}/lib/{p.name}")
            os.replace(part, archive)
    with zipfile.ZipFile(archive) as z:
        size = sum(i.file_size for i in z.infolist())
    carried = Carried(FOLDER, libpython.name, tuple(p.name for p in libraries),
                      f"Python {sys.version.split()[0]}", f"numpy {numpy.__version__}", size)
    return carried, archive


def compiled_name(rel: str) -> str:
    """Where this Python looks for the compiled module of the source ``rel`` (``__pycache__/x.cpython-311.pyc``)."""
    p = Path(rel)
    return str(p.parent / "__pycache__" / f"{p.stem}.{sys.implementation.cache_tag}.pyc")


def compiled(source: bytes, name: str) -> bytes:
    """The module ``source`` compiled by this Python, as an unchecked-hash .pyc (PEP 552): the carried interpreter
    loads it without comparing it with its source, whose time stamp the host's unpacking does not keep, so no host
    compiles the FMU's Python on every run (measured: fmusim's run of a standalone Gain FMU 3.4 s -> 1.9 s)."""
    import importlib.util
    from importlib._bootstrap_external import _code_to_hash_pyc

    code = compile(source, name, "exec", dont_inherit=True)
    return bytes(_code_to_hash_pyc(code, importlib.util.source_hash(source), checked=False))


def _stripped_copy(src: Path, dest: Path) -> None:
    """``src`` without its debug symbols (``strip``), or as it is where there is no strip."""
    strip = shutil.which("strip")
    if strip is None or subprocess.run([strip, "--strip-unneeded", "-o", str(dest), str(src)],
                                       capture_output=True).returncode != 0:
        shutil.copy2(src, dest)


def _cache_dir() -> Path:
    """build/standalone of the checkout where it can be written, else the temporary folder's."""
    build = ROOT / "build"
    if os.access(build if build.is_dir() else ROOT, os.W_OK):
        return build / "standalone"
    return Path(tempfile.gettempdir()) / "pressdrive_standalone"
