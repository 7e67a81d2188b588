"""Issue 58, hosts without Python: standalone FMUs (``build_fmus.py --standalone``, ``harness export DRIVE X.fmu
--standalone``) carry the builder's Python and numpy, trimmed to what the FMU imports, and run on a machine with no
Python at all (tests/colleague.py, python="none") in every host without Python at hand: the toolkit's C hosts
(FMI 2.0, FMI 3.0 co-simulation and model exchange), OMSimulator's command line (FMI 2.0 and 3.0 co-simulation:
it refuses FMI 3.0 model exchange, "Unsupported FMI version: 3") and fmusim where installed (``PRESSDRIVE_FMUSIM``
or ``fmusim`` on PATH; tests/test_handoff.py).  Each run equals the FMU's run on the builder's machine: FMPy's to
1e-9 of max(|y|, 1) at every communication point for co-simulation (the hosts' time doubles differ, and
OMSimulator writes 12 digits, as in tests/test_hosts.py), the same host's bit for bit for model exchange.

The default run takes one FMU of each kind (FMI 2.0, FMI 3.0 co-simulation, FMI 3.0 model exchange, a drive as
FMI 2.0 and 3.0); the slow suite takes every component and every shipped drive, each in one of its kinds, taken
in turn (:data:`COVERING`): what a standalone FMU carries depends on its Python code (the modules it imports,
measured per FMU: the same code in every kind), what runs it on its kind (the loader, one per kind, each kind
run with five components or four drives here).  Every kind of every FMU took 224 s of the slow suite's CPU; this
set about a third of that.
"""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import colleague
from harness.run import system_names
from test_handoff import MACHINE, _check_documented, _fmusim, model_identifier, non_python_hosts, unpacked

ROOT = Path(__file__).resolve().parents[1]
STEPS, STEP = 20, 1e-3
ONE_OF_EACH = {"fmi2": ("cam_rocker",), "fmi3": ("gear_sectors",), "fmi3me": ("fourbar",),
               "drives": (("bed_drive", 2), ("bed_drive", 3))}
VARIANTS = {"fmi2": ["--fmi-version", "2"], "fmi3": ["--fmi-version", "3"],
            "fmi3me": ["--fmi-version", "3", "--model-exchange"]}
COMPONENTS = sorted(p.stem.removeprefix("pd_") for p in (ROOT / "fmus" / "components").glob("pd_*.py"))
COVERING = {**{variant: tuple(COMPONENTS[k::len(VARIANTS)]) for k, variant in enumerate(VARIANTS)},
            "drives": tuple((name, 2 + k % 2) for k, name in enumerate(system_names()))}


def build_standalone(fmu_dir: Path, out: Path, which: dict) -> dict[str, int]:
    """The standalone FMUs of ``which`` (variant -> component names; "drives" -> (drive name, FMI version) pairs)
    built into ``out``: file name -> FMI version."""
    from fmus import build as build_fmus
    from harness import load
    from harness.export.drive_fmu import export_fmu

    from fmus.standalone import unavailable

    reason = unavailable()
    if reason:
        pytest.skip(reason)
    made = {}
    for variant, flags in VARIANTS.items():
        if which[variant] == ():
            continue
        folder = out / variant
        assert build_fmus.main([*flags, "--standalone", "--no-validate", "--out", str(folder),
                                "--only", *which[variant]]) == 0
        for f in sorted(folder.glob("*.fmu")):
            made[f"{variant}_{f.name}"] = 2 if variant == "fmi2" else 3
            f.rename(out / f"{variant}_{f.name}")
    for name, version in which["drives"]:
        export_fmu(load(name).on_fmus(fmu_dir), out / f"drive{version}_{name}.fmu", fmi_version=version,
                   standalone=True)
        made[f"drive{version}_{name}.fmu"] = version
    return made


def outputs_of(fmu: Path) -> str:
    from fmpy import read_model_description

    return ",".join(str(v.valueReference) for v in read_model_description(str(fmu)).modelVariables
                    if v.causality == "output")


