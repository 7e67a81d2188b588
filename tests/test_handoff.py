"""Issue 58: every FMU the toolkit writes runs on a colleague's machine that has never seen the toolkit.

The colleague's machine is a private mount namespace (tests/colleague.py: the checkout, the builder's virtualenv,
the temporary folder and ~/.cache hidden; for hosts without Python also pyenv's and the builder's Pythons, or
every Python).  Measured there:

* **FMPy of another Python** (a virtualenv of Python 3.10, 3.12 or 3.13 with nothing but fmpy): every FMU (every
  component as FMI 2.0, FMI 3.0 co-simulation and FMI 3.0 model exchange, every shipped drive as FMI 2.0 and 3.0)
  runs, and its result equals the builder's FMPy run value for value: bit for bit where the colleague's numpy is
  the builder's, else to 1e-9 of each column's size (the proof_press drive differed by 1.4e-10 under numpy 2.5.5
  and 2.2.6 against the builder's 2.4.6, and not at all under 2.4.6 in Python 3.12: numpy's OpenBLAS).
* **A missing piece is one FMI log line, never a crash**, in FMPy (Python 3.9, too old), libcosim (its Python has
  no numpy), OMSimulator's command line and the toolkit's C hosts (only the system's Python, or none at all), and
  fmusim where it is built (``PRESSDRIVE_FMUSIM`` or ``fmusim`` on PATH).
* **What a host needs is written in the FMU** (documentation/index.html, resources/requirements.txt,
  needsExecutionTool, binaries for linux64 only), and ``pythonfmu deploy`` installs it.

Standalone FMUs in hosts without Python: tests/test_standalone.py.  Where the namespace cannot be made (not root)
or a Python version is not installed, the tests skip, saying why.
"""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import colleague
from fmus.build import catalog
from harness.run import system_names

ROOT = Path(__file__).resolve().parents[1]
DRIVES = tuple(system_names())     # every shipped drive (tests/test_drive_fmu.py exports each, FMI 2.0 and 3.0)
MACHINE = colleague.unavailable()
SIGNALS = (-6, -11, 134, 139)      # abort and segmentation fault, as the process's return code or the shell's
# a value the colleague computes with another numpy build may differ from the builder's by round-off that the
# dynamics carry on: measured 1.4e-10 of the value at most (module docstring); bit for bit under the same numpy
NUMPY_BUILD_TOLERANCE = 1e-9


def _machine():
    if MACHINE:
        pytest.skip(MACHINE)


def _venv(version: str, package: str | None = None) -> Path:
    where = colleague.venv(version, package)
    if isinstance(where, str):
        pytest.skip(where)
    return where


def fmpy_jobs(fmu_dir: Path, fmu3_dir: Path, me_dir: Path, drive_fmus, work: Path) -> list[dict]:
    """Every FMU the toolkit writes, copied into ``work``, and FMPy's run of each (10 steps of 1 ms)."""
    jobs = []
    for kind, folder, fmi_type in (("fmi2", fmu_dir, None), ("fmi3", fmu3_dir, None),
                                   ("fmi3me", me_dir, "ModelExchange")):
        (work / kind).mkdir()
        for f in sorted(folder.glob("*.fmu")):
            shutil.copy2(f, work / kind / f.name)
            jobs.append({"fmu": f"{kind}/{f.name}", "stop": 0.01, "step": 1e-3, "fmi_type": fmi_type})
    (work / "drives").mkdir()
    for name in DRIVES:
        for version in (2, 3):
            shutil.copy2(drive_fmus(name, version), work / "drives" / f"{name}_fmi{version}.fmu")
            jobs.append({"fmu": f"drives/{name}_fmi{version}.fmu", "stop": 0.01, "step": 1e-3, "fmi_type": None})
    return jobs


