"""OSP's public demo SSP ``dp-ship`` (tests/osp/, MIT) through the harness, compared with libcosim (issue 16).

Five FMI 1.0 co-simulation FMUs in feedback (DP controller, observer, reference generator, thrust
allocation, ship), none declaring output dependencies, one with an invalid modelDescription.xml (a name
declared twice).  The harness loads the SSD as it is, with one warning line per problem, runs it with the
master the SSD's OSP annotation gives (step 0.04 s) and, with ``jacobi-sampled`` (libcosim's algorithm),
agrees with libcosim on every Real output to 1e-9 of that output's largest magnitude.
"""
from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from harness import load, simulate
from harness.errors import HarnessError
from harness.fmi.cache import InvalidModelDescription
from benchmarks import peers

SSD = Path(__file__).parent / "osp" / "dp-ship" / "SystemStructure.ssd"
STOP = 10.0


@pytest.fixture
def ssd(tmp_path) -> Path:
    """A private copy (the model-description cache warns once per file and modification time)."""
    folder = tmp_path / "dp-ship"
    shutil.copytree(SSD.parent, folder)
    return folder / SSD.name


def _run(path, **kw):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        df = simulate(path, stop_time=STOP, **kw)
    return df, caught


def test_dp_ship_runs_with_the_default_master_and_says_what_it_assumed(ssd):
    with warnings.catch_warnings(record=True) as loading:   # the load reads the FMUs' descriptions (bindings)
        warnings.simplefilter("always")
        system = load(ssd)
    assert system.experiment.step == pytest.approx(0.04)  # the OSP FixedStepAlgorithm annotation
    df, caught = _run(ssd)
    assert df.attrs["complete"], df.attrs.get("error")
    assert len(df) == round(STOP / 0.04) + 1
    assert np.isfinite(df.select_dtypes(float).to_numpy()).all()
    invalid = [str(w.message) for w in loading + caught if issubclass(w.category, InvalidModelDescription)]
    assert len(invalid) == 1 and "\n" not in invalid[0]
    assert "DPController.fmu" in invalid[0] and '"iex"' in invalid[0] and "loaded anyway" in invalid[0]
    # the controller acts: its force demand leaves zero as the ship drifts
    assert np.abs(df["DP Controller.Controlx"].to_numpy()).max() > 1.0


def test_a_variable_declared_twice_cannot_be_used_and_is_named(ssd):
    from harness.fmi import FMU1, open_instance

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        inst = open_instance(ssd.parent / "DPController.fmu", "dp")
    try:
        assert isinstance(inst, FMU1)
        assert inst.var("Controlx").causality == "output"
        with pytest.raises(HarnessError) as e:
            inst.var("iex")
        msg = str(e.value)
        assert "\n" not in msg and "'iex'" in msg and "more than once" in msg
    finally:
        inst.free()


def test_dp_ship_agrees_with_libcosim(ssd):
    avail = peers.available()
    if avail.get("libcosim") is not None:
        pytest.skip(f"libcosim not available: {avail['libcosim']}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = simulate(ssd, stop_time=STOP, master="jacobi-sampled")
        cols = [c for c in df.columns if df[c].dtype == np.float64]
        assert len(cols) >= 20
        ref = peers.run_isolated(peers.run_ssp_libcosim, ssd, STOP, 0.04, cols)
    assert len(ref) == len(df)
    a, b = ref[cols].to_numpy(), df[cols].to_numpy()
    scale = np.maximum(np.abs(b).max(axis=0), 1e-12)
    err = np.abs(a - b).max(axis=0) / scale
    assert err.max() <= 1e-9, f"{cols[int(np.argmax(err))]} differs from libcosim by {err.max():.3g} of its range"
