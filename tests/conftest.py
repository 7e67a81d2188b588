"""Shared fixtures: the toolkit's FMUs, built once and shared by every worker and session (tests/build_cache.py)."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def fmu_dir() -> Path:
    """Every FMU of the toolkit as FMI 2.0, built by build_fmus.py (with its fmpy validation). Read only:
    shared by every test (copy an FMU to change it)."""
    from build_cache import toolkit_fmus

    return toolkit_fmus(2)


@pytest.fixture(scope="session")
def fmu3_dir() -> Path:
    """Every FMU of the toolkit as FMI 3.0 co-simulation FMUs (build_fmus.py --fmi-version 3). Read only."""
    from build_cache import toolkit_fmus

    return toolkit_fmus(3)


@pytest.fixture(scope="session")
def me_dir() -> Path:
    """Every FMU of the toolkit as FMI 3.0 model exchange FMUs (--fmi-version 3 --model-exchange). Read only."""
    from build_cache import toolkit_fmus

    return toolkit_fmus(3, model_exchange=True)


@pytest.fixture(scope="session")
def drive_fmus(fmu_dir, tmp_path_factory):
    """``get(name, fmi_version=2)``: the drive ``name`` exported as one FMU (made on first need, once a session)."""
    from harness import load
    from harness.export.drive_fmu import export_fmu

    out = tmp_path_factory.mktemp("drive_fmus")
    cache = {}

    def get(name, fmi_version=2):
        if (name, fmi_version) not in cache:
            cache[name, fmi_version] = export_fmu(load(name).on_fmus(fmu_dir), out / f"{name}_fmi{fmi_version}.fmu",
                                                  fmi_version=fmi_version)
        return cache[name, fmi_version]
    return get


@pytest.fixture(scope="session")
def c_hosts(tmp_path_factory) -> dict:
    """tests/c_hosts/fmi2_host.c and tests/c_hosts/fmi3_host.c compiled: C programs that run an FMU, no Python in
    them (FMI version -> program)."""
    import subprocess

    from build_cache import compiler

    cc = compiler()
    out = tmp_path_factory.mktemp("c_hosts")
    hosts = {}
    for version in (2, 3):
        hosts[version] = out / f"fmi{version}_host"
        r = subprocess.run([cc, "-O2", "-o", str(hosts[version]), str(ROOT / "tests" / "c_hosts" /
                                                                      f"fmi{version}_host.c"), "-ldl"],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
    return hosts


# -- process exit ---------------------------------------------------------------------------------------------
# pythonfmu 0.7's C wrapper runs the FMUs' Python inside THIS interpreter and keeps references into it.  Tearing
# the interpreter down with such instances alive has, rarely (1 run in ~25 of tests/test_systems.py on a loaded
# machine), aborted AFTER the last test with "corrupted double-linked list" (glibc), turning a green run red.
# Every result is reported by then, so the session leaves with os._exit and its real status, skipping the
# finalisation (harness/__main__.py does the same for the CLI).
_EXIT_STATUS: list[int] = []


def pytest_sessionfinish(session, exitstatus):
    _EXIT_STATUS.append(int(exitstatus))


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    if _EXIT_STATUS and "PRESSDRIVE_NORMAL_EXIT" not in __import__("os").environ:
        import os

        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(_EXIT_STATUS[-1])