@pytest.fixture(scope="module")
def everything(fmu_dir, fmu3_dir, me_dir, drive_fmus, tmp_path_factory):
    """(work folder with every FMU and the jobs, the builder's FMPy results of them)."""
    work = tmp_path_factory.mktemp("colleague")
    jobs = fmpy_jobs(fmu_dir, fmu3_dir, me_dir, drive_fmus, work)
    (work / "jobs.json").write_text(json.dumps(jobs))
    shutil.copy2(ROOT / "tests" / "colleague_fmpy.py", work)
    r = subprocess.run([sys.executable, "colleague_fmpy.py", "jobs.json", "builder.json"], cwd=work,
                       capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-1500:]
    builder = json.loads((work / "builder.json").read_text())
    assert not {k: v["error"] for k, v in builder.items() if "error" in v}
    return work, builder


def test_the_colleagues_machine_has_neither_the_toolkit_nor_its_environment(tmp_path):
    """The namespace hides what it says: in the colleague's FMPy nothing of the toolkit, SciPy or pythonfmu
    imports (only fmpy and numpy); with python="none" there is no python3 and no libpython on the machine."""
    _machine()
    venv = _venv("3.12")
    probe = ("import importlib.util as u; print(sorted(m for m in ('fmus', 'harness', 'systems', 'scipy', "
             "'pythonfmu', 'pythonfmu3', 'fmpy', 'numpy') if u.find_spec(m)))")
    r = colleague.run(["/mnt/venv/bin/python", "-c", probe], tmp_path, venv_dir=venv)
    assert r.returncode == 0 and r.stdout.split() == ["['fmpy',", "'numpy']"], r.stdout + r.stderr
    look = ("command -v python3 || true; ls /usr/lib/x86_64-linux-gnu/libpython3* /usr/bin/python3* 2>/dev/null || "
            f"true; ls {colleague.PYENV} {colleague.ROOT} 2>&1 | head -3")
    r = colleague.run(["sh", "-c", look], tmp_path, python="none")
    assert r.returncode == 0 and "python3" not in r.stdout and "libpython" not in r.stdout, r.stdout + r.stderr


@pytest.mark.parametrize("version", colleague.OTHER_PYTHONS)
def test_every_fmu_runs_in_fmpy_of_another_python_as_for_the_builder(everything, version):
    """Every FMU (module docstring) in the colleague's FMPy (Python ``version``, a virtualenv with nothing but fmpy,
    nothing of the toolkit on the machine): every one runs, and every value of every column equals the builder's
    FMPy run (bit for bit under the builder's numpy, else to NUMPY_BUILD_TOLERANCE of the column's size)."""
    _machine()
    work, builder = everything
    venv = _venv(version)
    r = colleague.run(["/mnt/venv/bin/python", "colleague_fmpy.py", "jobs.json", f"colleague{version}.json"], work,
                      venv_dir=venv)
    assert r.returncode == 0, r.stderr[-1500:]
    theirs = json.loads((work / f"colleague{version}.json").read_text())
    assert theirs["_versions"]["python"].startswith(version + ".")
    failed = {k: v["error"] for k, v in theirs.items() if "error" in v}
    assert not failed, failed
    same_numpy = theirs["_versions"]["numpy"] == builder["_versions"]["numpy"]
    assert set(theirs) == set(builder) and len(builder) == 1 + 3 * len(catalog()) + 2 * len(DRIVES)
    for fmu, result in builder.items():
        if fmu == "_versions" or result == theirs[fmu]:
            continue
        assert not same_numpy, f"{fmu}: not bit for bit under the builder's numpy {builder['_versions']['numpy']}"
        for column, values in result.items():
            a, b = np.array(values), np.array(theirs[fmu][column])
            scale = max(float(np.abs(a).max()), 1.0)
            assert np.abs(a - b).max() <= NUMPY_BUILD_TOLERANCE * scale, (fmu, column, theirs["_versions"])


# ------------------------------------------------------------------------------------------ a missing piece
def _one_line(text: str, pattern: str) -> str:
    """The one log line matching ``pattern`` (and no second one, and no traceback)."""
    lines = [line for line in text.splitlines() if re.search(pattern, line)]
    assert len(lines) == 1, text[-2000:]
    assert "Traceback" not in text, text[-2000:]
    return lines[0]


