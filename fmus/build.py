"""The one way to build the press-drive FMUs with pythonfmu (library of ``build_fmus.py``).

    python build_fmus.py [--fmi-version 2|3] [--model-exchange] [--out DIR] [--only NAME ...] [--no-validate]
                         [--standalone]

Both FMI versions are built from the same declarations by the same command: FMI 2.0 (the default, pythonfmu,
into build/fmus) or FMI 3.0 co-simulation (``--fmi-version 3``, pythonfmu3, into build/fmus3; the declaration on
``fmus.slave3``'s base slave instead of ``fmus.slave``'s, :func:`fmu_module`), or FMI 3.0 model exchange
(``--fmi-version 3 --model-exchange``, into build/fmus3me; on ``fmus.slave3_me``'s: the host integrates the
model's derivatives).

Each FMU is built from its declaration ``fmus/components/pd_<name>.py`` plus the runtime part of the
``fmus`` package (the base slave, units and the pure equations in ``fmus/physics``), the FMU's module written
from the declaration's class name (:func:`fmu_module`: the declaration's source is copied, never edited), bundled under
build-unique names (:func:`stage_isolated`): the runtime as the package ``fmus_<runtime hash>``, one name for every
FMU of a build, so a process imports it once for all of them; the declaration in it and the FMU's module as
``pd_<name>_<hash>``, the hash over the declaration and the runtime.  So FMUs of any toolkit version load, unload
and reload side by side in one process.  On Linux the host loader
(``fmus/loader/pressdrive_loader.c``, for FMI 3.0 ``pressdrive_loader3.c``, compiled here) goes in front of
pythonfmu's (pythonfmu3's) wrapper, so the FMU also loads in hosts that do not run Python, and the FMU gets what
its host needs to know (:func:`finish`, :mod:`fmus.packaging`: the check of its Python, requirements.txt,
documentation/index.html); ``--standalone`` FMUs carry their own Python and numpy (:mod:`fmus.standalone`).
The modelDescription is written completely by the base slave (units, ModelStructure with dependencies,
InitialUnknowns); an FMI 3.0 FMU also gets its power bonds as terminals (:func:`add_terminals`).  The build then
checks each FMU with ``fmpy.validation`` and exits non-zero, naming the FMU, if a build or a check fails.
"""
from __future__ import annotations

import argparse
import ast
import contextlib
import hashlib
import importlib
import io
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMPONENTS = ROOT / "fmus" / "components"
DOCS = ROOT / "fmus" / "docs"
# the runtime part of the fmus package, for either FMI version; each FMU bundles all but the other version's slave
RUNTIME = ("__init__.py", "declaration.py", "slave_core.py", "slave.py", "slave3.py", "slave3_me.py", "units.py",
           "refusal.py", "wrapper_glue.py", "physics", "components/__init__.py")
SLAVE_MODULE = {2: "slave.py", 3: "slave3.py"}
VERSIONS = tuple(SLAVE_MODULE)
# FMI 3.0 model exchange (--model-exchange): the base slave of its FMUs, which extends slave3
ME_MODULE = "slave3_me.py"


LOADER = ROOT / "fmus" / "loader" / "pressdrive_loader.c"
PLATFORM = "linux64"     # the one platform the host loader is built for (the others keep pythonfmu's wrapper)
# per FMI version: the loader's source, its platform folder and the name of the exporter whose wrapper it loads
LOADERS = {2: (LOADER, PLATFORM, "pythonfmu"),
           3: (ROOT / "fmus" / "loader" / "pressdrive_loader3.c", "x86_64-linux", "pythonfmu3")}
OUT = {2: ROOT / "build" / "fmus", 3: ROOT / "build" / "fmus3"}   # default output folder of each version
OUT_ME = ROOT / "build" / "fmus3me"                                 # ... of the FMI 3.0 model exchange FMUs


DECLARATION_BASE = "Component"   # fmus.declaration.Component: the base of every declaration


def declared_classes(script: Path) -> list[str]:
    """The names of the classes a declaration file derives from :class:`fmus.declaration.Component`, read from its
    syntax tree (no import, so it needs neither pythonfmu nor the physics)."""
    tree = ast.parse(script.read_text(encoding="utf-8"), filename=str(script))
    return [node.name for node in tree.body if isinstance(node, ast.ClassDef)
            and any((b.id if isinstance(b, ast.Name) else getattr(b, "attr", None)) == DECLARATION_BASE
                    for b in node.bases)]


