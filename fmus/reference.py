"""The standard run of a component's pure model that each ``fmus/docs/<name>/make_reference.py`` records as
``reference.csv`` (packed into the FMU with its readme).  One loop for all components:

    t_k = k h (k = 0 ... n);  u_k = inputs(k, t_k);  x_0 = initial_state(u_0) (or ``x0``);
    row k = (t_k, output(t_k, x_k, u_k));  x_{k+1} = advance(t_k, h, x_k, u_k)

so the inputs are held over each step, as a co-simulation master with zero-order hold hands them over.
``inputs`` is called once per k, in order, so it may carry its own state (an angle integrated from a speed).
Run a script as ``python -m fmus.docs.<name>.make_reference`` (or by its path, with the package installed).

Every component's reference at once, against the model as it is now (``python -m fmus.reference``): each
script's run is taken in memory and compared with the committed file; any difference beyond the last digit
the file writes is reported, and the exit status is 1.  ``--write`` rewrites the files that differ (a physics
change is committed with its new references deliberately, never silently).
"""
from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import re
import sys
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

DOCS = Path(__file__).resolve().parent / "docs"
# the runs a script writes while :func:`captured` is active: (path, text, format), none written to disk
_CAPTURED: list | None = None


def standard_run(model, inputs: Callable[[int, float], Sequence[float]], h: float, n: int,
                 x0=None) -> list[tuple]:
    """Rows ``(t, *outputs)`` of the loop above."""
    rows, x = [], x0
    for k in range(n + 1):
        t = k * h
        u = inputs(k, t)
        if x is None:
            x = model.initial_state(u)
        rows.append((t, *model.output(t, x, u)))
        if k < n:
            x = model.advance(t, h, x, u)
    return rows


def render(model, rows, fmt: str = "%.15g") -> str:
    """The text of a reference.csv: header ``time`` and the model's outputs, one row per line in ``fmt``."""
    buf = io.StringIO()
    np.savetxt(buf, np.array(rows, dtype=float), delimiter=",", fmt=fmt,
               header=",".join(("time", *model.outputs)), comments="")
    return buf.getvalue()


def write_reference(script: str | Path, model, rows, fmt: str = "%.15g") -> Path:
    """Write ``rows`` as ``reference.csv`` beside ``script`` (:func:`render`); inside :func:`captured` the text
    is kept instead."""
    path = Path(script).resolve().with_name("reference.csv")
    text = render(model, rows, fmt)
    if _CAPTURED is not None:
        _CAPTURED.append((path, text, fmt))
    else:
        path.write_text(text, encoding="utf-8")
    return path


def components() -> list[str]:
    """The components with a standard run: the folders ``fmus/docs/<name>`` holding a make_reference.py."""
    return sorted(p.parent.name for p in DOCS.glob("*/make_reference.py"))


@contextlib.contextmanager
def captured():
    """What :func:`write_reference` is given meanwhile, as a list of (path, text, format), nothing written."""
    global _CAPTURED
    previous, _CAPTURED = _CAPTURED, []
    try:
        yield _CAPTURED
    finally:
        _CAPTURED = previous


def fresh(name: str) -> tuple[Path, str, str]:
    """(path, text, format) of component ``name``'s reference.csv as its script writes it now."""
    script = importlib.import_module(f"fmus.docs.{name}.make_reference")
    with captured() as out:
        script.main()
    if len(out) != 1:
        raise RuntimeError(f"fmus/docs/{name}/make_reference.py wrote {len(out)} references, not one")
    return out[0]


def digits(fmt: str) -> int:
    """Significant digits of a ``%.<n>g`` format."""
    m = re.fullmatch(r"%\.(\d+)g", fmt)
    if m is None:
        raise ValueError(f"reference format {fmt!r} is not %.<digits>g")
    return int(m.group(1))


def difference(committed: str, now: str, fmt: str) -> str | None:
    """None if ``now`` is ``committed`` (the text, or every number to one unit in the last digit ``fmt`` writes,
    which a last-bit difference of a libm on another machine may flip), else the first difference in words."""
    if committed == now:
        return None
    head_c, _, body_c = committed.partition("\n")
    head_n, _, body_n = now.partition("\n")
    if head_c != head_n:
        return f"columns differ: committed {head_c!r}, now {head_n!r}"
    a = np.loadtxt(io.StringIO(body_c), delimiter=",", ndmin=2)
    b = np.loadtxt(io.StringIO(body_n), delimiter=",", ndmin=2)
    if a.shape != b.shape:
        return f"{a.shape[0]} rows committed, {b.shape[0]} now"
    allowed = 10.0 ** (1 - digits(fmt)) * np.maximum(np.abs(a), np.abs(b))
    off = np.abs(a - b) > allowed
    if not off.any():
        return None
    row, col = np.argwhere(off)[0]
    return (f"{head_c.split(',')[col]} at t = {a[row, 0]:g}: committed {float(a[row, col])!r}, now {float(b[row, col])!r} "
            f"({int(off.sum())} values differ beyond the last digit)")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m fmus.reference",
                                 description="Compare every fmus/docs/<name>/reference.csv with its script's "
                                             "standard run of the model as it is now; --write rewrites those "
                                             "that differ.")
    ap.add_argument("names", nargs="*", help=f"components (default all: {', '.join(components())})")
    ap.add_argument("--write", action="store_true", help="rewrite each reference.csv that differs")
    args = ap.parse_args(argv)
    unknown = sorted(set(args.names) - set(components()))
    if unknown:
        print(f"fmus.reference: unknown component(s) {', '.join(unknown)} (allowed: {', '.join(components())})",
              file=sys.stderr)
        return 2
    differing = 0
    for name in args.names or components():
        path, text, fmt = fresh(name)
        why = difference(path.read_text(encoding="utf-8"), text, fmt) if path.is_file() else "no reference.csv"
        if why is None:
            print(f"{name}: unchanged")
            continue
        differing += 1
        if args.write:
            path.write_text(text, encoding="utf-8")
            print(f"{name}: WRITTEN ({why})")
        else:
            print(f"{name}: DIFFERS: {why}")
    if differing and not args.write:
        print(f"fmus.reference: {differing} reference(s) differ from the model's standard run; if the change is "
              f"meant, rewrite them with: python -m fmus.reference --write", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    # run as a script this module is __main__; the make_reference scripts write through the imported fmus.reference
    from fmus.reference import main as _main

    sys.exit(_main())
