"""The plain pythonfmu FMUs the tests use as content nobody here wrote: the scripts of tests/foreign built with the
``pythonfmu build`` command exactly as a new user would (no ModelStructure post-processing), once for every worker
and session (tests/build_cache.py).  pythonfmu is a dependency of the project: a missing command or a failed build
fails the tests that need it.  A helper module, not a test file: it holds no test."""
from __future__ import annotations

import sys
from importlib import metadata
from pathlib import Path

import pytest

from build_cache import cached, run

FOREIGN = Path(__file__).resolve().parent / "foreign"


def build_plain(script: Path, model: str, out: Path) -> Path:
    """``pythonfmu build -f script -d out``: ``out/<model>.fmu`` (uncached: for a script a test writes)."""
    exe = Path(sys.executable).with_name("pythonfmu")
    if not exe.is_file():
        pytest.fail(f"the pythonfmu command is not installed beside {sys.executable} (pythonfmu is a dependency)",
                    pytrace=False)
    run([exe, "build", "-f", script, "-d", out], f"pythonfmu build of {script.name}")
    fmu = Path(out) / f"{model}.fmu"
    if not fmu.is_file():
        pytest.fail(f"pythonfmu build of {script.name} made no {fmu.name}", pytrace=False)
    return fmu


def plain_fmu(script: str, model: str) -> Path:
    """tests/foreign/<script> built as ``<model>.fmu`` (shared, read only: copy it to change it)."""
    folder = cached(f"plain-{model}", [FOREIGN / script, f"pythonfmu {metadata.version('pythonfmu')}"],
                    lambda out: build_plain(FOREIGN / script, model, out))
    return folder / f"{model}.fmu"


def plain_lag() -> Path:
    """PlainLag.fmu (tests/foreign/plain_lag.py)."""
    return plain_fmu("plain_lag.py", "PlainLag")