def catalog() -> dict[str, Path]:
    """The FMU catalog: model (class) name -> its declaration ``fmus/components/pd_*.py``, for every FMU of the
    toolkit (:func:`declared_classes`); the one list that the build, the harness's name resolution, the reference
    and the studies use."""
    out: dict[str, Path] = {}
    for script in sorted(COMPONENTS.glob("pd_*.py")):
        for name in declared_classes(script):
            out[name] = script
    return out


def component_scripts() -> list[Path]:
    """The declaration scripts of the catalog, sorted by file name."""
    return sorted(set(catalog().values()))


def runtime(fmi_version: int = 2, model_exchange: bool = False) -> tuple[str, ...]:
    """The parts of the fmus package an FMU of this FMI version needs at run time (RUNTIME without the other
    version's slave module, so an FMU imports only its own exporter; the model exchange slave only in a model
    exchange FMU, so the co-simulation FMUs pack what they packed before it existed)."""
    if fmi_version not in SLAVE_MODULE:
        raise ValueError(f"FMI version {fmi_version!r} is not built here (allowed: {', '.join(map(str, VERSIONS))})")
    if model_exchange and fmi_version != 3:
        raise ValueError(f"model exchange FMUs are built for FMI 3.0 only (asked: FMI {fmi_version})")
    other = {m for v, m in SLAVE_MODULE.items() if v != fmi_version} | (set() if model_exchange else {ME_MODULE})
    return tuple(n for n in RUNTIME if n not in other)


