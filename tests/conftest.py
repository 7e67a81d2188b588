"""Shared fixtures: the FMUs are built once per test session into a temporary folder."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory) -> Path:
    """Every FMU of the toolkit, built by build_fmus.py (with its fmpy validation)."""
    sys.path.insert(0, str(ROOT))
    import build_fmus

    out = tmp_path_factory.mktemp("fmus")
    assert build_fmus.main(["--out", str(out)]) == 0, "build_fmus.py failed (see stderr)"
    return out