def test_fmpy_of_a_python_too_old_is_told_in_one_line(fmu_dir, fmu3_dir, tmp_path):
    """FMPy 0.3.20 under Python 3.9 (both allowed by FMPy): each FMU says in one error line which Python it needs,
    with debug logging off, and the process goes on."""
    _machine()
    venv = _venv("3.9", "fmpy==0.3.20")
    for folder, version in ((fmu_dir, 2), (fmu3_dir, 3)):
        shutil.copy2(folder / "Gain.fmu", tmp_path / f"Gain_{version}.fmu")
    code = ("import glob\nfrom fmpy import simulate_fmu\nfor f in sorted(glob.glob('*.fmu')):\n"
            "    try:\n        simulate_fmu(f, stop_time=0.01)\n    except Exception as e:\n"
            "        print('FAILED', f, type(e).__name__)\n")
    r = colleague.run(["/mnt/venv/bin/python", "-c", code], tmp_path, venv_dir=venv)
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.count("FAILED") == 2 and r.stdout.count("[ERROR]") == 2, r.stdout
    for line in r.stdout.splitlines():
        if line.startswith("[ERROR]"):
            assert "this FMU needs Python 3.10 or newer; the Python of the host process is 3.9." in line


LIBCOSIM = """
import sys
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimSlave import CosimLocalSlave
from libcosimpy._internal import get_last_error_message
execution = CosimExecution.from_step_size(1_000_000)
slave = CosimLocalSlave(fmu_path=sys.argv[1], instance_name="colleague")
if not slave.ptr():   # libcosimpy does not check: adding a slave that was not made segfaults (any FMU)
    print("NOSLAVE", get_last_error_message(), flush=True)
    sys.exit(0)
print("index", execution.add_local_slave(slave), "step", execution.step(10), flush=True)
"""


def test_libcosim_without_numpy_is_told_in_one_line(fmu_dir, tmp_path):
    """libcosimpy in a virtualenv without numpy (libcosimpy needs none): the FMU says, in one error line through
    libcosim's log, that numpy is missing and how to install it there; libcosim refuses the slave, no crash."""
    _machine()
    import importlib.metadata

    venv = _venv("3.12", f"libcosimpy=={importlib.metadata.version('libcosimpy')}")
    shutil.copy2(fmu_dir / "Gain.fmu", tmp_path)
    (tmp_path / "cosim.py").write_text(LIBCOSIM)
    r = colleague.run(["/mnt/venv/bin/python", "cosim.py", "/mnt/work/Gain.fmu"], tmp_path, venv_dir=venv)
    assert r.returncode == 0 and "NOSLAVE" in r.stdout, (r.returncode, (r.stdout + r.stderr)[-1500:])
    line = _one_line(r.stdout + r.stderr, r"logStatusError.*this FMU needs numpy")
    assert "No module named 'numpy'" in line and "/mnt/venv/bin/python -m pip install 'numpy>=1.26,<3'" in line


def _fmusim() -> Path | None:
    import os

    where = os.environ.get("PRESSDRIVE_FMUSIM") or shutil.which("fmusim")
    return Path(where) if where and Path(where).is_file() else None


def _omsimulator() -> Path | None:
    cli = Path(sys.executable).parent / "OMSimulator"
    return cli if cli.is_file() else (Path(shutil.which("OMSimulator")) if shutil.which("OMSimulator") else None)


def non_python_hosts(c_hosts, work: Path) -> dict:
    """Host name -> argv(fmu file, FMI version, steps, step, outputs) in the colleague's work folder: the toolkit's C
    hosts (FMI 2.0, FMI 3.0, the latter's model exchange for an FMU without co-simulation), OMSimulator's command
    line and fmusim where installed; each copied into ``work``.  The C hosts run the FMU unpacked beside it
    (:func:`unpacked`)."""
    from fmpy import read_model_description

    for path in c_hosts.values():
        shutil.copy2(path, work / path.name)

    def c_host(fmu, version, steps, h, outputs=""):
        md = read_model_description(str(work / fmu))
        folder = f"/mnt/work/{Path(fmu).stem}_x"
        platform = "linux64" if version == 2 else "x86_64-linux"
        me = [] if md.coSimulation is not None else ["me"]
        token = md.guid if version == 2 else md.instantiationToken
        return [f"./fmi{version}_host", f"{folder}/binaries/{platform}/{model_identifier(md)}.so",
                f"{folder}/resources", token, str(steps), repr(h), "", outputs, *me]

    hosts = {"c host": c_host}
    oms = _omsimulator()
    if oms is not None:
        shutil.copy2(oms, work / "OMSimulator")
        hosts["OMSimulator"] = lambda fmu, version, steps, h, outputs="": [
            "./OMSimulator", fmu, f"--stopTime={steps * h!r}", f"--stepSize={h!r}", f"--resultFile={fmu}.oms.csv"]
    fmusim = _fmusim()
    if fmusim is not None:
        shutil.copy2(fmusim, work / "fmusim")
        hosts["fmusim"] = lambda fmu, version, steps, h, outputs="": [
            "./fmusim", "--stop-time", repr(steps * h), "--output-interval", repr(h), "--output-file",
            f"{fmu}.fmusim.csv", fmu]
    return hosts


