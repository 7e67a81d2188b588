"""What the tests of the Modelica Reference-FMUs share (tests/test_reference_fmus.py, test_fmi_content.py,
test_ssp_connections.py, test_fmi3_arrays.py, test_input_signals.py): their one build from the pinned sources in
tests/reference_fmus (cached for every worker and session, tests/build_cache.py; a failed build fails), the system
of all six, and a run with the FMUs' warnings silenced.  A helper module, not a test file: it holds no test."""
from __future__ import annotations

import shutil
import tempfile
import warnings
from pathlib import Path

from build_cache import BuildError, cached, compiler, run, tool, version_line
from harness import simulate
from harness.model import Connection, Experiment, Instance, System

SOURCES = Path(__file__).resolve().parent / "reference_fmus"
MODELS = ("BouncingBall", "Dahlquist", "Feedthrough", "Resource", "Stair", "VanDerPol")


def quiet(system, **kw):
    """:func:`harness.simulate` with the FMUs' own warnings silenced."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(system, **kw)


def reference_fmus(version: int) -> dict[str, Path]:
    """The Reference-FMUs of tests/reference_fmus built with cmake for FMI ``version``: model name -> .fmu (every
    model the sources hold, :data:`MODELS` among them, and StateSpace and Clocks for FMI 3.0)."""
    cmake, cc = tool("cmake", "build the Reference-FMUs (tests/reference_fmus)"), compiler()

    def make(out: Path) -> None:
        with tempfile.TemporaryDirectory(prefix="reference_fmus_") as work:
            # gcc 12+ flags a strncpy in Resource/model.c (FMI 3.0 only) under the sources' own -Werror
            run([cmake, SOURCES, f"-DFMI_VERSION={version}", "-DCMAKE_BUILD_TYPE=Release", f"-DCMAKE_C_COMPILER={cc}",
                 "-DCMAKE_C_FLAGS=-Wno-error=stringop-truncation"], "cmake (configure the Reference-FMUs)", cwd=work)
            run([cmake, "--build", ".", "-j", "2"], "cmake --build (the Reference-FMUs)", cwd=work)
            built = sorted((Path(work) / "fmus").glob("*.fmu"))
            missing = [m for m in MODELS + (("StateSpace",) if version == 3 else ()) if m not in {f.stem for f in built}]
            if missing:
                raise BuildError(f"the Reference-FMUs build made no {', '.join(missing)}")
            for f in built:
                shutil.copy2(f, out / f.name)

    folder = cached(f"reference-fmus{version}", [SOURCES, version_line(cmake), version_line(cc)], make)
    return {p.stem: p for p in folder.glob("*.fmu")}


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
