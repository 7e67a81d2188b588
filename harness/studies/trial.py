"""One co-simulation run of a study, the same way for every study: warnings silenced (a study records what
went wrong in its table instead of warning per run), wall time measured around the run, and an exception or
an incomplete run turned into a one-line ``error`` instead of aborting the study.  And the one way a study
stopped by Ctrl-C or SIGTERM keeps its finished rows (:class:`StudyInterrupted`, :func:`keep_interrupted`)."""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

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
    from harness.master.divergence import DivergenceOptions

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


# -- a study stopped by Ctrl-C or SIGTERM ------------------------------------------------------------------------
class StudyInterrupted(KeyboardInterrupt):
    """Ctrl-C (SIGINT) or SIGTERM during a study: ``table`` holds the rows the study had finished (a DataFrame,
    possibly empty), ``status`` the exit status a shell expects (130 after Ctrl-C, 143 after SIGTERM) and ``how``
    says which.  A KeyboardInterrupt still, so a caller that does not look for it is interrupted as by any other."""

    def __init__(self, table: pd.DataFrame, cause: BaseException):
        from harness.run import interruption

        self.status, self.how = interruption(cause)
        super().__init__(f"{self.how}: {len(table)} rows finished")
        self.table = table


def partial_csv(path: Path) -> Path:
    """Where a study that did not finish writes its table instead of ``path``: ``x.csv`` -> ``x.partial.csv``
    (as ``run`` does), so an incomplete table never takes the name of a complete one."""
    path = Path(path)
    return path.with_name(f"{path.stem}.partial.csv")


def keep_interrupted(e: StudyInterrupted, csv_path: Path, what: str) -> int:
    """The command line's answer to :class:`StudyInterrupted`: the finished rows written to
    :func:`partial_csv` of ``csv_path``, one line on stderr saying so, and the exit status to return."""
    import sys

    out = partial_csv(csv_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    e.table.to_csv(out, index=False)
    print(f"error: {e.how}: {what}; the {len(e.table)} rows finished are kept in {out} (incomplete: no chart)",
          file=sys.stderr)
    return e.status


def write_complete(table: pd.DataFrame, csv_path: Path) -> Path:
    """A finished study's table at ``csv_path``; a partial table left there by an interrupted run is removed."""
    csv_path = Path(csv_path)
    csv_path.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(csv_path, index=False)
    partial_csv(csv_path).unlink(missing_ok=True)
    return csv_path
