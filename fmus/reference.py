"""The standard run of a component's pure model that each ``fmus/docs/<name>/make_reference.py`` records as
``reference.csv`` (packed into the FMU with its readme).  One loop for all components:

    t_k = k h (k = 0 ... n);  u_k = inputs(k, t_k);  x_0 = initial_state(u_0) (or ``x0``);
    row k = (t_k, output(t_k, x_k, u_k));  x_{k+1} = advance(t_k, h, x_k, u_k)

so the inputs are held over each step, as a co-simulation master with zero-order hold hands them over.
``inputs`` is called once per k, in order, so it may carry its own state (an angle integrated from a speed).
Run a script as ``python -m fmus.docs.<name>.make_reference`` (or by its path, with the package installed).
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable, Sequence

import numpy as np


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


def write_reference(script: str | Path, model, rows, fmt: str = "%.15g") -> Path:
    """Write ``rows`` as ``reference.csv`` beside ``script`` (header ``time`` and the model's outputs)."""
    path = Path(script).resolve().with_name("reference.csv")
    np.savetxt(path, np.array(rows, dtype=float), delimiter=",", fmt=fmt,
               header=",".join(("time", *model.outputs)), comments="")
    return path