def host_runs(work: Path, made: dict, hosts: dict, colleague_machine: bool = True) -> dict:
    """Each FMU in each host, on the colleague's machine without any Python (else on the builder's):
    (host, FMU) -> {column: final value} (the C hosts' printed outputs, by name) or {column: [values]} (the
    others' result files)."""
    import csv

    from fmpy import read_model_description

    out = {}
    for fmu, version in made.items():
        unpacked(work / fmu)
        names = {str(v.valueReference): v.name for v in read_model_description(str(work / fmu)).modelVariables}
        for host, argv in hosts.items():
            if host == "OMSimulator" and "fmi3me_" in fmu:
                continue   # OMSimulator 3.0's command line: "Unsupported FMI version: 3" for model exchange
            cmd = argv(fmu, version, STEPS, STEP, outputs_of(work / fmu))
            if colleague_machine:
                r = colleague.run(cmd, work, python="none")
            else:
                r = subprocess.run([str(work / c) if c.startswith("./") else c.replace("/mnt/work", str(work))
                                    for c in cmd], cwd=work, capture_output=True, text=True, timeout=600)
            text = r.stdout + r.stderr
            assert r.returncode == 0 and "error" not in text.lower(), (host, fmu, text[-2000:])
            if host == "c host":
                out[host, fmu] = {names[vr]: float(v) for vr, v in (line.split() for line in r.stdout.splitlines()
                                                                      if not line.startswith("LOG"))}
                continue
            result = work / f"{fmu}.{'oms' if host == 'OMSimulator' else 'fmusim'}.csv"
            with open(result, newline="") as f:
                rows = list(csv.reader(f, skipinitialspace=True))
            result.unlink()
            # OMSimulator writes each communication point twice (before and after the input update): the last counts
            last = {float(row[0]): row for row in rows[1:]}
            out[host, fmu] = {c: [float(last[t][k]) for t in sorted(last)] for k, c in enumerate(rows[0])
                              if c != "time" or k == 0}
    return out


def check_standalone(fmu_dir: Path, c_hosts: dict, work: Path, which: dict) -> None:
    """Build ``which`` standalone (fmpy's validation passes on each), run each FMU in every host without Python on a
    machine without Python, and compare with the FMU's run on the builder's machine: FMPy's for co-simulation (to
    1e-9), the same host's for model exchange (bit for bit: each host integrates in its own way; the C host's
    forward Euler ignores the events FMPy's handles, measured 1.3e-8 apart on ParallelShafts)."""
    if MACHINE:
        pytest.skip(MACHINE)
    from fmpy.validation import validate_fmu

    made = build_standalone(fmu_dir, work, which)
    invalid = {f: problems for f in made if (problems := validate_fmu(str(work / f)))}
    assert not invalid, invalid
    hosts = non_python_hosts(c_hosts, work)
    theirs = host_runs(work, made, hosts)
    me = {f: v for f, v in made.items() if "fmi3me_" in f}
    builder = host_runs(work, me, hosts, colleague_machine=False)
    assert builder and all(theirs[key] == value for key, value in builder.items()), "model exchange: not bit for bit"
    jobs = [{"fmu": f, "stop": STEPS * STEP, "step": STEP, "fmi_type": None} for f in made if f not in me]
    (work / "jobs.json").write_text(json.dumps(jobs))
    shutil.copy2(ROOT / "tests" / "colleague_fmpy.py", work)
    r = subprocess.run([sys.executable, "colleague_fmpy.py", "jobs.json", "fmpy.json"], cwd=work, capture_output=True,
                       text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-1500:]
    fmpy = json.loads((work / "fmpy.json").read_text())
    for fmu in made:
        ran = [h for h in sorted(hosts) if (h, fmu) in theirs]
        capable = [h for h in sorted(hosts) if not (h == "OMSimulator" and fmu in me)]
        assert ran == capable and len(ran) >= 1 + (len(hosts) > 1 and fmu not in me), (fmu, ran)
        if fmu in me:
            continue
        builder = fmpy[fmu]
        assert "error" not in builder, builder
        for host in ran:
            compared = [c for c in builder if c != "time"]          # every output, as FMPy records them
            assert compared and set(compared) <= set(theirs[host, fmu]), (host, fmu, compared)
            for column in compared:
                value = theirs[host, fmu][column]
                want = builder[column] if isinstance(value, list) else builder[column][-1]
                assert np.shape(value) == np.shape(want), (host, fmu, column)
                diff = float(np.max(np.abs(np.array(value) - np.array(want))))
                assert diff <= 1e-9 * max(float(np.max(np.abs(want))), 1.0), (host, fmu, column, value, want)


@pytest.mark.interop
def test_one_standalone_fmu_of_each_kind_runs_without_any_python(fmu_dir, c_hosts, tmp_path):
    """One FMU of each kind (module docstring) in every host without Python at hand, on a machine without any
    Python, as on the builder's machine (check_standalone)."""
    check_standalone(fmu_dir, c_hosts, tmp_path, ONE_OF_EACH)


