"""Compiled element loops over the C library's math functions for a batch of variants (:mod:`fmus.physics.mathns`).

Python's ``math`` calls the C library's ``exp``, ``tanh``, ``acos``, ``sin``, ``cos``, ``atan2`` and ``pow`` (and
``abs`` of a complex number its ``hypot``, which ``math.hypot`` is not: CPython computes that itself); numpy
computes most of them by its own approximations, which differ in the last bit.  A batch of variants must give each
variant the bits its own FMU gives, so :data:`fmus.physics.mathns.VECTOR` calls the C library's functions element by
element: here in a loop compiled once (``fmus/batch_libm.c``, a CPython extension module, with the machine's C
compiler, ``$CC`` else ``cc``, and the interpreter's headers) into the cache folder (``$PRESSDRIVE_CACHE/libm``,
else ``<temp>/pressdrive_libm``), about ten times faster than Python's ``math`` per element and about a microsecond
a call; ``math.hypot`` (CPython's own algorithm) is called per element from there too.  Without a compiler the
batch keeps the per-element Python loop (the same bits, slower) and :func:`status` says so.
"""
from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import os
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

import numpy as np

from .physics import mathns

SOURCE = Path(__file__).with_name("batch_libm.c")
UNARY = ("exp", "tanh", "acos", "sin", "cos")
BINARY = ("atan2", "pow", "chypot")
_state = {"tried": False, "why": ""}


def cache_dir() -> Path:
    env = os.environ.get("PRESSDRIVE_CACHE")
    return Path(env) / "libm" if env else Path(tempfile.gettempdir()) / "pressdrive_libm"


def _build() -> Path:
    text = SOURCE.read_bytes()
    digest = hashlib.sha256(text + sys.version.encode()).hexdigest()[:16]
    out = cache_dir() / digest / f"pd_libm{sysconfig.get_config_var('EXT_SUFFIX') or '.so'}"
    if out.is_file():
        return out
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".pd_libm.{os.getpid()}.so")
    cc = os.environ.get("CC", "cc")
    include = sysconfig.get_paths()["include"]
    cmd = [cc, "-shared", "-fPIC", "-O2", "-fno-fast-math", f"-I{include}", "-o", str(tmp), str(SOURCE), "-lm"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0 or not tmp.is_file():
        raise OSError(f"{' '.join(cmd)} failed: {' '.join((r.stderr or '').split())[:300]}")
    os.replace(tmp, out)
    return out


def _load(path: Path):
    """The compiled module (a CPython extension named pd_libm) from ``path``."""
    loader = importlib.machinery.ExtensionFileLoader("pd_libm", str(path))
    spec = importlib.util.spec_from_file_location("pd_libm", str(path), loader=loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def _unary(cfun):
    def f(x):
        x = np.ascontiguousarray(x, dtype=float)
        out = np.empty_like(x)
        cfun(x, out)
        return out
    return f


def _operands(a, b):
    """(a, b, the output's shape): floats stay floats (the loop takes one for every element), arrays C-contiguous
    float64; numpy's broadcasting where the shapes differ otherwise."""
    fa, fb = isinstance(a, float), isinstance(b, float)
    if not fa:
        a = np.ascontiguousarray(a, dtype=float)
    if not fb:
        b = np.ascontiguousarray(b, dtype=float)
    if fa and not fb:
        return a, b, b.shape
    if fb and not fa:
        return a, b, a.shape
    if not (fa or fb) and a.shape == b.shape:
        return a, b, a.shape
    a, b = np.broadcast_arrays(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    return np.ascontiguousarray(a), np.ascontiguousarray(b), a.shape


def _binary(cfun):
    def f(a, b):
        a, b, shape = _operands(a, b)
        out = np.empty(shape)
        cfun(a, b, out)
        return out
    return f


def _pyhypot(cfun):
    """``math.hypot`` element by element, the function object called from the compiled loop."""
    import math

    def f(a, b):
        a, b, shape = _operands(a, b)
        out = np.empty(shape)
        cfun(math.hypot, a, b, out)
        return out
    return f


def install() -> str:
    """Give :data:`fmus.physics.mathns.VECTOR` the compiled loops (once per process); returns :func:`status`."""
    if _state["tried"]:
        return status()
    _state["tried"] = True
    try:
        lib = _load(_build())
    except (OSError, ImportError) as e:
        _state["why"] = f"no compiled loops ({' '.join(str(e).split())[:200]}): math per element"
        mathns.VECTOR.trig()
        return status()
    functions = {name: _unary(getattr(lib, name)) for name in UNARY}
    functions.update({name: _binary(getattr(lib, name.removeprefix("c"))) for name in BINARY})
    functions["hypot"] = _pyhypot(lib.pyhypot)
    mathns.install_loops(functions, "compiled")
    mathns.VECTOR.trig()
    return status()


def status() -> str:
    """How :data:`~fmus.physics.mathns.VECTOR` computes the C library's functions: one line."""
    v = mathns.VECTOR
    trig = "numpy's sin and cos" if v.sin is np.sin else "the C library's sin and cos"
    if v.loops == "compiled":
        return f"compiled loops over the C library's functions ({trig}; math.hypot called per element)"
    return _state["why"] or f"Python's math per element ({trig})"
