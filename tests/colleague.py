"""Another machine, for tests/test_handoff.py: a colleague's, which has never seen the toolkit.

A private mount namespace (``unshare -m``; root only, as CI runs) in which the toolkit's checkout, the
builder's virtualenv, the temporary folder and ``~/.cache`` are empty folders; with ``python="system"`` pyenv's
Pythons and the builder's are gone too (what is left is the system's Python, if the machine has one, without the
builder's packages), and with ``python="none"`` every Python installation is gone: also the system's
``/usr/lib/python3*`` and ``/usr/local/lib/python3*``, and every ``libpython3*`` and ``python3*`` file in the
library and program folders (overlays whose lower copies stay untouched).  Only the work folder (``/mnt/work``) and, for FMPy runs, the colleague's own virtualenv
(``/mnt/venv``) are visible; the process starts with an environment of PATH, HOME and LANG only.

The colleague's FMPy: a virtualenv of another Python with nothing but ``fmpy`` (at the builder's version, and
so numpy), made once and kept under ``build/colleague`` keyed by Python version and that pin (:func:`venv`).

A helper module, not a test file: it holds no test.
"""
from __future__ import annotations

import glob
import importlib.metadata
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PYENV = Path.home() / ".pyenv" / "versions"
OTHER_PYTHONS = ("3.10", "3.12", "3.13")
# where a Linux machine keeps Python's shared library and programs
LIBRARY_FOLDERS = ("/usr/lib/x86_64-linux-gnu", "/usr/lib", "/usr/local/lib", "/lib/x86_64-linux-gnu")
PROGRAM_FOLDERS = ("/usr/bin", "/usr/local/bin")


def unavailable() -> str | None:
    """Why no private mount namespace can stand in for another machine here, or None."""
    if os.geteuid() != 0:
        return "hiding the toolkit needs a private mount namespace (unshare -m), which needs root (CI runs as root)"
    if shutil.which("unshare") is None:
        return "unshare (util-linux) is not installed"
    r = subprocess.run(["unshare", "-m", "sh", "-c", "mount -t tmpfs tmpfs /mnt"], capture_output=True, text=True)
    if r.returncode != 0:
        return f"unshare -m cannot mount here: {r.stderr.strip()[-200:]}"
    return None


def hidden() -> list[str]:
    """The folders the colleague's machine does not have: the toolkit, the builder's environment, the temporary
    folder and the user's caches."""
    out = {str(ROOT), tempfile.gettempdir(), str(Path.home() / ".cache")}
    if sys.prefix != sys.base_prefix:
        out.add(sys.prefix)
    out.update(p for p in sys.path if p and "site-packages" in p and not p.startswith(sys.base_prefix))
    return sorted(p for p in out if Path(p).is_dir())


def pythons_gone(python: str) -> tuple[list[str], list[tuple[str, str]]]:
    """(folders to empty, (folder, file pattern) to remove under an overlay) for ``python`` = "yes" (nothing
    more), "system" (pyenv's and the builder's Pythons) or "none" (every Python)."""
    if python not in ("yes", "system", "none"):
        raise ValueError(f"python = {python!r}: 'yes', 'system' or 'none'")
    folders, removals = [], set()
    if python != "yes":
        folders += [str(PYENV.parent), sys.base_prefix]
    if python == "none":
        folders += [*glob.glob("/usr/lib/python3*"), *glob.glob("/usr/local/lib/python3*")]
        removals = {(os.path.realpath(d), pattern) for group, pattern in ((LIBRARY_FOLDERS, "libpython3*"),
                                                                         (PROGRAM_FOLDERS, "python3*"))
                    for d in group if glob.glob(f"{d}/{pattern}")}
    return [f for f in folders if Path(f).is_dir() and not Path(f).is_symlink()], sorted(removals)


def system_python() -> tuple[str, bool] | None:
    """The system's own Python that a host without Python finds on the library path when pyenv's and the builder's
    are gone (``python="system"``): (its libpython, whether it has numpy), or None."""
    for minor in range(20, 9, -1):
        libs = [p for d in LIBRARY_FOLDERS for p in glob.glob(f"{d}/libpython3.{minor}.so.1.0")]
        if libs:
            numpy = [p for d in ("/usr/lib/python3/dist-packages", f"/usr/lib/python3.{minor}/site-packages",
                                 f"/usr/local/lib/python3.{minor}/dist-packages") for p in glob.glob(f"{d}/numpy")]
            return libs[0], bool(numpy)
    return None