@pytest.mark.interop
def test_fmusim_runs_a_standalone_model_exchange_fmu_without_any_python(fmu_dir, c_hosts, tmp_path):
    """The second host without Python for model exchange (OMSimulator's command line refuses FMI 3.0 model
    exchange): fmusim, where it is built (it cannot be committed: PRESSDRIVE_FMUSIM or fmusim on PATH)."""
    if _fmusim() is None:
        pytest.skip("fmusim is not built here (build it from the Modelica Reference-FMUs' sources, v0.0.39 has it, "
                    "against Debian's libxml2-dev, libminizip-dev and libsundials-dev, and set PRESSDRIVE_FMUSIM): "
                    "model exchange standalone FMUs ran in the toolkit's C host only")
    check_standalone(fmu_dir, c_hosts, tmp_path, {"fmi2": (), "fmi3": (), "fmi3me": ("gear_sectors",), "drives": ()})


@pytest.mark.slow
@pytest.mark.interop
def test_every_standalone_fmu_runs_without_any_python(fmu_dir, c_hosts, tmp_path):
    """Every component and every shipped drive standalone, each in one of its kinds (:data:`COVERING`, the module
    docstring), as the default test checks one of each kind."""
    assert set(sum((COVERING[v] for v in VARIANTS), ())) == set(COMPONENTS) and len(COMPONENTS) >= 15
    assert {name for name, _ in COVERING["drives"]} == set(system_names())
    check_standalone(fmu_dir, c_hosts, tmp_path, COVERING)


def test_a_standalone_fmu_carries_its_python_trimmed_and_says_so(fmu_dir, tmp_path):
    """What the FMU carries: the builder's libpython, the standard library it imports (no tkinter, unittest,
    asyncio or test package), numpy without its tests, the libraries the extension modules need; a loader that
    links no libpython (no undefined Py symbol); documentation that says it carries Python, needsExecutionTool
    false; fmpy's validation passes."""
    from fmpy.validation import validate_fmu

    made = build_standalone(fmu_dir, tmp_path, {"fmi2": ("gain",), "fmi3": ("gain",), "fmi3me": ("gain",),
                                                "drives": ()})
    version = f"{sys.version_info.major}.{sys.version_info.minor}"
    for fmu, fmi_version in made.items():
        path = tmp_path / fmu
        assert validate_fmu(str(path)) == [], fmu
        _check_documented(path, fmi_version, standalone=True)
        platform = "linux64" if fmi_version == 2 else "x86_64-linux"
        with zipfile.ZipFile(path) as z:
            names = z.namelist()
            config = dict(line.split("=", 1) for line in z.read("resources/pressdrive_python.txt").decode().splitlines())
        carried = f"binaries/{platform}/python/"
        assert config["standalone"] == "python" and f"{carried}lib/{config['soname']}" in names
        assert all(f"{carried}lib/{lib}" in names for lib in config["preload"].split())
        stdlib = {n.removeprefix(f"{carried}lib/python{version}/").split("/")[0] for n in names
                  if n.startswith(f"{carried}lib/python{version}/")}
        assert {"os.py", "encodings", "json", "site-packages", "lib-dynload"} <= stdlib
        assert not {"tkinter", "unittest", "asyncio", "test", "idlelib", "ensurepip"} & stdlib
        assert not [n for n in names if "/numpy/" in n and "/tests/" in n]
        from fmpy import read_model_description

        loader = unpacked(path) / "binaries" / platform / f"{model_identifier(read_model_description(str(path)))}.so"
        undefined = subprocess.run(["nm", "-D", "--undefined-only", str(loader)], capture_output=True, text=True)
        assert undefined.returncode == 0 and " Py" not in undefined.stdout, undefined.stdout


def test_a_python_that_cannot_be_carried_is_refused_in_one_line(monkeypatch, capsys, tmp_path):
    """A Python built without a shared libpython (--enable-shared) cannot be carried: build_fmus says so in one
    line and builds nothing; the CLI refuses --standalone for an SSP in one line."""
    import sysconfig

    from fmus import build as build_fmus

    real = sysconfig.get_config_var
    monkeypatch.setattr(sysconfig, "get_config_var", lambda name: 0 if name == "Py_ENABLE_SHARED" else real(name))
    assert build_fmus.main(["--standalone", "--only", "gain", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "built without --enable-shared" in err[0] and not list(tmp_path.iterdir())
    monkeypatch.undo()
    r = subprocess.run([sys.executable, "-m", "harness", "export", "two_inertia", str(tmp_path / "x.ssp"),
                        "--standalone"], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode != 0 and "--standalone applies to a drive FMU (.fmu)" in r.stderr, r.stderr[-800:]
