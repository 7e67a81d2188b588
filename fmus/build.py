"""The one way to build the press-drive FMUs with pythonfmu (library of ``build_fmus.py``).

    python build_fmus.py [--out DIR] [--only NAME ...] [--no-validate]
    from fmus.build import build; build(out_dir, ["pd_fourbar"])

Each FMU is built from its declaration ``fmus/components/pd_<name>.py`` (a unique module name, so several
FMUs load into one process) plus the runtime part of the ``fmus`` package (the base slave, units and the
pure equations in ``fmus/physics``).  The modelDescription is written completely by the base slave
(units, ModelStructure with dependencies, InitialUnknowns); the build then checks each FMU with
``fmpy.validation`` and exits non-zero, naming the FMU, if a build or a check fails.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import shutil
import sys
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMPONENTS = ROOT / "fmus" / "components"
DOCS = ROOT / "fmus" / "docs"
RUNTIME = ("__init__.py", "slave.py", "units.py", "physics")


_DECLARATION = re.compile(r"^class\s+(\w+)\s*\(\s*PressSlave\s*\)", re.M)


def catalog() -> dict[str, Path]:
    """The FMU catalog: model (class) name -> its declaration ``fmus/components/pd_*.py``, for every FMU of the
    toolkit.  Read from the sources (no import, so it needs no pythonfmu); the one list that the build, the
    harness's name resolution, the reference and the studies use."""
    out: dict[str, Path] = {}
    for script in sorted(COMPONENTS.glob("pd_*.py")):
        for name in _DECLARATION.findall(script.read_text(encoding="utf-8")):
            out[name] = script
    return out


def component_scripts() -> list[Path]:
    """The declaration scripts of the catalog, sorted by file name."""
    return sorted(set(catalog().values()))


def stage_runtime(dest: Path) -> Path:
    """Copy the parts of the fmus package an FMU needs at run time into dest/fmus."""
    pkg = dest / "fmus"
    pkg.mkdir(parents=True)
    for name in RUNTIME:
        src = ROOT / "fmus" / name
        if src.is_dir():
            shutil.copytree(src, pkg / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(src, pkg / name)
    return pkg


def build_one(script: Path, out: Path, runtime: Path) -> Path:
    import pythonfmu
    from pythonfmu.builder import FmuBuilder

    doc_dir = DOCS / script.stem.removeprefix("pd_")
    with contextlib.redirect_stdout(io.StringIO()):
        fmu = Path(FmuBuilder.build_FMU(
            script, dest=out, project_files=[runtime],
            documentation_folder=doc_dir if doc_dir.is_dir() else None,
            canGetAndSetFMUstate=True, canHandleVariableCommunicationStepSize=True,
            needsExecutionTool=False))
    with zipfile.ZipFile(fmu) as z:
        if not any(n.startswith("binaries/") and not n.endswith("/") for n in z.namelist()):
            # the pythonfmu in use is a copy from some FMU's resources (no binaries of its own)
            raise RuntimeError(f"{fmu.name} has no binaries: the pythonfmu imported from "
                               f"{Path(pythonfmu.__file__).parent} is not an installed package")
    return fmu


def validate(fmu: Path) -> list[str]:
    from fmpy.validation import validate_fmu
    return list(validate_fmu(str(fmu)))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1].strip(),
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=ROOT / "build" / "fmus", help="output folder (default build/fmus)")
    ap.add_argument("--only", nargs="*", default=None, help="build only these modules (e.g. pd_fourbar)")
    ap.add_argument("--no-validate", action="store_true", help="skip the fmpy validation of each FMU")
    args = ap.parse_args(argv)

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
        runtime = stage_runtime(Path(tmp))
        for script in scripts:
            # built into a private folder and moved into place atomically: another process (a sweep worker, a
            # test run) that builds or loads the same FMU at the same time never sees a half-written archive
            stage = Path(tempfile.mkdtemp(prefix=f".{script.stem}_", dir=args.out))
            try:
                try:
                    staged = build_one(script, stage, runtime)
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

