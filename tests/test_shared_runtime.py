"""The FMUs of one toolkit build share one import of their runtime package (fmus/build.py: stage_isolated).

Each FMU packs the runtime (base slaves, units, physics) as ``fmus_<runtime hash>`` and its declaration as
``components/pd_<name>_<code hash>.py`` in it: a process imports the runtime once for all FMUs of a build, and
each FMU still finds its own declaration, also when the FMU whose copy of the package was imported first has had
its folder deleted.  (The C wrappers' side: tests/test_hosts.py and tests/test_fmi3_export.py run FMUs one after
the other through fmpy, which deletes each FMU's folder after its run.)
"""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

from fmus import build

ROOT = Path(__file__).resolve().parents[1]


def _run_script(code: str, **env) -> str:
    """Run ``code`` in a fresh interpreter (no FMU code imported yet) and return its stdout."""
    code = textwrap.dedent(code) + "\nimport os as _os, sys as _sys\n_sys.stdout.flush(); _os._exit(0)\n"
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=600,
                       env={**os.environ, "PRESSDRIVE_NORMAL_EXIT": "1", **env})
    assert r.returncode == 0, f"exit {r.returncode}: {(r.stdout + r.stderr)[-1500:]}"
    return r.stdout


def test_runtime_package_is_named_by_the_runtime_and_the_declaration_by_its_own_code(tmp_path):
    """One package name for every declaration of a build; another for another FMI version or interface; the
    declaration's module name changes with the declaration."""
    scripts = build.component_scripts()
    packages = {build.stage_isolated(s, tmp_path / s.stem)[1].name for s in scripts[:3]}
    assert packages == {f"fmus_{build.runtime_hash()}"}
    assert len({build.runtime_hash(), build.runtime_hash(3), build.runtime_hash(3, True)}) == 3
    changed = tmp_path / "changed" / scripts[0].name
    changed.parent.mkdir()
    changed.write_text(scripts[0].read_text(encoding="utf-8") + "\n# changed\n", encoding="utf-8")
    staged, pkg = build.stage_isolated(changed, tmp_path / "other")
    assert pkg.name == f"fmus_{build.runtime_hash()}"
    assert staged.stem != build.stage_isolated(scripts[0], tmp_path / "again")[0].stem
    assert (pkg / "components" / f"{staged.stem}.py").is_file()


def test_six_fmus_of_one_build_import_the_runtime_package_once(fmu_dir):
    """The bed drive's six FMUs, in process: one runtime package with each of its modules once, plus the six
    declarations, each from its own FMU's folder."""
    out = _run_script("""
        import sys
        from pathlib import Path
        from harness import load, simulate

        system = load("bed_drive")
        simulate(system, stop_time=0.002, on_error="raise")
        packages = sorted(m for m in sys.modules if m.startswith("fmus_") and "." not in m)
        print(len(packages), len(system.instances))
        modules = [m for m in sys.modules if m.startswith("fmus_")]
        declarations = [m for m in modules if ".components.pd_" in m]
        print(len(modules) - len(declarations), len(declarations))
        # each declaration from the folder of the FMU module that imports it (resources/<module>.py)
        def own(d):
            package, module = d.split(".")[0], d.rsplit(".", 1)[1]
            return Path(sys.modules[module].__file__).parent / package / "components" / f"{module}.py"
        print(all(Path(sys.modules[d].__file__) == own(d) for d in declarations))
    """, PRESSDRIVE_FMU_DIR=str(fmu_dir))
    packages, instances, runtime, declarations, own = out.split()
    assert (packages, instances) == ("1", "6")
    package = f"fmus_{build.runtime_hash()}"
    expected = {".".join(f.relative_to(build.ROOT / "fmus").with_suffix("").parts).removesuffix(".__init__")
                for f in build.runtime_files(2)}
    assert int(runtime) == len({package} | {f"{package}.{m}" for m in expected if m != "__init__"})
    assert declarations == "6" and own == "True"


