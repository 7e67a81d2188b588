"""What the tests of the Modelica Reference-FMUs share (tests/test_reference_fmus.py, test_fmi_content.py,
test_ssp_connections.py): their one build from the pinned sources in tests/reference_fmus, the system of all
six, and a run with the FMUs' warnings silenced.  A helper module, not a test file: it holds no test."""
from __future__ import annotations

import shutil
import subprocess
import warnings
from pathlib import Path

import pytest

from harness import simulate
from harness.model import Connection, Experiment, Instance, System

SOURCES = Path(__file__).resolve().parent / "reference_fmus"
MODELS = ("BouncingBall", "Dahlquist", "Feedthrough", "Resource", "Stair", "VanDerPol")


def quiet(system, **kw):
    """:func:`harness.simulate` with the FMUs' own warnings silenced."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(system, **kw)


def build_reference_fmus(out: Path, version: int) -> dict[str, Path]:
    """The Reference-FMUs of tests/reference_fmus built with cmake for FMI ``version`` into ``out``: model name
    -> .fmu.  Skips, saying why, without cmake, a C compiler or the sources, or when the build fails."""
    if shutil.which("cmake") is None:
        pytest.skip("cmake is not installed: cannot build the Reference-FMUs")
    if shutil.which("cc") is None and shutil.which("gcc") is None:
        pytest.skip("no C compiler (cc/gcc): cannot build the Reference-FMUs")
    if not (SOURCES / "CMakeLists.txt").is_file():
        pytest.skip(f"no Reference-FMUs sources in {SOURCES}")
    # gcc 12+ flags a strncpy in Resource/model.c (FMI 3.0 only) under the sources' own -Werror
    for cmd in (["cmake", str(SOURCES), f"-DFMI_VERSION={version}", "-DCMAKE_BUILD_TYPE=Release",
                 "-DCMAKE_C_FLAGS=-Wno-error=stringop-truncation"], ["cmake", "--build", ".", "-j", "2"]):
        r = subprocess.run(cmd, cwd=out, capture_output=True, text=True)
        if r.returncode != 0:
            pytest.skip(f"building the Reference-FMUs failed ({' '.join(cmd[:2])}): {r.stderr.strip()[-300:]}")
    fmus = {p.stem: p for p in (out / "fmus").glob("*.fmu")}
    missing = [m for m in MODELS if m not in fmus]
    if missing:
        pytest.skip(f"the Reference-FMUs build made no {', '.join(missing)}")
    return fmus


def reference_system(fmus: dict, *, float_chain: bool = True, feedthrough: bool = True,
                     stop: float = 3.0, step: float = 0.01) -> System:
    """All six (Feedthrough twice): Stair -> Feedthrough (Int32), VanDerPol -> Feedthrough (Float64),
    Feedthrough -> Feedthrough (Int32, Boolean; with ``float_chain`` Float64 too), BouncingBall -> Feedthrough
    (Float64).  ``feedthrough=False``: without the Feedthrough instances and so without connections (libcosim
    0.11 aborts the process on their ssc:Enumeration connectors)."""
    common = [Instance("bb", str(fmus["BouncingBall"])), Instance("dq", str(fmus["Dahlquist"])),
              Instance("stair", str(fmus["Stair"]))]
    vdp = Instance("vdp", str(fmus["VanDerPol"]), {"mu": 1.5})
    experiment = Experiment(stop_time=stop, step=step)
    if not feedthrough:
        return System("reference_no_ft", common + [Instance("res", str(fmus["Resource"])), vdp],
                      experiment=experiment)
    connections = [Connection("stair.counter", "ft.Int32_input"),
                   Connection("vdp.x0", "ft.Float64_continuous_input"),
                   Connection("ft.Int32_output", "ft2.Int32_input"),
                   Connection("ft.Boolean_output", "ft2.Boolean_input")]
    if float_chain:
        connections.append(Connection("ft.Float64_continuous_output", "ft2.Float64_discrete_input"))
    connections.append(Connection("bb.h", "ft2.Float64_continuous_input"))
    return System("reference", common + [Instance("ft", str(fmus["Feedthrough"])),
                                         Instance("ft2", str(fmus["Feedthrough"])),
                                         Instance("res", str(fmus["Resource"])), vdp],
                  connections, experiment=experiment)