def model_identifier(md) -> str:
    return (md.coSimulation or md.modelExchange).modelIdentifier


def unpacked(fmu: Path) -> Path:
    """The FMU unpacked beside it (``<stem>_x``), for the C hosts."""
    where = fmu.with_name(f"{fmu.stem}_x")
    if not where.is_dir():
        with zipfile.ZipFile(fmu) as z:
            z.extractall(where)
    return where


@pytest.mark.interop
@pytest.mark.parametrize("python", ["system", "none"])
def test_hosts_without_python_are_told_in_one_line_what_is_missing(fmu_dir, fmu3_dir, drive_fmus, c_hosts, tmp_path,
                                                                   python):
    """A (not standalone) component FMU and drive FMU in every host without Python at hand, on a machine with only
    the system's Python ("system": pyenv's and the builder's gone; the loader finds the system's libpython, which
    has no numpy here) or none at all: one error line naming what is missing and how to supply it; the host ends
    by itself (no abort, no segfault; OMSimulator and fmusim report the failed instantiation, the C hosts exit 3)."""
    _machine()
    for folder, version in ((fmu_dir, 2), (fmu3_dir, 3)):
        unpacked(shutil.copy2(folder / "Gain.fmu", tmp_path / f"Gain_{version}.fmu"))
        unpacked(shutil.copy2(drive_fmus("bed_drive", version), tmp_path / f"BedDrive_{version}.fmu"))
    system = colleague.system_python()
    if python == "none" or system is None:
        expected = r"no Python for this FMU: .* or use this FMU exported with --standalone"
    elif system[1]:
        pytest.skip(f"the system's Python ({system[0]}) has numpy: nothing is missing with python='system'")
    else:
        expected = r"this FMU needs numpy>=1\.26,<3, which does not import in Python 3\.\d+\.\d+ at .*PRESSDRIVE_PYTHONPATH"
    for name, argv in non_python_hosts(c_hosts, tmp_path).items():
        for fmu, version in (("Gain_2.fmu", 2), ("Gain_3.fmu", 3), ("BedDrive_2.fmu", 2), ("BedDrive_3.fmu", 3)):
            r = colleague.run(argv(fmu, version, 10, 1e-3), tmp_path, python=python)
            text = r.stdout + r.stderr
            assert r.returncode not in SIGNALS and "terminate called" not in text, (name, fmu, text[-1500:])
            if name == "c host":
                assert r.returncode == 3 and "NOINSTANCE" in r.stdout, (name, fmu, text[-1500:])
            _one_line(text, expected)


@pytest.mark.interop
def test_a_drive_that_cannot_start_says_why_and_leaves_the_host_standing(drive_fmus, c_hosts, tmp_path):
    """A drive FMU whose initialisation raises (its members cannot be unpacked: PRESSDRIVE_CACHE is not a folder)
    in every host without Python at hand, on the builder's machine: the drive's one line says why, and the host
    ends by itself.  Before the loader's logger stood between pythonfmu's wrapper and the host, OMSimulator's
    command line aborted here (the wrapper logs the exception with a NULL category: "terminate called after
    throwing an instance of 'std::logic_error'")."""
    import os

    hosts = non_python_hosts(c_hosts, tmp_path)
    env = {**{k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "VIRTUAL_ENV"))},
           "PRESSDRIVE_CACHE": "/proc/nonexistent"}
    for version in (2, 3):
        fmu = f"BedDrive_{version}.fmu"
        unpacked(shutil.copy2(drive_fmus("bed_drive", version), tmp_path / fmu))
        for name, argv in hosts.items():
            cmd = [str(tmp_path / c) if c.startswith("./") else c.replace("/mnt/work", str(tmp_path))
                   for c in argv(fmu, version, 10, 1e-3)]
            r = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
            text = r.stdout + r.stderr
            assert r.returncode not in SIGNALS and "terminate called" not in text, (name, fmu, text[-1500:])
            _one_line(text, r"drive bed_drive \(.*\): initialization failed: FileNotFoundError: .*/proc/nonexistent")


