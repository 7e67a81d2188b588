"""The Modelica Reference-FMUs (FMI 2.0 CS, built from the pinned sources in tests/reference_fmus with cmake)
through the harness (issue 16): each FMU alone against ``fmpy.simulate_fmu``, and all six in one system with
Integer and Boolean connections, exported as SSP and run in libcosim and Ecos.  Without cmake or a C compiler, or when the build fails, the
tests fail (tests/build_cache.py)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness.model import Experiment, Instance, System
from harness.ssp import export_ssp
from benchmarks import peers
import reference_builds
from reference_builds import MODELS, quiet, reference_system

STOP, STEP = 3.0, 0.01


@pytest.fixture(scope="session")
def reference_fmus() -> dict[str, Path]:
    return reference_builds.reference_fmus(2)


@pytest.mark.parametrize("model", MODELS)
def test_each_reference_fmu_alone_matches_fmpy(reference_fmus, model):
    from fmpy import simulate_fmu

    fmu = reference_fmus[model]
    df = quiet(System(model, [Instance("m", str(fmu))], experiment=Experiment(stop_time=STOP, step=STEP)),
               master="jacobi-sampled")
    ref = pd.DataFrame(simulate_fmu(str(fmu), stop_time=STOP, step_size=STEP, output_interval=STEP,
                                    fmi_type="CoSimulation")).set_index("time")
    assert len(df) == len(ref)
    np.testing.assert_allclose(df.index.to_numpy(), ref.index.to_numpy(), rtol=1e-12, atol=1e-12)
    compared = 0
    for col in ref.columns:
        ours = df[f"m.{col}"]
        if ours.dtype == object:
            assert list(ours) == [v.decode() if isinstance(v, bytes) else v for v in ref[col]]
        else:
            a, b = ours.to_numpy(dtype=float), ref[col].to_numpy(dtype=float)
            scale = max(np.abs(b).max(), 1.0)
            assert np.abs(a - b).max() <= 1e-9 * scale, f"{model}.{col}: {np.abs(a - b).max():.3g}"
            assert ours.dtype == {"Real": np.float64, "Integer": np.int64, "Enumeration": np.int64,
                                  "Boolean": bool}[_type(fmu, col)]
        compared += 1
    assert compared >= 1


def _type(fmu: Path, name: str) -> str:
    from harness.model import model_description

    return {v.name: v.type for v in model_description(fmu).modelVariables}[name]


def system(fmus: dict, feedthrough: bool = True) -> System:
    """All six without the Float64 chain between the Feedthroughs (:func:`reference_builds.reference_system`)."""
    return reference_system(fmus, float_chain=False, feedthrough=feedthrough, stop=STOP, step=STEP)


@pytest.mark.parametrize("master", ["jacobi-sampled", "jacobi", "gauss-seidel", "iterative", "jacobian"])
def test_reference_system_with_integer_and_boolean_connections(reference_fmus, master):
    df = quiet(system(reference_fmus), master=master)
    assert len(df) == round(STOP / STEP) + 1 and df.attrs["complete"]
    assert df["stair.counter"].dtype == np.int64 and df["ft2.Boolean_output"].dtype == bool
    counter = df["stair.counter"].to_numpy()
    if master in ("jacobi", "iterative", "jacobian"):
        # these refresh declared feed-through at each point, Integer and Boolean as Real: Feedthrough's
        # outputs are its inputs of the same point, through the chain stair -> ft -> ft2
        assert (df["ft.Int32_output"].to_numpy() == counter).all()
        assert (df["ft2.Int32_output"].to_numpy() == counter).all()
        assert (df["ft2.Boolean_output"].to_numpy() == df["ft.Boolean_output"].to_numpy()).all()
    else:
        # sampled (libcosim's and Ecos's way): each input holds its source's value from the step's start,
        # one step of delay per feed-through FMU
        assert (df["ft.Int32_output"].to_numpy()[1:] == counter[:-1]).all()
        assert (df["ft2.Int32_output"].to_numpy()[2:] == counter[:-2]).all()
    assert counter[-1] > counter[0]


@pytest.mark.parametrize("tool", ["libcosim", "ecos"])
def test_reference_system_agrees_with_peer_tools(reference_fmus, tmp_path, tool):
    avail = peers.available()
    if avail.get(tool) is not None:
        pytest.skip(f"{tool} not available: {avail[tool]}")
    reference_ssp = export_ssp(system(reference_fmus, feedthrough=tool != "libcosim"), tmp_path / "reference.ssp")
    ref = quiet(reference_ssp, master="jacobi-sampled")
    # outputs without feed-through (Ecos records feed-through outputs after the input update: test_ssp.py)
    cols = ["bb.h", "bb.v", "dq.x", "vdp.x0", "vdp.x1"]
    if tool == "libcosim":
        df = peers.run_isolated(peers.run_ssp_libcosim, reference_ssp, STOP, STEP, cols)
    else:
        df = peers.run_ssp_ecos(reference_ssp, STOP, STEP, cols, parameter_set="default")
    assert len(df) == len(ref)
    a, b = df[cols].to_numpy(), ref[cols].to_numpy()
    err = np.abs(a - b).max(axis=0) / np.maximum(np.abs(b).max(axis=0), 1.0)
    assert err.max() <= 1e-9, f"{tool}: {cols[int(np.argmax(err))]} differs by {err.max():.3g}"
