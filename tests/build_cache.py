"""The builds the tests need, made once and shared by every pytest-xdist worker and every later session.

Each build lives in ``build/test-cache/<kind>-<key>/``, ``<key>`` a digest of everything the build reads: its
source files (every byte, by relative path), the tools and their versions, this Python.  A change of any of them
is another key, so a cached build is never stale; a key's first user builds it under a file lock (the other
workers wait for it, then use it) into a private folder that is moved into place whole, and the builds of other
keys of the same kind that nobody used for a day are removed then (not sooner: another virtualenv, such as
.ci/run's lowest-FMPy one, or a session started before a source changed may still use theirs).  A build that
fails FAILS the tests that need it, naming the command and its last error lines: these are the project's own
fixtures, and a broken one must not pass as skipped.

A helper module, not a test file: it holds no test.
"""
from __future__ import annotations

import fcntl
import hashlib
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable, Iterable

import pytest

ROOT = Path(__file__).resolve().parents[1]
CACHE = ROOT / "build" / "test-cache"
DONE = ".complete"
PRUNE_AFTER_S = 86400.0   # a build of another key is removed once unused for a day (never while a session uses it)


class BuildError(RuntimeError):
    """A fixture the project owns could not be built (the message says which command and why)."""


def tool(name: str, why: str) -> str:
    """The path of the command ``name``; a missing one FAILS the test, saying what it is needed for."""
    path = shutil.which(name)
    if path is None:
        pytest.fail(f"{name} is not installed: it is needed to {why}", pytrace=False)
    return path


def compiler() -> str:
    """The C compiler (``$CC``, else cc or gcc): fmus/build.py needs one too (the host loader)."""
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.fail("no C compiler (cc/gcc; or set CC): the project's FMUs and test fixtures are compiled",
                    pytrace=False)
    return cc


def run(cmd: list, what: str, **kw) -> subprocess.CompletedProcess:
    """Run a build command; a non-zero exit raises :class:`BuildError` with its last error lines."""
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kw)
    if r.returncode != 0:
        tail = (r.stderr.strip() or r.stdout.strip())[-600:]
        raise BuildError(f"{what} failed (exit {r.returncode}: {' '.join(map(str, cmd[:3]))} ...): {tail}")
    return r


def version_line(cmd: str) -> str:
    """The first line of ``cmd --version`` (part of a key: another compiler is another build)."""
    try:
        r = subprocess.run([cmd, "--version"], capture_output=True, text=True)
    except OSError:
        return f"{cmd}: absent"
    return (r.stdout.strip().splitlines() or [f"{cmd}: exit {r.returncode}"])[0]


def _digest(parts: Iterable) -> str:
    h = hashlib.sha1()
    for part in parts:
        if isinstance(part, Path):
            files = sorted(f for f in part.rglob("*") if f.is_file() and "__pycache__" not in f.parts
                           and f.suffix != ".pyc") if part.is_dir() else [part]
            for f in files:
                h.update(str(f.relative_to(ROOT) if f.is_relative_to(ROOT) else f).encode() + b"\0")
                h.update(f.read_bytes())
        else:
            h.update(str(part).encode() + b"\0")
    return h.hexdigest()[:16]


def cached(kind: str, inputs: Iterable, build: Callable[[Path], None]) -> Path:
    """The folder of build ``kind`` for these ``inputs`` (paths: files or folders, read byte for byte; anything
    else by its text), made by ``build(folder)`` the first time (module docstring)."""
    inputs = [kind, sys.version, *inputs]
    final = CACHE / f"{kind}-{_digest(inputs)}"
    if (final / DONE).is_file():
        os.utime(final / DONE)                    # in use: not pruned (below) for another day
        return final
    CACHE.mkdir(parents=True, exist_ok=True)
    with open(CACHE / f"{kind}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)          # released when the file closes, also if this process dies
        if (final / DONE).is_file():
            return final
        for old in CACHE.glob(f"{kind}-*"):       # builds of other keys unused for a day (another virtualenv's,
            done = old / DONE                     # such as .ci/run's lowest-FMPy one, or older sources)
            if not done.is_file() or time.time() - done.stat().st_mtime > PRUNE_AFTER_S:
                shutil.rmtree(old, ignore_errors=True)
        work = CACHE / f".{final.name}.{os.getpid()}"
        shutil.rmtree(work, ignore_errors=True)
        work.mkdir()
        try:
            build(work)
        except BuildError as e:
            shutil.rmtree(work, ignore_errors=True)
            pytest.fail(f"building the test fixture {kind!r}: {e}", pytrace=False)
        except BaseException:
            shutil.rmtree(work, ignore_errors=True)
            raise
        (work / DONE).write_text("\n".join(map(str, inputs)) + "\n", encoding="utf-8")
        os.replace(work, final)
    return final


def _package_version(name: str) -> str:
    from importlib import metadata

    return f"{name} {metadata.version(name)}"


def toolkit_fmus(fmi_version: int = 2, model_exchange: bool = False) -> Path:
    """Every FMU of the toolkit as ``build_fmus.py`` builds it (with fmpy's validation) for this FMI version
    (and interface).  Keyed by everything under fmus/ (declarations, runtime, loaders, docs packed into each
    FMU, the build itself), the Python the FMUs record, the exporters, fmpy (the validation) and the compiler."""
    from fmus import build as build_fmus
    from fmus.packaging import python_config

    argv = ["--fmi-version", str(fmi_version)] + (["--model-exchange"] if model_exchange else [])

    def make(out: Path) -> None:
        if build_fmus.main([*argv, "--out", str(out)]) != 0:
            raise BuildError(f"build_fmus.py {' '.join(argv)} (see its FAILED lines on stderr)")

    kind = f"fmi{fmi_version}" + ("me" if model_exchange else "")
    return cached(kind, [ROOT / "fmus", ROOT / "build_fmus.py", python_config(),
                         _package_version("pythonfmu"), _package_version("pythonfmu3"), _package_version("fmpy"),
                         version_line(os.environ.get("CC", "cc"))], make)
