"""Monolithic references computed once and shared by the tests that need the same one (pytest-xdist workers and
the slow suite after the default one included): a drive's accuracy reference is asked for by
tests/test_host_accuracy.py, test_drive_fmu.py, test_study_cli.py and a docs page's ``study accuracy``; a
scenario's by tests/test_scenario_accuracy.py and the transients page's commands.

Opt-in, never global: :func:`shared` is :func:`harness.studies.reference.reference` or ``scenario_reference``
with the cache; :func:`sharing` installs both for a test's duration (``monkeypatch``), where studies call them.
Tests of the reference itself never use it.  Each result is stored in ``build/test-cache/references/`` under a
digest of the call (its arguments' repr, object addresses left out: a system's or scenario's repr is its whole
description; a call with input signals is not cached), every source it runs (harness/, fmus/, systems/) and the
versions of Python, numpy, scipy and pandas: a cached reference is never stale.  A helper module, not a test file.
"""
from __future__ import annotations

import fcntl
import functools
import hashlib
import os
import pickle
import re
import sys
from importlib import metadata

from build_cache import CACHE, ROOT, _digest

FOLDER = CACHE / "references"
ADDRESS = re.compile(r" at 0x[0-9a-fA-F]+")


@functools.lru_cache(maxsize=1)
def _sources() -> str:
    versions = [f"{p} {metadata.version(p)}" for p in ("numpy", "scipy", "pandas")]
    return _digest([ROOT / "harness", ROOT / "fmus", ROOT / "systems", sys.version, *versions])


def shared(name: str):
    """``harness.studies.reference.<name>`` (``reference`` or ``scenario_reference``), each distinct call computed
    once (module docstring)."""
    from harness.studies import reference as module

    compute = getattr(module, name)
    compute = getattr(compute, "__wrapped__", compute)

    @functools.wraps(compute)
    def cached(*args, **kwargs):
        if kwargs.get("inputs") is not None:
            return compute(*args, **kwargs)
        call = ADDRESS.sub("", repr((name, args, sorted(kwargs.items()))))
        key = hashlib.sha1(f"{_sources()}\n{call}".encode()).hexdigest()[:20]
        path = FOLDER / f"{key}.pkl"
        FOLDER.mkdir(parents=True, exist_ok=True)
        with open(FOLDER / f"{key}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)        # a second worker asking for it waits, then reads it
            if not path.is_file():
                result = compute(*args, **kwargs)
                tmp = path.with_suffix(f".{os.getpid()}.part")
                tmp.write_bytes(pickle.dumps(result))
                os.replace(tmp, path)
                return result
        return pickle.loads(path.read_bytes())

    return cached


def sharing(monkeypatch) -> None:
    """Both reference functions cached for the rest of the test (the studies import them at call time)."""
    from harness.studies import reference as module

    for name in ("reference", "scenario_reference"):
        monkeypatch.setattr(module, name, shared(name))