# ------------------------------------------------------------------------------------------ what the FMU says
def _check_documented(fmu: Path, fmi_version: int, standalone: bool = False) -> None:
    from fmpy import read_model_description

    platform = "linux64" if fmi_version == 2 else "x86_64-linux"
    md = read_model_description(str(fmu))
    with zipfile.ZipFile(fmu) as z:
        names = z.namelist()
        page = z.read("documentation/index.html").decode()
        requirements = z.read("resources/requirements.txt").decode()
        description = z.read("modelDescription.xml").decode()
    assert requirements == "numpy>=1.26,<3\n", fmu.name
    assert "resources/pressdrive_check.py" in names
    assert {n.split("/")[1] for n in names if n.startswith("binaries/") and n.count("/") > 1} == {platform}
    needs = re.findall(r'needsExecutionTool="(\w+)"', description)
    assert needs and set(needs) == {"false" if standalone else "true"}, (fmu.name, needs)
    assert md.modelName in page and "What a host needs" in page and "PRESSDRIVE_LIBPYTHON" in page
    assert f"{platform} (Linux, x86-64, glibc)" in page and ("win64" in page or "x86_64-windows" in page)
    for v in md.modelVariables:
        if v.causality in ("parameter", "input", "output"):
            assert f"<td>{v.name}</td>" in page, (fmu.name, v.name)
    assert ("carries Python 3." in page) == standalone


def test_every_fmu_says_what_its_host_needs(fmu_dir, fmu3_dir, me_dir, drive_fmus):
    """documentation/index.html (every parameter, input and output; what each kind of host needs; the environment
    variables; the platforms built and tested), requirements.txt, the check, needsExecutionTool true (a Python
    is needed), and binaries for linux64 (x86_64-linux) only: pythonfmu's stock Windows wrapper is not shipped."""
    for folder, version in ((fmu_dir, 2), (fmu3_dir, 3), (me_dir, 3)):
        fmus = sorted(folder.glob("*.fmu"))
        assert len(fmus) == len(catalog())
        for fmu in fmus:
            _check_documented(fmu, version)
    for version in (2, 3):
        _check_documented(drive_fmus("bed_drive", version), version)


