"""The plain pythonfmu FMU the tests use as content nobody here wrote: tests/foreign/plain_lag.py built with the
``pythonfmu build`` command exactly as a new user would (no ModelStructure post-processing).  A helper module, not
a test file: it holds no test."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

SOURCE = Path(__file__).resolve().parent / "foreign" / "plain_lag.py"


def build_plain_lag(out: Path) -> Path:
    """PlainLag.fmu built into ``out``; skips, saying why, without the pythonfmu command or when the build fails."""
    exe = Path(sys.executable).with_name("pythonfmu")
    if not exe.is_file():
        pytest.skip("pythonfmu command not installed")
    r = subprocess.run([str(exe), "build", "-f", str(SOURCE), "-d", str(out)], capture_output=True, text=True)
    fmu = Path(out) / "PlainLag.fmu"
    if r.returncode != 0 or not fmu.is_file():
        pytest.skip(f"pythonfmu build failed: {r.stderr.strip()[-300:]}")
    return fmu