def stage_runtime(dest: Path, package: str = "fmus", fmi_version: int = 2, model_exchange: bool = False) -> Path:
    """Copy the parts of the fmus package an FMU needs at run time into dest/<package>."""
    pkg = dest / package
    pkg.mkdir(parents=True)
    for name in runtime(fmi_version, model_exchange):
        src = ROOT / "fmus" / name
        if src.is_dir():
            shutil.copytree(src, pkg / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            (pkg / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, pkg / name)
    return pkg


def runtime_files(fmi_version: int | None = None, model_exchange: bool = False) -> list[Path]:
    """The source files an FMU packs besides its declaration: every file of :func:`runtime` (of both FMI versions
    and both interfaces when ``fmi_version`` is None), folders walked for ``*.py``."""
    names = RUNTIME if fmi_version is None else runtime(fmi_version, model_exchange)
    files: list[Path] = []
    for name in names:
        src = ROOT / "fmus" / name
        files += sorted(src.rglob("*.py")) if src.is_dir() else [src]
    return files


def runtime_hash(fmi_version: int = 2, model_exchange: bool = False) -> str:
    """Digest of the runtime sources an FMU of this FMI version (and interface) packs, the name of its runtime
    package ``fmus_<hash>``: the same for every FMU of one build, different for any other runtime."""
    h = hashlib.sha1(b"model exchange" if model_exchange else b"")
    for f in runtime_files(fmi_version, model_exchange):
        h.update(str(f.relative_to(ROOT)).encode())
        h.update(f.read_bytes())
    return h.hexdigest()[:12]


def code_hash(script: Path, fmi_version: int = 2, model_exchange: bool = False) -> str:
    """Digest of everything an FMU's Python code consists of: its declaration and the runtime sources."""
    h = hashlib.sha1(script.read_bytes())
    h.update(runtime_hash(fmi_version, model_exchange).encode())
    return h.hexdigest()[:12]


def stage_isolated(script: Path, dest: Path, fmi_version: int = 2, model_exchange: bool = False) -> tuple[Path, Path]:
    """The FMU's code under names unique to its build: the runtime package ``fmus_<runtime hash>``
    (:func:`runtime_hash`), the declaration in it as ``components/<script>_<hash>.py`` and the FMU's module
    ``<script>_<hash>`` (:func:`fmu_module`), ``<hash>`` over the declaration and the runtime (:func:`code_hash`).

    Every FMU bundles the runtime package, under a name that only its runtime sources decide: the FMUs of one
    build name the same package, so a host process imports it once for all of them (the first FMU's copy), while
    FMUs of another toolkit version name another package and never share it.  The declaration's name is unique
    to the declaration and the runtime, so two builds of one runtime with different declarations are two modules.
    When the package is already imported, from another FMU's folder (which the host may have deleted since), the
    FMU's module puts its own ``components`` folder first on the package's ``components.__path__`` before it
    imports its declaration, so the declaration always comes from the FMU's own folder.  The package, the
    declaration included, imports itself relatively; only the FMU's module names it.  That module ends by
    importing every module of the package, so nothing is imported lazily later (a function's own
    ``from .x import y`` then finds ``x`` in ``sys.modules`` even after the host deleted the folder it came
    from).  The shared modules hold no state that depends on which FMU imported them: caches are keyed by value
    or by class (the runtime's ``lru_cache`` functions), per instance (``last_call``) or by thread (the loader bridge)."""
    digest = code_hash(script, fmi_version, model_exchange)
    package = f"fmus_{runtime_hash(fmi_version, model_exchange)}"
    module = f"{script.stem}_{digest}"
    pkg = stage_runtime(dest, package, fmi_version, model_exchange)
    shutil.copy2(script, pkg / "components" / f"{module}.py")
    names = declared_classes(script)
    if len(names) != 1:
        raise RuntimeError(f"{script.name}: expected one class deriving from {DECLARATION_BASE}, found {len(names)}")
    text = fmu_module(package, module, names[0], fmi_version, model_exchange, source=script.name)
    modules = sorted(".".join(f.relative_to(dest).with_suffix("").parts).removesuffix(".__init__")
                     for f in pkg.rglob("*.py"))
    text += ("\n\n# every module of the bundled package, imported now (fmus/build.py: stage_isolated)\n"
             + "".join(f"import {m}  # noqa: E402,F401\n" for m in modules))
    staged = dest / f"{module}.py"
    staged.write_text(text, encoding="utf-8")
    return staged, pkg


def fmu_module(package: str, module: str, name: str, fmi_version: int = 2, model_exchange: bool = False,
               source: str | None = None) -> str:
    """The source of an FMU's module: the FMU class ``name`` as the declaration ``<package>.components.<module>``
    on the base slave of the variant (:mod:`fmus.slave`, :mod:`fmus.slave3` or :mod:`fmus.slave3_me`), the class
    each of those modules' ``fmu_class`` makes in process.  The module first puts its own folder's
    ``<package>/components`` on the package's ``components.__path__`` (in front): the package may have been
    imported from another FMU's folder (:func:`stage_isolated`).  An FMI 3.0 class statement also names pythonfmu3's
    ``Fmi3Slave``, already a base of the FMI 3.0 slave: pythonfmu3's builder finds the FMU class by that word.
    ``source``: the declaration's file name, for the docstring (default ``<module>.py``)."""
    base = "slave3_me" if model_exchange else Path(SLAVE_MODULE[fmi_version]).stem
    variant = ("FMI 3.0 model exchange" if model_exchange else f"FMI {fmi_version}.0 co-simulation")
    source = source or f"{module}.py"
    lines = [f'"""{name} (fmus/components/{source}) as an {variant} FMU; written by fmus/build.py."""',
             "import os as _os",
             "",
             f"import {package}.components as _components",
             "",
             "# the runtime package may come from another FMU of this build (fmus/build.py: stage_isolated): this",
             "# FMU's declaration is in its own folder",
             f"_own = _os.path.join(_os.path.dirname(_os.path.abspath(__file__)), {package!r}, 'components')",
             "if _own not in _components.__path__:",
             "    _components.__path__.insert(0, _own)",
             f"from {package}.components.{module} import {name} as _Declaration  # noqa: E402",
             f"from {package}.{base} import PressSlave  # noqa: E402"]
    bases = "_Declaration, PressSlave"
    if fmi_version == 3:
        lines.append("from pythonfmu3 import Fmi3Slave  # noqa: E402")
        bases += ", Fmi3Slave"
    lines += ["", "", f"class {name}({bases}):", f'    """{name}: the declaration on the {variant} base slave."""']
    return "\n".join(lines) + "\n"


def compile_loader(dest: Path, fmi_version: int = 2, standalone: bool = False) -> Path:
    """Compile the host loader of this FMI version (fmus/loader/pressdrive_loader.c, pressdrive_loader3.c) with
    the C compiler of the machine; FMI 3.0's takes its prototypes from the FMI 3.0 headers pythonfmu3 ships.
    ``standalone``: the loader of a standalone FMU, which also starts the interpreter the FMU carries
    (pressdrive_pyconfig.c, compiled against that Python's headers: :mod:`fmus.standalone`)."""
    source = LOADERS[fmi_version][0]
    cc = os.environ.get("CC", "cc")
    out = dest / f"{source.stem}{'_standalone' if standalone else ''}.so"
    cmd = [cc, "-shared", "-fPIC", "-O2", "-o", str(out), str(source), "-ldl", "-lpthread"]
    if standalone:
        from fmus.standalone import include_dir

        cmd[6:6] = [str(LOADER.parent / "pressdrive_pyconfig.c"), f"-I{include_dir()}"]
    if fmi_version == 3:   # the installed package's headers (not those of a copy an FMU run in this process put first)
        cmd.insert(1, f"-I{installed_package('pythonfmu3') / 'pythonfmu-export' / 'src' / 'fmi'}")
    try:
        r = subprocess.run(cmd, capture_output=True, text=True)
    except FileNotFoundError:
        raise RuntimeError(f"no C compiler {cc!r} to build the host loader {source.name} (set CC)") from None
    if r.returncode != 0:
        first = r.stderr.strip().splitlines()[0] if r.stderr.strip() else f"exit {r.returncode}"
        raise RuntimeError(f"compiling {source.name} failed: {first}")
    return out


def finish(fmu: Path, loader: Path | None, fmi_version: int = 2, standalone: bool = False,
           extra: tuple[str, ...] = ()) -> None:
    """The exporter's archive ``fmu`` made the FMU the toolkit ships (:func:`fmus.packaging.finish`: the host loader
    in front of the exporter's wrapper, the check, requirements, documentation); ``standalone``: with the
    interpreter the FMU's code needs (:mod:`fmus.standalone`, measured on the FMU's own code), for which ``loader``
    must be compiled with ``standalone=True``; ``extra``: requirements beyond numpy."""
    from fmus.packaging import finish as finish_archive

    carried = archive = None
    if standalone:
        from fmus.standalone import imported_files, runtime

        with tempfile.TemporaryDirectory(prefix="pressdrive_imports_") as tmp:
            with zipfile.ZipFile(fmu) as z:
                z.extractall(tmp)
            carried, archive = runtime(fmi_version, imported_files(Path(tmp) / "resources"))
    finish_archive(fmu, fmi_version, loader, carried, archive, extra)


EXPORTERS = {2: "pythonfmu", 3: "pythonfmu3"}
# what an FMU of the toolkit imports under its build's names: its runtime package (fmus_<hash>, a drive's
# harness_<hash>) and its module (<declaration>_<hash>, <drive>_fmu_<hash>): stage_isolated, drive_fmu.stage
_RUNTIME = re.compile(r"(fmus|harness)_[0-9a-f]{12}(\.|$)|\w+_[0-9a-f]{12}$")


def installed_package(name: str) -> Path:
    """The folder of the installed package ``name`` (its distribution's files), whichever copy is imported."""
    from importlib import metadata

    try:
        return Path(metadata.distribution(name).locate_file(name)).resolve()
    except metadata.PackageNotFoundError:
        raise RuntimeError(f"building an FMU needs {name} installed (pip install {name})") from None


@contextlib.contextmanager
def installed_exporter(fmi_version: int = 2):
    """pythonfmu's (FMI 2.0) or pythonfmu3's (FMI 3.0) ``FmuBuilder`` as installed, for the length of a build.

    Every FMU the toolkit writes carries the Python part of its exporter's package in its resources (a host needs
    nothing of it installed: fmus.packaging), and a host that runs such an FMU in this process (FMPy through the
    exporter's C wrapper) imports that copy, which has no binaries or headers to build with.  Where the package
    in ``sys.modules`` is such a copy, the installed one takes its place while the build runs (the FMU classes the
    build imports must subclass the builder's own slave class) and the copy is put back afterwards."""
    name = EXPORTERS[fmi_version]
    installed = installed_package(name)
    current = sys.modules.get(name)
    if current is None or Path(current.__file__).resolve().parent == installed:
        yield importlib.import_module(f"{name}.builder").FmuBuilder
        return

    def on_the_copy() -> list[str]:   # the exporter's modules, and the FMUs' own (_RUNTIME) imported on the copy
        return [k for k in sys.modules if k == name or k.startswith(name + ".") or _RUNTIME.match(k)]

    saved = {k: sys.modules.pop(k) for k in on_the_copy()}
    sys.path.insert(0, str(installed.parent))
    try:
        yield importlib.import_module(f"{name}.builder").FmuBuilder
    finally:
        sys.path.remove(str(installed.parent))
        for k in on_the_copy():
            del sys.modules[k]
        sys.modules.update(saved)


def build_one(script: Path, out: Path, runtime: Path | None = None, loader: Path | None = None,
              fmi_version: int = 2, model_exchange: bool = False, standalone: bool = False) -> Path:
    """Build one FMU from its declaration into ``out`` (its code under build-unique names, see
    :func:`stage_isolated`) and finish it (:func:`finish`); with ``loader`` (compiled for the same FMI version, and
    with ``standalone=True`` for a standalone FMU), the host loader goes in front of the exporter's wrapper;
    ``standalone``: the FMU carries its own Python and numpy (:mod:`fmus.standalone`)."""
    doc_dir = DOCS / script.stem.removeprefix("pd_")
    stage = Path(tempfile.mkdtemp(prefix=f"pressdrive_src_{script.stem}_"))
    try:
        with installed_exporter(fmi_version) as FmuBuilder:
            staged, runtime = stage_isolated(script, stage, fmi_version, model_exchange)
            fmu = _pythonfmu_build(FmuBuilder, staged, out, runtime, doc_dir, fmi_version)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    if fmi_version == 3:
        add_terminals(fmu, script)
    finish(fmu, loader, fmi_version, standalone)
    return fmu


def declaration(script: Path) -> type:
    """The declaration class of ``fmus/components/pd_<name>.py`` (for what the build writes beside the
    modelDescription)."""
    names = declared_classes(script)
    if len(names) != 1:
        raise RuntimeError(f"{script.name}: expected one class deriving from {DECLARATION_BASE}, found {len(names)}")
    return getattr(importlib.import_module(f"fmus.components.{script.stem}"), names[0])


def add_terminals(fmu: Path, script: Path) -> None:
    """FMI 3.0: the power bonds as terminals, ``terminalsAndIcons/terminalsAndIcons.xml``
    (:func:`fmus.slave3.terminals_and_icons`; pythonfmu3 0.3.4's own ``terminals`` option packs a wrong file)."""
    from xml.dom.minidom import parseString
    from xml.etree.ElementTree import tostring

    from fmus.slave3 import terminals_and_icons

    root = terminals_and_icons(declaration(script).ports)
    if root is None:
        return
    with zipfile.ZipFile(fmu, "a", zipfile.ZIP_DEFLATED) as z:
        z.writestr("terminalsAndIcons/terminalsAndIcons.xml",
                   parseString(tostring(root, "UTF-8")).toprettyxml(encoding="UTF-8"))


def _pythonfmu_build(FmuBuilder, script: Path, out: Path, runtime: Path, doc_dir: Path,
                     fmi_version: int = 2) -> Path:
    # FMI 3.0 spells the state capability canGetAndSetFMUState (fmus.slave3 sets every capability itself too); an
    # FMI 2.0 slave serializes its state too (fmus.slave_core.state_to_bytes: the checkpoints of harness.run)
    state = ({"canGetAndSetFMUState": True} if fmi_version == 3 else
             {"canGetAndSetFMUstate": True, "canSerializeFMUstate": True})
    with contextlib.redirect_stdout(io.StringIO()):
        fmu = Path(FmuBuilder.build_FMU(
            script, dest=out, project_files=[runtime],
            documentation_folder=doc_dir if doc_dir.is_dir() else None,
            canHandleVariableCommunicationStepSize=True, **state))
    return fmu


def validate(fmu: Path) -> list[str]:
    from fmpy.validation import validate_fmu
    return list(validate_fmu(str(fmu)))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1].strip(),
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fmi-version", type=int, choices=VERSIONS, default=2,
                    help="FMI version of the FMUs: 2 (pythonfmu) or 3 (pythonfmu3, co-simulation); default 2")
    ap.add_argument("--model-exchange", action="store_true",
                    help="FMI 3.0 model exchange FMUs (the model's ODE, integrated by the host) instead of "
                         "co-simulation ones; with --fmi-version 3, into build/fmus3me")
    ap.add_argument("--out", type=Path, default=None,
                    help="output folder (default build/fmus for FMI 2.0, build/fmus3 for FMI 3.0, build/fmus3me "
                         "for FMI 3.0 model exchange)")
    ap.add_argument("--only", nargs="*", default=None, help="build only these modules (e.g. pd_fourbar)")
    ap.add_argument("--no-validate", action="store_true", help="skip the fmpy validation of each FMU")
    ap.add_argument("--standalone", action="store_true",
                    help="FMUs that carry their own Python and numpy, for hosts without Python on machines without "
                         "Python (linux64; about 12 MB each: docs/howto/export.md)")
    args = ap.parse_args(argv)
    if args.model_exchange and args.fmi_version != 3:
        print(f"build_fmus: --model-exchange builds FMI 3.0 FMUs: add --fmi-version 3 (got {args.fmi_version})",
              file=sys.stderr)
        return 2
    if args.out is None:
        args.out = OUT_ME if args.model_exchange else OUT[args.fmi_version]
    exporter = LOADERS[args.fmi_version][2]
    try:
        importlib.import_module(exporter)
    except ImportError as e:
        print(f"build_fmus: FMI {args.fmi_version}.0 FMUs are built with {exporter}, which does not import here "
              f"({e}); install it with: pip install {exporter}", file=sys.stderr)
        return 2
    if args.standalone:
        from fmus.standalone import unavailable

        reason = unavailable()
        if reason:
            print(f"build_fmus: --standalone: {reason}", file=sys.stderr)
            return 2

    scripts = component_scripts()
    if args.only:
        wanted = {n if n.startswith("pd_") else f"pd_{n}" for n in args.only}
        unknown = wanted - {s.stem for s in scripts}
        if unknown:
            print(f"build_fmus: unknown FMU module(s): {', '.join(sorted(unknown))}", file=sys.stderr)
            return 2
        scripts = [s for s in scripts if s.stem in wanted]
    args.out.mkdir(parents=True, exist_ok=True)
    failed = []
    with tempfile.TemporaryDirectory(prefix="pressdrive_runtime_") as tmp:
        loader = None
        if sys.platform.startswith("linux"):
            try:
                loader = compile_loader(Path(tmp), args.fmi_version, args.standalone)
            except RuntimeError as e:
                print(f"build_fmus: FAILED host loader: {e}", file=sys.stderr)
                return 1
        for script in scripts:
            # built into a private folder and moved into place atomically: another process (a sweep worker, a
            # test run) that builds or loads the same FMU at the same time never sees a half-written archive
            stage = Path(tempfile.mkdtemp(prefix=f".{script.stem}_", dir=args.out))
            try:
                try:
                    staged = build_one(script, stage, loader=loader, fmi_version=args.fmi_version,
                                       model_exchange=args.model_exchange, standalone=args.standalone)
                except Exception as e:  # report and continue with the others
                    print(f"build_fmus: FAILED {script.name}: {type(e).__name__}: {e}", file=sys.stderr)
                    failed.append(script.name)
                    continue
                problems = [] if args.no_validate else validate(staged)
                if problems:
                    print(f"build_fmus: INVALID {staged.name}: " + "; ".join(p.strip() for p in problems),
                          file=sys.stderr)
                    failed.append(staged.name)
                    continue
                fmu = args.out / staged.name
                os.replace(staged, fmu)
                print(f"built {fmu.relative_to(Path.cwd()) if fmu.is_relative_to(Path.cwd()) else fmu}")
            finally:
                shutil.rmtree(stage, ignore_errors=True)
    if failed:
        print(f"build_fmus: {len(failed)} of {len(scripts)} FMU(s) failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0