def test_pythonfmu_deploy_installs_what_the_fmu_needs(fmu_dir):
    """``pythonfmu deploy`` reads resources/requirements.txt (before: "Unable to find requirement file"); here
    everything is installed, so pip only confirms it."""
    r = subprocess.run([sys.executable, "-m", "pythonfmu", "deploy", "-f", str(fmu_dir / "GearSectors.fmu")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "Unable to find requirement file" not in r.stdout + r.stderr


# ------------------------------------------------------------------------------------------ the drive FMU's own code
def test_the_drive_fmus_reader_reads_what_fmpy_reads(fmu_dir, drive_fmus):
    """harness.fmi.description (the modelDescription reader a drive FMU carries: no FMPy, no lxml) against FMPy's
    on every component FMU and a drive FMU: the same variables with every attribute the harness reads, the same
    capabilities and the same output dependencies."""
    from fmpy import read_model_description

    from harness.fmi.description import read

    attrs = ("name", "valueReference", "type", "causality", "variability", "initial", "start", "unit", "min", "max",
             "nominal", "description", "declaredType")
    caps = ("modelIdentifier", "canHandleVariableCommunicationStepSize", "canInterpolateInputs",
            "canGetAndSetFMUstate", "providesDirectionalDerivative", "needsExecutionTool")
    for fmu in [*sorted(fmu_dir.glob("*.fmu")), drive_fmus("bed_drive", 2)]:
        theirs, ours = read_model_description(str(fmu)), read(fmu)
        assert (ours.modelName, ours.guid, ours.fmiVersion) == (theirs.modelName, theirs.guid, theirs.fmiVersion)
        assert [getattr(ours.coSimulation, c) for c in caps] == [getattr(theirs.coSimulation, c) for c in caps]
        assert ours.modelExchange is None and theirs.modelExchange is None
        assert len(ours.modelVariables) == len(theirs.modelVariables) > 0
        for a, b in zip(ours.modelVariables, theirs.modelVariables):
            for k in attrs:
                x, y = getattr(a, k), getattr(b, k)
                if k == "declaredType":
                    x, y = getattr(x, "unit", None), getattr(y, "unit", None)
                assert x == y, (fmu.name, a.name, k, x, y)
        for mine, fmpys in ((ours.outputs, theirs.outputs), (ours.initialUnknowns, theirs.initialUnknowns)):
            assert [(u.variable.name, None if u.dependencies is None else [d.name for d in u.dependencies])
                    for u in mine] == [(u.variable.name, None if u.dependencies is None else
                                        [d.name for d in u.dependencies]) for u in fmpys], fmu.name


def test_the_drive_fmu_imports_nothing_of_the_toolkit_or_fmpy(fmu_dir, tmp_path):
    """What a drive FMU's own package imports when it is imported (every module-level import of every file in it):
    the standard library, numpy, its exporter (pythonfmu or pythonfmu3, which the FMU carries) and itself; not
    fmpy, scipy, lxml, pandas, networkx, nor the toolkit's own harness or fmus."""
    import ast

    from harness import load
    from harness.export.drive_fmu import stage

    for version in (2, 3):
        script, (package, _), _ = stage(load("bed_drive").on_fmus(fmu_dir), tmp_path / f"v{version}",
                                        fmi_version=version)
        found = set()
        for f in [script, *package.rglob("*.py")]:
            for node in ast.parse(f.read_text()).body:
                if isinstance(node, ast.Import):
                    found.update(a.name.split(".")[0] for a in node.names)
                elif isinstance(node, ast.ImportFrom) and node.level == 0:
                    found.add(node.module.split(".")[0])
        foreign = {m for m in found if m not in sys.stdlib_module_names} - {"numpy", package.name}
        assert foreign == {"pythonfmu" if version == 2 else "pythonfmu3"}, (version, foreign)


def test_the_check_names_what_is_missing(tmp_path, monkeypatch):
    """fmus/hostcheck.py in this Python: a requirement that does not import, one at a version outside its range,
    and a module of the FMU that raises on import are each one line naming it; a complete FMU is ""."""
    import runpy

    check = runpy.run_path(str(ROOT / "fmus" / "hostcheck.py"))["check"]
    (tmp_path / "slavemodule.txt").write_text("pd_probe_fmu\n")
    (tmp_path / "pd_probe_fmu.py").write_text("import numpy\n")
    (tmp_path / "requirements.txt").write_text("numpy>=1.26,<3\n# a comment\n\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert check(str(tmp_path)) == ""
    (tmp_path / "requirements.txt").write_text("numpy>=99\n")
    line = check(str(tmp_path))
    assert line.startswith("this FMU needs numpy>=99; Python 3.") and f"numpy {np.__version__}" in line
    assert "-m pip install 'numpy>=99'" in line and "\n" not in line
    (tmp_path / "requirements.txt").write_text("pressdrive-absent-module>=1.0\n")
    line = check(str(tmp_path))
    assert "this FMU needs pressdrive-absent-module>=1.0, which does not import" in line
    assert "No module named 'pressdrive_absent_module'" in line
    (tmp_path / "requirements.txt").write_text("numpy\n")
    (tmp_path / "pd_probe_fmu2.py").write_text("raise RuntimeError('the model cannot start\\nat all')\n")
    (tmp_path / "slavemodule.txt").write_text("pd_probe_fmu2\n")
    line = check(str(tmp_path))
    assert line.endswith("RuntimeError: the model cannot start at all") and "this FMU's code does not import" in line