def _outermost(folders: list[str]) -> list[str]:
    """The folders without those inside another of them (emptying the outer one hides them already)."""
    real = sorted({os.path.realpath(f) for f in folders}, key=len)
    out: list[str] = []
    for f in real:
        if not any(f == o or f.startswith(o + "/") for o in out):
            out.append(f)
    return out


def script(workdir: Path, venv_dir: Path | None, python: str) -> str:
    """The shell script that makes the namespace the colleague's machine, then runs its arguments in /mnt/work."""
    lines = ["set -e", "mount -t tmpfs tmpfs /mnt", "mkdir -p /mnt/work /mnt/venv /mnt/ov",
             f"mount --bind {shlex.quote(str(workdir))} /mnt/work"]
    if venv_dir is not None:
        lines.append(f"mount --bind {shlex.quote(str(venv_dir))} /mnt/venv")
    folders, removals = pythons_gone(python)
    empty = hidden() + folders
    lines += [f"mount -t tmpfs tmpfs {shlex.quote(d)}" for d in _outermost(empty)]
    for k, (folder, pattern) in enumerate(removals):
        up, work = f"/mnt/ov/{k}/u", f"/mnt/ov/{k}/w"
        lines += [f"mkdir -p {up} {work}",
                  f"mount -t overlay overlay -o lowerdir={folder},upperdir={up},workdir={work} {folder}",
                  f"rm -f {folder}/{pattern}"]
    lines += ["cd /mnt/work", 'exec env -i PATH=/usr/bin:/bin HOME="$HOME" LANG=C.UTF-8 "$@"']
    return "\n".join(lines)


def run(argv: list[str], workdir: Path, *, venv_dir: Path | None = None, python: str = "yes",
        env: dict | None = None, timeout: float = 600) -> subprocess.CompletedProcess:
    """``argv`` (paths inside: /mnt/work, /mnt/venv) run on the colleague's machine, with ``python`` as
    :func:`pythons_gone` takes it; ``env``: variables to set there (the environment is otherwise PATH, HOME and
    LANG only)."""
    extra = [f"{k}={v}" for k, v in (env or {}).items()]
    cmd = ["unshare", "-m", "--propagation", "private", "sh", "-c", script(workdir, venv_dir, python), "colleague",
           *(["env", *extra] if extra else []), *argv]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


def fmpy_pin() -> str:
    """The builder's FMPy version: the colleague installs the same."""
    return importlib.metadata.version("fmpy")


def venv(version: str, package: str | None = None) -> Path | str:
    """The colleague's FMPy under Python ``version`` (a virtualenv with nothing but fmpy at the builder's version,
    or with nothing but ``package``, e.g. ``fmpy==0.3.20``), made once under build/colleague; or why there is none
    (no such pyenv Python, pip failed)."""
    pythons = sorted(PYENV.glob(f"{version}.*/bin/python{version}"))
    if not pythons:
        return f"no Python {version} under {PYENV} (pyenv install {version})"
    package = package or f"fmpy=={fmpy_pin()}"
    where = ROOT / "build" / "colleague" / f"py{version}-{package.replace('==', '')}"
    if (where / ".complete").is_file():
        return where
    where.parent.mkdir(parents=True, exist_ok=True)
    # the virtualenv without its own pip (ensurepip costs 7 s), filled by this pip (pip >= 22.3: --python); where this
    # pip no longer supports that Python (pip 25 needs 3.10: the too-old-Python case), the virtualenv's own pip
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "VIRTUAL_ENV"))}
    python, install = str(where / "bin" / "python"), ["install", "-q", "--no-compile", package]
    attempts = (([str(pythons[-1]), "-m", "venv", "--without-pip", str(where)],
                 [sys.executable, "-m", "pip", "--python", python, *install]),
                ([str(pythons[-1]), "-m", "venv", str(where)], [python, "-m", "pip", *install]))
    for attempt in attempts:
        shutil.rmtree(where, ignore_errors=True)
        for cmd in attempt:
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=900, env=env)
            if r.returncode != 0:
                break
        else:
            (where / ".complete").write_text(f"Python {version}, {package}\n")
            return where
    shutil.rmtree(where, ignore_errors=True)
    return f"making the colleague's virtualenv failed ({' '.join(cmd[:3])}): {r.stderr.strip()[-300:]}"
