"""The FMI 3.0 FMUs in hosts nobody here wrote and in hosts without Python (split from tests/test_fmi3_export.py):
OMSimulator 3.0 (its Python API) runs each FMU and the SSP of a drive made of them like fmpy and the toolkit's
Jacobi; fmpy loads, frees and loads them again; a C host without Python runs each through the FMI 3.0 host
loader (fmus/loader/pressdrive_loader3.c) like fmpy, and a missing Python environment is one clear error."""
from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from fmpy import extract, read_model_description, simulate_fmu

from test_fmi3_export import CATALOG
from test_hosts import _run_script, clean_env

# -- OMSimulator (a host nobody here wrote; its Python API: the FMUs' wrapper needs the Python of the process) ----
def _omsimulator_missing() -> str | None:
    try:
        import OMSimulator  # noqa: F401
    except Exception as e:
        return (f"OMSimulator's Python API is not installed ({type(e).__name__}); install it with "
                f"../shared/tools/omsimulator/install where that folder exists")
    return None


@pytest.mark.interop
def test_omsimulator_runs_every_fmi3_fmu_like_fmpy(fmu3_dir, tmp_path):
    """Each FMI 3.0 FMU alone in OMSimulator 3.0 (its inputs at their start values) over 50 steps of 1 ms: every
    output it records equals fmpy's run of the same FMU to 1e-9 of max(|output|, 1)."""
    reason = _omsimulator_missing()
    if reason:
        pytest.skip(reason)
    out = _run_script(f"""
        import json
        from pathlib import Path
        import numpy as np, pandas as pd
        from fmpy import simulate_fmu
        from OMSimulator import SSP, CRef
        stop, step, result = 0.05, 1e-3, {{}}
        for fmu in sorted(Path({str(fmu3_dir)!r}).glob("*.fmu")):
            m = SSP()
            m.addResource(str(fmu), new_name=f"resources/{{fmu.name}}")
            m.addComponent(CRef("default", "c"), f"resources/{{fmu.name}}")
            im = m.instantiate()
            csv = Path({str(tmp_path)!r}) / f"{{fmu.stem}}.csv"
            im.setResultFile(str(csv)); im.setFixedStepSize(step); im.setStopTime(stop)
            im.initialize(); im.simulate(); im.terminate(); im.delete()
            oms = pd.read_csv(csv, skipinitialspace=True)
            oms.columns = [c.strip().strip('"') for c in oms.columns]
            # the FMU's own independent variable is recorded as default.c.time beside OMSimulator's time
            oms = oms.drop(columns=["default.c.time"], errors="ignore")
            oms.columns = [c.removeprefix("default.c.") for c in oms.columns]
            oms = oms.groupby("time").last()   # OMSimulator writes each point before and after the input update
            ref = pd.DataFrame(simulate_fmu(str(fmu), stop_time=stop, step_size=step,
                                            output_interval=step)).set_index("time")
            cols = [c for c in ref.columns if c in oms.columns]
            rows = len(oms) == len(ref)
            scale = np.maximum(ref[cols].abs().max().to_numpy(), 1.0)
            error = np.abs(oms[cols].to_numpy() - ref[cols].to_numpy()).max(axis=0) / scale if rows else None
            worst = float(error.max()) if rows else None
            result[fmu.stem] = [len(cols), rows, worst]
        print(json.dumps(result))
    """)
    result = json.loads(out.strip().splitlines()[-1])
    assert sorted(result) == sorted(CATALOG)
    for name, (n_cols, same_rows, worst) in result.items():
        assert n_cols >= 1 and same_rows, (name, n_cols, same_rows)
        assert worst <= 1e-9, f"{name}: OMSimulator differs from fmpy by {worst:.3g}"


