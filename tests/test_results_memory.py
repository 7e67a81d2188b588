"""Memory of a run: the result buffers are sized up front and handed over to the DataFrame without a copy, so a
long run holds nothing per step but its result (a 1e6-step run must not grow beyond the result size: checked at
2.5e5 steps in the slow suite, 5e4 in the default one).

Measured with tracemalloc around ``simulate`` (after a warm-up run, so imports and extraction are not
counted): the peak of a run, less the size of its own result, must not grow with the number of steps.
"""
from __future__ import annotations

import tracemalloc
import warnings

import pytest

from benchmarks.cases import ring
from harness import simulate

STEP = 1e-5  # the 2-ring of integrals grows as cosh(t): 1e6 steps stay far below the blow-up limit


@pytest.fixture(autouse=True)
def _built(fmu_dir, monkeypatch):
    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))
    warnings.simplefilter("ignore")


def _overhead(steps: int) -> tuple[int, int]:
    """(peak traced bytes during the run minus the result's bytes, the result's bytes)."""
    system = ring(2)
    tracemalloc.start()
    try:
        df = simulate(system, stop_time=steps * STEP, step=STEP, outputs=["g0.integral", "g1.integral"])
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert df.attrs["complete"] and len(df) == steps + 1
    result = df.values.nbytes + df.index.values.nbytes
    return peak - result, result


def _check(steps: int) -> None:
    simulate(ring(2), stop_time=10 * STEP, step=STEP)  # warm-up: imports, FMU extraction, first instances
    small, _ = _overhead(steps // 10)
    large, result = _overhead(steps)
    # nothing per step beyond the result: ten times the steps, the same overhead (within 64 kB of noise)
    assert large - small < 65_536, (small, large, result)
    assert large < 0.25 * result, (large, result)


def test_a_run_holds_nothing_per_step_but_its_result():
    _check(50_000)


@pytest.mark.slow
def test_a_long_run_holds_nothing_per_step_but_its_result():
    """250 000 steps against 25 000: anything a run kept per step, down to 0.3 byte a step (one 32-byte object
    every 100 steps), would add more than the 64 kB allowed; the buffers are sized up front, so what holds for
    2.5e5 steps holds for the 1e6 of the requirement.  (1e6 steps cost four times as much to see leaks down to
    0.07 byte a step.)"""
    _check(250_000)