def test_a_second_fmu_finds_its_declaration_after_the_first_ones_folder_is_gone(fmu_dir, tmp_path):
    """FourBar imported (in process) from a folder that is then deleted; RackBed and a second FourBar loaded
    afterwards from folders of their own take the shared package from sys.modules and their declarations from
    their own folders, and step."""
    out = _run_script(f"""
        import shutil, sys, zipfile
        from pathlib import Path
        from harness.fmi.inprocess import slave_class

        def open_and_step(fmu, folder):
            with zipfile.ZipFile(fmu) as z:
                z.extractall(folder)
            cls = slave_class(Path(folder))
            s = cls(instance_name=Path(folder).name, resources=str(Path(folder) / "resources"), logger=0, visible=0)
            s.setup_experiment(0.0, None, None)
            s.enter_initialization_mode()
            s.exit_initialization_mode()
            assert s.do_step(0.0, 1e-3)
            return cls

        tmp = Path({str(tmp_path)!r})
        open_and_step({str(fmu_dir / "FourBar.fmu")!r}, tmp / "a")
        shutil.rmtree(tmp / "a")
        for fmu, folder in (("RackBed", "b"), ("FourBar", "c")):
            cls = open_and_step(str(Path({str(fmu_dir)!r}) / (fmu + ".fmu")), tmp / folder)
            declaration = sys.modules[cls.__mro__[1].__module__]
            print(fmu, Path(declaration.__file__).relative_to(tmp).parts[0])
        print(len([m for m in sys.modules if m.startswith("fmus_") and "." not in m]))
    """)
    # the second FourBar is the first one's code: its declaration module is the one imported from "a" already
    assert out.split() == ["RackBed", "b", "FourBar", "a", "1"]


def test_two_builds_of_different_runtimes_run_side_by_side(fmu_dir, tmp_path, monkeypatch):
    """A Gain built from a runtime whose physics doubles the output names another package than this build's:
    both FMUs in one system (in process and through FMI), each with its own runtime."""
    import shutil

    copy = tmp_path / "root"
    shutil.copytree(build.ROOT / "fmus", copy / "fmus", ignore=shutil.ignore_patterns("__pycache__", "docs"))
    physics = copy / "fmus" / "physics" / "testing.py"
    text = physics.read_text(encoding="utf-8")
    old = "return (min(p.limit, max(-p.limit, y)), float(x[0]))"
    assert text.count(old) == 1
    physics.write_text(text.replace(old, "return (2.0 * min(p.limit, max(-p.limit, y)), float(x[0]))"),
                       encoding="utf-8")
    monkeypatch.setattr(build, "ROOT", copy)
    out = tmp_path / "out"
    out.mkdir()
    other = build.build_one(copy / "fmus" / "components" / "pd_gain.py", out)
    doubling = build.runtime_hash()
    monkeypatch.undo()
    assert doubling != build.runtime_hash()
    ours = fmu_dir / "Gain.fmu"
    result = _run_script(f"""
        import sys
        from harness import simulate
        from harness.model import Connection, Experiment, Instance, System
        from harness.run import RunOptions
        system = System("runtimes", instances=[Instance("v1", {str(ours)!r}, {{"k": 3.0, "offset": 1.0}}),
                                               Instance("v2", {str(other)!r}, {{"k": 3.0, "offset": 1.0}})],
                        connections=[Connection("v1.y", "v2.u")], experiment=Experiment(stop_time=0.003, step=1e-3))
        for in_process in (False, True):
            df = simulate(system, master="jacobi", on_error="raise", options=RunOptions(in_process=in_process))
            print(df["v1.y"].iloc[-1], df["v2.y"].iloc[-1])
        print(len([m for m in sys.modules if m.startswith("fmus_") and "." not in m]))
    """)
    # v1.y = 3*0 + 1 = 1 feeds v2.u; v2.y = 2*(3*1 + 1) = 8 with the doubling runtime
    assert result.split() == ["1.0", "8.0", "1.0", "8.0", "2"]
