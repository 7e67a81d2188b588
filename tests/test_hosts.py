"""The toolkit's FMUs and SSP files in every FMI host (issue 17).

* Non-Python hosts: OMSimulator's command-line tool (a C++ process without Python) runs every FMU with no
  environment set by hand (the host loader of fmus/loader finds the recorded Python) and its CSV matches
  ``fmpy.simulate_fmu`` on the same FMU; with the environment gone it logs one clear error line.
* Isolation: FMUs loaded, freed (their unpacked folder deleted) and loaded again, different ones one after
  the other, in one process under fmpy, libcosim and Ecos, and two builds from different sources side by side.
* Exported SSDs validate against the SSP 1.0 schema that fmpy ships, and ``fmpy.ssp.simulate_ssp`` loads them.

Tests that need OMSimulator, libcosim or Ecos skip, saying why, where the tool is absent.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from benchmarks import peers
from harness import load
from harness.ssp import export_ssp

ROOT = Path(__file__).resolve().parents[1]
SYSTEMS = ("two_inertia", "feeder_gto52", "bed_drive", "spine_knife", "proof_press")
AVAILABLE = peers.available()


def omsimulator_cli() -> Path | None:
    for candidate in (Path(sys.executable).parent / "OMSimulator", shutil.which("OMSimulator")):
        if candidate and Path(candidate).is_file():
            return Path(candidate)
    return None


OMS_CLI = omsimulator_cli()
NO_OMS = ("OMSimulator's command-line tool is not installed in this environment "
          "(install it with ../shared/tools/omsimulator/install where that folder exists)")


def clean_env(**extra) -> dict:
    """The process environment without anything that would point a host at Python."""
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("PYTHON", "PRESSDRIVE_", "VIRTUAL_ENV", "LD_PRELOAD"))}
    env.update(extra)
    return env


def fmus_of(fmu_dir: Path) -> list[Path]:
    return sorted(fmu_dir.glob("*.fmu"))



@pytest.fixture(scope="module")
def archives(fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("ssp_hosts")
    return {name: export_ssp(load(name).on_fmus(fmu_dir), out / f"{name}.ssp") for name in SYSTEMS}


# ------------------------------------------------------------------------------------------ the host loader
# per FMI version: the fixture of its FMUs, the platform folder of its binaries, the exporter whose wrapper the loader
# loads (fmus/build.py: LOADERS)
VERSIONS = {2: ("fmu_dir", "linux64", "pythonfmu"), 3: ("fmu3_dir", "x86_64-linux", "pythonfmu3")}


@pytest.mark.parametrize("version", VERSIONS)
def test_every_fmu_carries_the_loader_and_the_recorded_python(request, version):
    fixture, platform, exporter = VERSIONS[version]
    for fmu in fmus_of(request.getfixturevalue(fixture)):
        with zipfile.ZipFile(fmu) as z:
            names = set(z.namelist())
            ident = fmu.stem
            assert {f"binaries/{platform}/{ident}.so", f"binaries/{platform}/{ident}_{exporter}.so",
                    "resources/pressdrive_python.txt"} <= names, fmu.name
            config = dict(line.split("=", 1) for line in
                          z.read("resources/pressdrive_python.txt").decode().splitlines())
        assert config["version"] == f"{sys.version_info.major}.{sys.version_info.minor}"
        assert config["minimum"] == "3.10"     # not the builder's: any Python from 3.10 runs it (tests/test_handoff.py)
        assert Path(config["libpython"]).is_file() and Path(config["home"]) == Path(sys.base_prefix)


def _oms_run(fmu: Path, workdir: Path, stop: float, step: float, env: dict) -> subprocess.CompletedProcess:
    return subprocess.run([str(OMS_CLI), str(fmu), f"--stopTime={stop}", f"--stepSize={step}",
                           f"--resultFile={fmu.stem}.csv"], cwd=workdir, env=env, capture_output=True,
                          text=True, timeout=300)


@pytest.mark.interop
@pytest.mark.parametrize("version", VERSIONS)
def test_omsimulator_cli_runs_every_fmu_like_fmpy(request, version, tmp_path):
    """OMSimulator's command-line tool, a C++ process without Python, in an environment that names no Python:
    every FMU of either FMI version (inputs at their start values) over 50 steps of 1 ms equals fmpy to 1e-9 of
    max(|y|, 1)."""
    if OMS_CLI is None:
        pytest.skip(NO_OMS)
    from fmpy import simulate_fmu

    fmu_dir = request.getfixturevalue(VERSIONS[version][0])
    stop, step = 0.05, 1e-3
    compared = 0
    for fmu in fmus_of(fmu_dir):
        r = _oms_run(fmu, tmp_path, stop, step, clean_env())
        text = r.stdout + r.stderr
        assert r.returncode == 0 and "error" not in text.lower(), f"{fmu.name}: {text[-800:]}"
        oms = pd.read_csv(tmp_path / f"{fmu.stem}.csv", skipinitialspace=True)
        oms.columns = [c.strip().strip('"') for c in oms.columns]
        # OMSimulator writes each communication point twice (before and after the input update): keep the last;
        # an FMI 3.0 FMU's own independent variable 'time' comes after OMSimulator's: pandas names it time.1
        oms = oms.drop(columns=["time.1"], errors="ignore").groupby("time").last()
        ref = simulate_fmu(str(fmu), stop_time=stop, step_size=step, output_interval=step,
                           fmi_type="CoSimulation")
        ref = pd.DataFrame(ref).set_index("time")
        cols = [c for c in ref.columns if c in oms.columns]
        assert len(cols) >= 1, fmu.name
        assert len(oms) == len(ref), f"{fmu.name}: {len(oms)} rows, fmpy {len(ref)}"
        scale = np.maximum(ref[cols].abs().max().to_numpy(), 1.0)
        err = (oms[cols].to_numpy() - ref[cols].to_numpy())
        worst = np.abs(err).max(axis=0) / scale
        assert worst.max() <= 1e-9, f"{fmu.name}: {cols[int(np.argmax(worst))]} differs by {worst.max():.3g}"
        compared += 1
    assert compared == len(fmus_of(fmu_dir)) >= 10


@pytest.mark.interop
def test_a_missing_environment_is_one_clear_fmi_error(fmu_dir, tmp_path):
    if OMS_CLI is None:
        pytest.skip(NO_OMS)
    fmu = fmu_dir / "Gain.fmu"
    r = _oms_run(fmu, tmp_path, 0.01, 1e-3, clean_env(PRESSDRIVE_LIBPYTHON="/nonexistent/libpython3.so"))
    text = r.stdout + r.stderr
    assert "PRESSDRIVE_LIBPYTHON='/nonexistent/libpython3.so' does not load" in text, text[-800:]
    assert "a Python 3.10 or newer that has numpy" in text
    assert "undefined symbol" not in text


# ------------------------------------------------------------------------------------------ isolation
def _run_script(code: str, timeout: float = 600) -> str:
    # leave with os._exit once everything is printed: tearing the interpreter down with pythonfmu instances
    # of a peer tool still referenced has aborted with "corrupted double-linked list" (tests/conftest.py)
    code = textwrap.dedent(code) + "\nimport os as _os, sys as _sys\n_sys.stdout.flush(); _os._exit(0)\n"
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       timeout=timeout, env={**os.environ, "PRESSDRIVE_NORMAL_EXIT": "1"})
    assert r.returncode == 0, f"exit {r.returncode}: {(r.stdout + r.stderr)[-1500:]}"
    return r.stdout


def test_load_free_load_another_and_again_under_fmpy(fmu_dir):
    """fmpy.simulate_fmu unpacks each FMU into a temporary folder and deletes it afterwards."""
    order = ["FourBar", "CamRocker", "FourBar", "RackBed", "CamRocker", "MotorBelt"]
    out = _run_script(f"""
        import os, sys
        from fmpy import simulate_fmu
        for name in {order!r}:
            r = simulate_fmu(os.path.join({str(fmu_dir)!r}, name + ".fmu"), stop_time=0.01, step_size=1e-3)
            print(name, len(r))
        print("declarations", len([m for m in sys.modules if m.startswith("fmus_") and ".components.pd_" in m]))
        print("packages", sorted(m for m in sys.modules if m.startswith("fmus_") and "." not in m))
    """)
    lines = out.splitlines()
    assert [line.split()[0] for line in lines[:-2]] == order
    assert lines[-2] == "declarations 4"          # one declaration per distinct FMU
    assert lines[-1].count("fmus_") == 1          # one runtime package for the whole build


@pytest.mark.interop
@pytest.mark.parametrize("tool", ["libcosim", "ecos"])
def test_load_free_load_another_and_again_in_peer(archives, tool):
    """Whole SSPs one after the other in ONE process: each tool unpacks the FMUs into its own folder and
    deletes it when the execution is freed (no FMU code is imported beforehand from anywhere else)."""
    if AVAILABLE[tool]:
        pytest.skip(AVAILABLE[tool])
    runs = [("spine_knife", "linkage.rocker.phi"), ("feeder_gto52", "feeder.rocker.phi"),
            ("spine_knife", "linkage.rocker.phi"), ("bed_drive", "bed.bed.s"), ("feeder_gto52", "feeder.rocker.phi")]
    runs = [(str(archives[name]), col) for name, col in runs]
    call = ("peers.run_ssp_libcosim(path, 0.002, 1e-4, [col])" if tool == "libcosim"
            else "peers.run_ssp_ecos(path, 0.002, 1e-4, [col], parameter_set='default')")
    out = _run_script(f"""
        from benchmarks import peers
        for path, col in {runs!r}:
            df = {call}
            print(len(df), bool(df[col].notna().all()))
    """)
    assert out.split() == ["21", "True"] * len(runs)   # t = 0 and 20 steps


def test_two_builds_from_different_sources_in_one_system(tmp_path):
    """Two Gain FMUs whose code differs (v2 doubles its output): one after the other in fmpy and side by
    side in one system (harness, FMI and in-process paths): one runtime package (the runtime is the same), each
    with its own declaration module."""
    from fmus import build

    src = (ROOT / "fmus" / "components" / "pd_gain.py").read_text()
    v2 = tmp_path / "v2"
    v2.mkdir()
    script = v2 / "pd_gain.py"
    script.write_text(src + textwrap.dedent("""

        class _Doubled(GainModel):
            def output(self, t, x, u):
                y, integral = super().output(t, x, u)
                return (2.0 * y, integral)


        Gain.model = _Doubled
        """))
    out1, out2 = tmp_path / "v1", tmp_path / "v2out"
    out1.mkdir(), out2.mkdir()
    a = build.build_one(ROOT / "fmus" / "components" / "pd_gain.py", out1)
    b = build.build_one(script, out2)
    out = _run_script(f"""
        import sys
        from fmpy import simulate_fmu
        from harness import simulate
        from harness.model import Connection, Experiment, Instance, System
        from harness.run import RunOptions
        for path in ({str(a)!r}, {str(b)!r}, {str(a)!r}):   # one after the other, each unpacked and deleted
            r = simulate_fmu(path, stop_time=0.002, step_size=1e-3, start_values={{"k": 3.0, "offset": 1.0}},
                             output=["y"])
            print(r["y"][-1])
        # and side by side in one system: v1.y = 3*0 + 1 = 1 feeds v2.u, v2.y = 2*(3*1 + 1) = 8
        system = System("versions", instances=[Instance("v1", {str(a)!r}, {{"k": 3.0, "offset": 1.0}}),
                                               Instance("v2", {str(b)!r}, {{"k": 3.0, "offset": 1.0}})],
                        connections=[Connection("v1.y", "v2.u")], experiment=Experiment(stop_time=0.003, step=1e-3))
        for in_process in (False, True):
            df = simulate(system, master="jacobi", on_error="raise", options=RunOptions(in_process=in_process))
            print(df["v1.y"].iloc[-1], df["v2.y"].iloc[-1])
        print(len([m for m in sys.modules if m.startswith("fmus_") and "." not in m]))
        print(len([m for m in sys.modules if m.startswith("fmus_") and ".components.pd_gain_" in m]))
    """)
    values = out.split()
    assert [float(v) for v in values[:7]] == [1.0, 2.0, 1.0, 1.0, 8.0, 1.0, 8.0], out
    assert values[7:] == ["1", "2"]   # one runtime package (one runtime), two declarations


# ------------------------------------------------------------------------------------------ SSP schema
@pytest.mark.parametrize("name", SYSTEMS)
def test_exported_ssd_is_schema_valid_and_fmpy_loads_it(archives, name):
    from lxml import etree
    from fmpy.ssp.ssd import validate_tree
    from fmpy.ssp.simulation import simulate_ssp

    with zipfile.ZipFile(archives[name]) as z:
        root = etree.fromstring(z.read("SystemStructure.ssd"))
    validate_tree(root, "SystemStructureDescription.xsd")      # raises with the schema's messages
    for ann in root.iter("{http://ssp-standard.org/SSP1/SystemStructureCommon}Annotation"):
        assert len(ann) == 1
    result = simulate_ssp(str(archives[name]), stop_time=0.002, step_size=1e-4)
    assert len(result) >= 2 and np.isfinite(result["time"]).all()


# ------------------------------------------------------------------------------------------ OMSimulator API
def _omsimulator_api() -> str | None:
    try:
        import OMSimulator  # noqa: F401
        return None
    except Exception as e:
        return f"OMSimulator's Python API unavailable ({type(e).__name__}: {e}); {NO_OMS}"


# Each output is compared relative to its own range over the run, but never to a range below SCALE_FLOOR (in
# SI units: 0.01 N.m, W, rad, m/s ... is nothing in these drives): spine_knife's belt torque is zero to
# round-off over the first 20 steps (the speed source and the shaft start at the same speed), |tau| ~ 3e-13 N.m
# and the motor's power ~ 5e-11 W, and 2.9e-13 against 2.7e-13 N.m is round-off, not a difference.
SCALE_FLOOR = 1e-2


@pytest.mark.interop
@pytest.mark.parametrize("name", SYSTEMS)
def test_exported_drive_runs_in_omsimulator_api_like_jacobi(fmu_dir, archives, name, tmp_path):
    reason = _omsimulator_api()
    if reason:
        pytest.skip(reason)
    out = _run_script(f"""
        import json, os, warnings
        from harness import load, simulate
        from harness.model import model_description
        from OMSimulator import SSP, CRef
        s = load({name!r}).on_fmus({str(fmu_dir)!r})
        step = s.experiment.step
        stop = 20 * step
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ref = simulate(s, stop_time=stop, step=step, master="jacobi", extrapolation=0, on_error="raise")
        im = SSP({str(archives[name])!r}).instantiate()
        im.setFixedStepSize(step); im.setStopTime(stop); im.setResultFile({str(tmp_path / 'oms.mat')!r})
        im.initialize(); im.simulate()
        feed = set()
        for inst in s.instances:
            md = model_description(inst.fmu)
            feed.update(f"{{inst.name}}.{{o.variable.name}}" for o in md.outputs if o.dependencies)
        errors = {{}}
        for c in ref.columns:
            inst, var = c.split(".", 1)
            value = im.getValue(CRef(s.name, inst, var))
            errors[c] = [abs(value - ref[c].iloc[-1]) / max(float(ref[c].abs().max()), {SCALE_FLOOR!r}), c in feed]
        im.terminate(); im.delete()
        print(json.dumps(errors), flush=True)
        os._exit(0)
    """)
    errors = __import__("json").loads(out.strip().splitlines()[-1])
    states = {c: e for c, (e, feed) in errors.items() if not feed}
    assert len(states) >= 2
    worst = max(states, key=states.get)
    assert states[worst] <= 1e-9, f"{name}: {worst} differs by {states[worst]:.3g} of its range"
    worst = max(errors, key=lambda c: errors[c][0])
    assert errors[worst][0] <= 1e-9, f"{name}: {worst} differs by {errors[worst][0]:.3g} of its range"


def test_nothing_is_imported_lazily_from_a_folder_the_host_deleted(fmu_dir):
    """fmpy.simulate_fmu deletes the folder it unpacked the FMU into; a later instance of the same FMU finds the
    bundled package in sys.modules with its path in that deleted folder.  A module only a function imports
    (CamRocker's law 8 imports the seed-004 carrier law when it is chosen) must already be imported."""
    fmu = str(fmu_dir / "CamRocker.fmu")
    law8 = {"mechanism": 1, "swing": 0.6981317007977318, "law": 8, "law_return": 0, "law_km": 0.246176}
    out = _run_script(f"""
        from fmpy import simulate_fmu
        first = simulate_fmu({fmu!r}, stop_time=0.002, step_size=1e-4)
        again = simulate_fmu({fmu!r}, stop_time=0.002, step_size=1e-4, start_values={law8!r})
        print(len(first), len(again))
    """)
    n_first, n_again = out.split()
    assert n_first == n_again and int(n_first) > 2
