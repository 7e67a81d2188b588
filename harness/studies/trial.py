"""One co-simulation run of a study, the same way for every study: warnings silenced (a study records what
went wrong in its table instead of warning per run), wall time measured around the run, and an exception or
an incomplete run turned into a one-line ``error`` instead of aborting the study."""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, replace

import pandas as pd


@dataclass
class Trial:
    """``result``: the run's DataFrame (None if it raised); ``wall_time`` [s] around the run; ``complete``:
    it reached its stop time; ``error``: one line ("" when complete)."""
    result: pd.DataFrame | None
    wall_time: float
    complete: bool
    error: str


def one_line(e: BaseException) -> str:
    """``"ExceptionType: first line of the message"``."""
    return f"{type(e).__name__}: {e}".splitlines()[0]


def quiet_simulate(*args, ignore: type[Warning] = Warning, **kwargs) -> pd.DataFrame:
    """:func:`harness.simulate` with warnings of category ``ignore`` silenced."""
    from harness import simulate

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ignore)
        return simulate(*args, **kwargs)


def study_options(n_steps: int):
    """:class:`harness.RunOptions` for a study's run of ``n_steps`` steps: a stability study's run spans many
    periods in few large steps, so its divergence detector gets blocks of fewer steps (at least one) to still
    have 2 x ``min_blocks`` of them.  (Not the default of :func:`harness.simulate`: a short run of a drive
    starting from rest, a few dozen steps of its own default step, grows by x10 in its first milliseconds.)"""
    from harness import RunOptions
    from harness.divergence import DivergenceOptions

    d = DivergenceOptions()
    if n_steps >= 2 * d.min_blocks * d.block:
        return RunOptions()
    return RunOptions(divergence=replace(d, block=max(1, n_steps // (2 * d.min_blocks))))


def trial(system, ignore: type[Warning] = Warning, **options) -> Trial:
    """Run ``simulate(system, **options)`` quietly; never raises (an exception is the trial's ``error``)."""
    t0 = time.perf_counter()
    try:
        df = quiet_simulate(system, ignore=ignore, **options)
    except Exception as e:
        return Trial(None, time.perf_counter() - t0, False, one_line(e))
    wall = time.perf_counter() - t0
    if df.attrs.get("complete") is False:
        message = str(df.attrs.get("error") or "incomplete run").splitlines() or ["incomplete run"]
        return Trial(df, wall, False, message[0])
    return Trial(df, wall, True, "")
