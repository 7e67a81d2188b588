"""Power-bond energy diagnostics of a co-simulation result (ECCO-style power residual).

Why this is not :func:`harness.results.bond_energy`: that one reads the master's own bond log, which only
this toolkit's masters write.  This module works on ANY result table with the bond's columns -- a CSV, or a
run of libcosim, Ecos or CoFmuPy -- by reconstructing the held inputs with the masters' rule, so it is the
diagnostic for results the master did not make (and the two agree where both apply, see below).

A power bond joins port ``A.port`` (motion OUT: outputs ``phi, w``; input ``tau``) and port ``B.port``
(motion IN: inputs ``phi, w``; output ``tau``); translational ports use ``s, v, f``.  In the monolithic
system the power ``tau * w`` leaving B equals the power entering A at every instant.  In a co-simulation each
side only sees its HELD inputs over a communication step ``[t_k, t_k+1]`` (``H = t_k+1 - t_k``), so the two
sides disagree, and the disagreement is energy created (or destroyed) by the coupling.

What each side sees over step k, and the definitions used here
------------------------------------------------------------------
* A holds the torque ``tau_held`` (constant over the step) and moves.  The energy it receives is EXACTLY
  ``W_out = tau_held * (phi_A(t_k+1) - phi_A(t_k))`` (its angle output is the exact integral of its speed).
  ``P_out = W_out / H`` (mean power into A).  Without an angle column the trapezoidal mean of ``w_A`` is
  used instead of the angle increment.
* B holds the speed ``w_held`` (constant) and its torque output varies over the step.  The power it
  delivers as it sees it is ``w_held * tau_B(t)``; its mean is taken by the trapezoidal rule on the
  consistent outputs at the two communication points: ``P_in = w_held * (tau_B(t_k) + tau_B(t_k+1)) / 2``.
* The residual power ``dP = P_out - P_in``; :func:`coupling_energy` is its running integral
  ``E_k = sum dP * H`` [J] (positive: the coupling has put energy into the system), and
  :func:`ecco_residual` the per-step energy residual ``|dP| * H`` of ECCO (Sadjina et al. 2017), which a step
  controller compares with a tolerance.

``P_in`` is an ESTIMATE: B's torque between communication points, and its jump when new held inputs are
set, are not in the result (they need B's internals, e.g. the spring rate).  So the residual is an error
indicator of the same order as the true energy error, not its exact value.  For the undamped free-free
two-inertia system with zero-order hold, Jacobi: the true drift per step is ``c dphi1 (dphi1/2 - dphi2)``
and the diagnostic reports the same sign and order (H^2 per step), on the zero-momentum mode
(1 + J1/J2) / (1/2 + J1/J2) times the true drift (tests/test_energy.py checks both).  Known blind spot:
Gauss-Seidel with zero-order hold, where the drift ``c dphi1^2 / 2`` comes entirely from B's torque jump
when its held angle moves to the new sample; the residual then under-reports by orders of magnitude.
This definition coincides with the master's own bond log (:func:`harness.results.bond_energy`) whenever
the motion-output side's speed is linear over the step (an inertia under a held torque).

Held values are NOT in a result (B's recorded inputs are its point values after the exchange), so they are
reconstructed with the masters' rule (:mod:`harness.master.extrapolation`): extrapolation order 0 holds the newest
sample; order q >= 1 the degree-q polynomial through the newest q+1 samples evaluated at the step midpoint
(degree reduced while fewer samples exist).  Which samples are "known" depends on the master:

* ``jacobi``: both sides use samples up to ``t_k``;
* ``gauss-seidel``: the side that steps first uses samples up to ``t_k``, the second one includes the first
  one's new sample at ``t_k+1``; ``first="out"`` (default: the motion-output side has no direct
  feed-through in a force-displacement split, so :func:`harness.master.graph.stepping_order` puts it first);
* ``iterative``: the converged held values use the samples up to ``t_k+1`` on both sides.

``master`` and ``order`` default to ``df.attrs["master"]`` and ``df.attrs["extrapolation"]`` (set by
:func:`harness.simulate`).  Variable steps are handled (the times come from the index).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

_ROT = ("phi", "w", "tau")
_TRA = ("s", "v", "f")


def _ports(bond) -> tuple[str, str]:
    """(motion_out, motion_in) from a harness.model.Bond, a pair of strings or ``"A.port->B.port"``."""
    if hasattr(bond, "motion_out") and hasattr(bond, "motion_in"):
        return str(bond.motion_out), str(bond.motion_in)
    if isinstance(bond, str) and "->" in bond:
        a, b = (s.strip() for s in bond.split("->", 1))
        return a, b
    if isinstance(bond, (tuple, list)) and len(bond) == 2 and all(isinstance(s, str) for s in bond):
        return bond[0], bond[1]
    raise ValueError(f"bond = {bond!r} is not admissible: give a harness.model.Bond, a pair "
                     f"('A.port', 'B.port') or 'A.port->B.port'")


def _columns(df: pd.DataFrame, bond) -> tuple[str | None, str, str]:
    a, b = _ports(bond)
    for p, v, e in (_ROT, _TRA):
        if f"{a}.{v}" in df.columns or f"{b}.{e}" in df.columns:
            need = [f"{a}.{v}", f"{b}.{e}"]
            missing = [c for c in need if c not in df.columns]
            if missing:
                raise ValueError(f"bond {a}->{b}: column {missing[0]!r} is not in the result "
                                 f"(record it with output=[...])")
            angle = f"{a}.{p}" if f"{a}.{p}" in df.columns else None
            return angle, f"{a}.{v}", f"{b}.{e}"
    raise ValueError(f"bond {a}->{b}: the result has neither {a}.w/{b}.tau nor {a}.v/{b}.f columns")


def held_values(t: np.ndarray, y: np.ndarray, order: int, include_end: bool) -> np.ndarray:
    """Value held over each step [t_k, t_k+1] (k = 0..n-2) by an input fed from samples ``y`` at ``t``.

    Order 0: the newest known sample; order q >= 1: the polynomial through the newest q+1 known samples at
    t_k + H/2.  Known samples: up to t_k, or up to t_k+1 with ``include_end``."""
    if order not in (0, 1, 2):
        raise ValueError(f"extrapolation order = {order!r} is not admissible: must be 0, 1 or 2")
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    n = len(t)
    out = np.empty(max(n - 1, 0))
    shift = 1 if include_end else 0
    for k in range(n - 1):
        newest = k + shift
        if order == 0:
            out[k] = y[newest]
            continue
        te = 0.5 * (t[k] + t[k + 1])
        q = min(order, newest)
        nodes = range(newest, newest - q - 1, -1)
        val = 0.0
        for j in nodes:
            w = 1.0
            for m in nodes:
                if m != j:
                    w *= (te - t[m]) / (t[j] - t[m])
            val += w * y[j]
        out[k] = val
    return out


def _rule(df: pd.DataFrame, master, order, first: str) -> tuple[bool, bool, int]:
    master = df.attrs.get("master") if master is None else master
    order = df.attrs.get("extrapolation") if order is None else order
    if master is None or order is None:
        raise ValueError("the result does not say its master/extrapolation (df.attrs): give master= and order=")
    key = str(master).strip().lower().replace("_", "-")
    if key in ("gs", "gaussseidel"):
        key = "gauss-seidel"
    if first not in ("out", "in"):
        raise ValueError(f"first = {first!r} is not admissible: must be 'out' or 'in'")
    if key == "jacobi":
        return False, False, int(order)
    if key == "gauss-seidel":
        return (first == "in"), (first == "out"), int(order)
    if key == "iterative":
        return True, True, int(order)
    raise ValueError(f"master = {master!r} is not admissible: must be jacobi, gauss-seidel or iterative")


def bond_power(df: pd.DataFrame, bond, master: str | None = None, order: int | None = None,
               first: str = "out") -> pd.DataFrame:
    """Mean power over each communication step on both sides of a bond (module docstring) [W].

    Columns ``P_out`` (into the motion-output side, exact), ``P_in`` (out of the motion-input side, as it
    sees it), ``residual`` = P_out - P_in; indexed by the step's END time (the first row, t_0, is NaN)."""
    angle, wcol, ecol = _columns(df, bond)
    out_end, in_end, q = _rule(df, master, order, first)
    t = df.index.to_numpy(dtype=float)
    if len(t) < 2:
        raise ValueError(f"the result has {len(t)} communication point(s): need at least 2")
    H = np.diff(t)
    if not np.all(H > 0):
        raise ValueError("the result's time index must be strictly increasing")
    w = df[wcol].to_numpy(dtype=float)
    tau = df[ecol].to_numpy(dtype=float)
    tau_held = held_values(t, tau, q, out_end)       # torque held by the motion-output side
    w_held = held_values(t, w, q, in_end)            # speed held by the motion-input side
    if angle is not None:
        dphi = np.diff(df[angle].to_numpy(dtype=float))
    else:
        dphi = 0.5 * (w[1:] + w[:-1]) * H
    p_out = tau_held * dphi / H
    p_in = w_held * 0.5 * (tau[1:] + tau[:-1])
    nan = np.array([np.nan])
    return pd.DataFrame({"P_out": np.concatenate([nan, p_out]), "P_in": np.concatenate([nan, p_in]),
                         "residual": np.concatenate([nan, p_out - p_in])}, index=df.index.copy())


def coupling_energy(df: pd.DataFrame, bond, master: str | None = None, order: int | None = None,
                    first: str = "out") -> pd.Series:
    """Energy created by the coupling of a bond, accumulated from the start [J] (0 at t_0)."""
    bp = bond_power(df, bond, master, order, first)
    H = np.diff(df.index.to_numpy(dtype=float))
    e = np.concatenate([[0.0], np.cumsum(bp["residual"].to_numpy()[1:] * H)])
    a, b = _ports(bond)
    return pd.Series(e, index=df.index.copy(), name=f"{a}->{b}")


def ecco_residual(df: pd.DataFrame, bond, master: str | None = None, order: int | None = None,
                  first: str = "out") -> pd.Series:
    """ECCO's energy residual per step, |P_out - P_in| * H [J], indexed by the step's end time (NaN at t_0)."""
    bp = bond_power(df, bond, master, order, first)
    H = np.concatenate([[np.nan], np.diff(df.index.to_numpy(dtype=float))])
    a, b = _ports(bond)
    return pd.Series(np.abs(bp["residual"].to_numpy()) * H, index=df.index.copy(), name=f"{a}->{b}")


__all__ = ["bond_power", "coupling_energy", "ecco_residual", "held_values"]
