"""A master's own state as data, for a checkpoint of a whole run (:mod:`harness.run.checkpoint`).

What a master carries from one communication step to the next besides its FMUs' states: the signal vector
``y``, the held inputs ``u``, the extrapolation history (times, values, counts and whether every signal's newest
sample shares one time), the power bonds' bookkeeping (powers over the last step, energy error), its time and
counters, where each instance's own step ends (:mod:`harness.master.multirate`), and a method's own data named
in its ``checkpointed`` class attribute (the interface Jacobian of ``jacobian``).  Restored into a master built
for the same system and initialized, the run continues bit for bit as if it had not stopped."""
from __future__ import annotations

import copy

import numpy as np


def master_state(m) -> dict:
    """``m``'s state (module docstring): arrays copied, so the master may go on."""
    h = m.history
    return {"y": m.y.copy(), "u": m.u.copy(), "bond_log": m.bond_log.copy(),
            "history": {"t": h.t.copy(), "y": h.y.copy(), "n": h.n.copy(), "newest": h._newest, "full": h._full},
            "t_ns": int(m.t_ns), "steps": m.steps, "fmu_steps": m.fmu_steps, "iterations": m.iterations,
            "halvings": m.halvings, "rates": None if m.rates is None else m.rates.state(),
            "method": {name: copy.deepcopy(getattr(m, name)) for name in type(m).checkpointed}}


def restore_master_state(m, state: dict) -> None:
    """Put ``state`` (:func:`master_state` of a master of the same system, method and rates) into ``m``."""
    for name in ("y", "u", "bond_log"):
        getattr(m, name)[:] = state[name]
    h = state["history"]
    m.history.t[:], m.history.y[:], m.history.n[:] = h["t"], h["y"], np.asarray(h["n"])
    m.history._newest, m.history._full = h["newest"], h["full"]
    m.t_ns = int(state["t_ns"])
    m.steps, m.fmu_steps = state["steps"], state["fmu_steps"]
    m.iterations, m.halvings = state["iterations"], state["halvings"]
    if state["rates"] is not None:
        m.rates.set_state(state["rates"])
    for name, value in state["method"].items():
        setattr(m, name, copy.deepcopy(value))
    m._y_list = None


__all__ = ["master_state", "restore_master_state"]