# OMSimulator 3.0 takes these FMI 3.0 FMUs' outputs as depending on every input (their Output/InitialUnknown
# dependencies are those of the FMI 2.0 builds, read by fmpy as such; the FMI 2.0 builds of the same drives have
# no loop there), finds an algebraic loop (feeder_gto52 9 of 30 variables, bed_drive 18 of 78) and solves it with
# KINSOL, which asks for directional derivatives the FMUs do not provide, unless told to use finite differences.
# Tried without effect: value references equal to 1-based indices, no empty dependency list, dependenciesKind,
# initial="calculated" on the outputs, no independent variable.  With finite differences it iterates the loop
# every step: bed_drive then differs from the Jacobi run by 3.4e-2 of a range (measured), the others agree.
_NO_DD = "--directionalDerivatives=false"
_OMS_CASES = [pytest.param("two_inertia", ""), pytest.param("feeder_gto52", _NO_DD),
              pytest.param("bed_drive", _NO_DD, marks=pytest.mark.xfail(strict=True, reason=(
                  "OMSimulator iterates the loop it sees among the FMI 3.0 FMUs (see above): 3.4e-2 of a range "
                  "from the Jacobi run, measured"))),
              pytest.param("spine_knife", _NO_DD), pytest.param("proof_press", _NO_DD)]


@pytest.mark.interop
@pytest.mark.parametrize("name,options", _OMS_CASES)
def test_omsimulator_runs_the_ssp_of_a_drive_made_of_fmi3_fmus(name, options, fmu3_dir, fmu_dir, tmp_path):
    """The drive exported as SSP (harness.ssp.export_ssp) from its FMI 3.0 FMUs, run by OMSimulator's API over
    20 steps: every value at the end equals the master's Jacobi zero-order-hold run of the FMI 2.0 FMUs to 1e-9
    of its range (OMSimulator's own master is a Jacobi that refreshes feed-through outputs).  ``options``: the
    OMSimulator command-line options the drive needs (above)."""
    reason = _omsimulator_missing()
    if reason:
        pytest.skip(reason)
    out = _run_script(f"""
        import json, warnings
        from pathlib import Path
        from harness import load, simulate
        from harness.ssp import export_ssp
        from OMSimulator import SSP, CRef, capi

        for option in {options!r}.split():
            capi.Capi.setCommandLineOption(option)

        def on(folder):
            return load({name!r}).on_fmus(folder)

        s3 = on({str(fmu3_dir)!r})
        ssp = export_ssp(s3, Path({str(tmp_path)!r}) / "drive.ssp")
        step = s3.experiment.step
        stop = 20 * step
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ref = simulate(on({str(fmu_dir)!r}), stop_time=stop, step=step, master="jacobi", extrapolation=0,
                           on_error="raise")
        im = SSP(str(ssp)).instantiate()
        im.setFixedStepSize(step); im.setStopTime(stop); im.setResultFile({str(tmp_path / 'oms.mat')!r})
        im.initialize(); im.simulate()
        errors = {{}}
        for c in ref.columns:
            inst, var = c.split(".", 1)
            value = im.getValue(CRef(s3.name, inst, var))
            errors[c] = abs(value - ref[c].iloc[-1]) / max(float(ref[c].abs().max()), 1e-2)
        im.terminate(); im.delete()
        print(json.dumps(errors))
    """)
    errors = json.loads(out.strip().splitlines()[-1])
    worst = max(errors, key=errors.get)
    assert len(errors) >= 2 and errors[worst] <= 1e-9, f"{name}: {worst} differs by {errors[worst]:.3g}"


def test_fmi3_fmus_load_free_and_load_again_under_fmpy(fmu3_dir):
    """fmpy.simulate_fmu unpacks each FMU into a temporary folder and deletes it afterwards: the FMUs share their
    build's runtime package (fmus_<hash>, imported from the first FMU's folder), each finds its own declaration in
    its own folder, and a module only a function imports (CamRocker's law 8 imports the seed-004 carrier law) is
    found after its folder is gone."""
    law8 = {"mechanism": 1, "swing": 0.6981317007977318, "law": 8, "law_return": 0, "law_km": 0.246176}
    order = ["FourBar", "CamRocker", "FourBar", "RackBed", "CamRocker", "MotorBelt"]
    out = _run_script(f"""
        import os, sys
        from fmpy import simulate_fmu
        for name in {order!r}:
            r = simulate_fmu(os.path.join({str(fmu3_dir)!r}, name + ".fmu"), stop_time=0.01, step_size=1e-3)
            print(name, len(r))
        r = simulate_fmu(os.path.join({str(fmu3_dir)!r}, "CamRocker.fmu"), stop_time=0.002, step_size=1e-4,
                         output_interval=1e-4,
                         start_values={law8!r})
        print("law8", len(r))
        print("declarations", len([m for m in sys.modules if m.startswith("fmus_") and ".components.pd_" in m]))
        print("packages", sorted(m for m in sys.modules if m.startswith("fmus_") and "." not in m))
    """)
    lines = out.splitlines()
    assert [line.split()[0] for line in lines[:-3]] == order
    assert lines[-3] == "law8 21"
    assert lines[-2] == "declarations 4"          # one declaration per distinct FMU
    assert lines[-1].count("fmus_") == 1          # one runtime package for the whole build


# -- hosts without Python: the FMI 3.0 host loader (fmus/loader/pressdrive_loader3.c) ------------------------------
@pytest.fixture(scope="module")
def c_host(c_hosts) -> Path:
    """tests/c_hosts/fmi3_host.c compiled (conftest: c_hosts): a C program that runs an FMI 3.0 FMU, no Python in it."""
    return c_hosts[3]


def _run_in_c_host(c_host: Path, fmu: Path, where: Path, steps: int, inputs: dict, outputs: list, env: dict):
    folder = Path(extract(str(fmu), unzipdir=str(where / fmu.stem)))
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    args = [str(c_host), str(folder / "binaries" / "x86_64-linux" / f"{fmu.stem}.so"), str(folder / "resources"),
            md.guid, str(steps), "0.001", ",".join(f"{vr[k]}={v!r}" for k, v in inputs.items()),
            ",".join(str(vr[o]) for o in outputs)]
    return subprocess.run(args, capture_output=True, text=True, env=env, timeout=300)


def test_every_fmi3_fmu_runs_in_a_c_host_without_python_like_fmpy(fmu3_dir, c_host, tmp_path):
    """The loader finds the recorded Python, initialises it with the recorded environment and hands every call
    to pythonfmu3's wrapper: each FMU, its inputs held at 0.1, 0.2, ... over 100 steps of 1 ms, gives fmpy's
    outputs (fmpy's steps are differences of multiples of 1 ms, the host's exactly 1 ms: 1e-9 of max(|y|, 1)).
    The host exits normally (status 0: pythonfmu3's wrapper no longer corrupts the heap at exit)."""
    for name in sorted(CATALOG):
        fmu = fmu3_dir / f"{name}.fmu"
        md = read_model_description(str(fmu))
        inputs = {v.name: 0.1 * (i + 1) for i, v in enumerate(v for v in md.modelVariables if v.causality == "input")}
        outputs = [v.name for v in md.modelVariables if v.causality == "output"]
        r = _run_in_c_host(c_host, fmu, tmp_path, 100, inputs, outputs, clean_env())
        assert r.returncode == 0, f"{name}: exit {r.returncode}: {(r.stdout + r.stderr)[-800:]}"
        got = dict(line.split() for line in r.stdout.splitlines() if not line.startswith("LOG"))
        ref = simulate_fmu(str(fmu), stop_time=0.1, step_size=1e-3, output_interval=1e-3, start_values=inputs,
                           output=outputs)
        vr = {v.name: str(v.valueReference) for v in md.modelVariables}
        for o in outputs:
            want = float(ref[o][-1])
            assert abs(float(got[vr[o]]) - want) <= 1e-9 * max(abs(want), 1.0), (name, o, got[vr[o]], want)


def test_a_missing_python_environment_is_one_clear_fmi3_error(fmu3_dir, c_host, tmp_path):
    r = _run_in_c_host(c_host, fmu3_dir / "FourBar.fmu", tmp_path, 1, {}, ["crank.tau"],
                       clean_env(PRESSDRIVE_LIBPYTHON="/nonexistent/libpython3.so"))
    assert r.returncode == 3 and "NOINSTANCE" in r.stdout, r.stdout + r.stderr
    errors = [line for line in r.stdout.splitlines() if line.startswith("LOG 3 logStatusError")]
    assert len(errors) == 1 and "PRESSDRIVE_LIBPYTHON='/nonexistent/libpython3.so' does not load" in errors[0]
    assert "a Python 3.10 or newer that has numpy" in errors[0]
