"""Interface Jacobians of a co-simulation step: how each FMU's outputs at the end of a communication step
respond to the inputs it holds over the step (the ``jacobian`` master, :class:`harness.master.InterfaceJacobian`).

The scheme (linearly implicit coupling; Schweizer, Li and Lu's implicit predictor/corrector coupling with
approximated interface Jacobians, where one corrector step is taken)
-----------------------------------------------------------------------------------------------------
Let ``G(u)`` take the step ``[t, t+h]`` on held inputs ``u`` and return the held inputs recomputed from the
outputs at ``t+h``: ``(1 - theta) y(t) + theta y(t+h)`` of each input's source.  Its fixed point ``u = G(u)`` is
an implicit coupling whose stability no longer depends on the stiffness that spans FMUs
(:func:`harness.studies.stability.theory.amplification_matrix`, master ``jacobian``, the closed form):

* ``theta = 1/2`` for every input is the trapezoid: energy-conserving on a power bond (the effort held by one
  side is the mean of the other side's, and so is the speed), spectral radius exactly 1 at every step on the
  undamped two-inertia pair with exact subsystems, second order.  Neutral is not enough on a press drive: the
  bed drive's stiff modes (the elastic coupler, ~3e3 rad/s, aliased by the trapezoid) met the drive's
  time-varying kinematics and grew at a 2 ms step (measured, also with the fixed point fully converged by
  Newton iteration, so it is the fixed point, not the single correction);
* so on each power bond the effort held by the motion-output side leans to the step's END and the motion
  held by the motion-input side to its START, ``theta = 1/2 + s`` and ``1/2 - s``: the pair then dissipates
  at every step, while a shift the other way, or ``theta = 1`` on both (the new sample held, the
  ``iterative`` master's order-0 fixed point), grows at every step (closed form).  A constant shift would
  cost a first-order damping at every step size (the undamped two-inertia pair lost a quarter of its
  amplitude per second at 1 ms with ``s = 0.1``), so the shift follows the bond's loop gain over the step
  (:func:`bond_gain`: how much of a held value comes back through the bond within the step, about
  ``(omega h)^2 / 2`` for a spring between inertias): ``s = THETA_SHIFT * min(1, gain)`` with
  :data:`THETA_SHIFT` = 0.1.  Where the step resolves the bond's dynamics the coupling is the trapezoid,
  second order; where it does not, it damps (two-inertia: spectral radius 0.96 at omega h = 2 to 12);
* a bond position that the FMU advances itself with the held speed keeps its value at t (``theta = 0``);
  every other connection takes the trapezoid.

The extrapolation order of the run only sets the predictor.  The scheme solves the fixed point with ONE
Newton step from the explicit (Jacobi) prediction ``u0``:

    (I - J_G) du = G(u0) - u0,        u1 = u0 + du,

then takes the step again on ``u1`` (rollback).  For FMUs that are linear over a step (the two-inertia
benchmark, any linearised drive) the step on ``u1`` IS the fixed point, at the cost of two FMU steps per
communication step.  For a nonlinear drive the remaining residual ``G(u1) - u1`` is of second order in ``du``
and measures how good the Jacobian still is.

``J_G`` is assembled from per-FMU blocks (:func:`assemble`)::

    y(t+h) = A u + D v,    v = C y + offset   (the inputs set at t+h to refresh feed-through outputs)
    dy = (I - D C)^-1 A du,      J_G = W (I - D C)^-1 A = diag(theta) S,   S = C (I - D C)^-1 A

* ``A_i`` (outputs x held inputs of FMU i): the step's sensitivity through the FMU's state, estimated by rollback
  (fmi2SetFMUstate to the step start) and a step with one input perturbed, the point inputs then set back
  (:func:`step_sensitivity`); one extra FMU step per input.
* ``D_i``: the direct feed-through at the point, by perturbing one input and reading the outputs again (no step).
* ``W`` (held inputs x outputs): ``theta_k fac_k`` at (k, source of k) (:func:`target_weights`).

The Jacobians are refreshed only when they have changed: after each corrector the master compares the residual
``G(u1) - u1`` with ``G(u0) - u0``; a Newton step with a good Jacobian contracts it by far more than
:data:`CONTRACTION` (quadratically), a stale one does not, and the next step estimates them anew (also when the
step size changes).  A step whose residual grows is taken once more with fresh Jacobians.

Contacts within a step.  A clearance that closes or opens inside a step (the full bed model's stone pin and
four-bar joint when the load reverses) makes the outputs respond to the inputs through a different law on
each side of the contact: Jacobians estimated in the step then leave the corrector's residual about as large
as the predictor's, or larger, and one Newton step lands far from the fixed point (at 1 ms the impact came out
a hundred times the reference's force and the run diverged).  Such a step (:func:`needs_halving`) is taken again
as two halves, each by the same scheme, down to 1/16 of it (:data:`MAX_HALVINGS`), so the step stays large
away from the contacts.  What the scheme does not do: locate an FMU's events (the FMUs do, inside their steps),
or correct non-Real connections (passed as by ``jacobi``); FMUs without fmi2Get/SetFMUstate are refused.
"""
from __future__ import annotations

import math

import numpy as np

CONTRACTION = 0.2   # refresh the Jacobians when a corrector leaves more than this share of the predictor's residual
THETA_SHIFT = 0.1    # largest shift of theta from 1/2 on a bond's effort / motion (module docstring: why and cost)
MAX_HALVINGS = 4     # a step is halved at most this often (to 1/16 of it) where its correction does not contract
HALVING_RESIDUAL = 1e-3   # ... and leaves more than this share of the held values (harness.master.jacobian.needs_halving)
RELATIVE_PERTURBATION = 1e-6   # forward-difference perturbation, relative to max(1, |input|)


def perturbation(values: np.ndarray) -> np.ndarray:
    """Forward-difference perturbation of each input (relative to its magnitude, at least 1e-6)."""
    return RELATIVE_PERTURBATION * np.maximum(1.0, np.abs(values))


def motion_held(inst, bond) -> list[int]:
    """Indices in the held-input vector of the motion (position and speed) held at ``bond``'s motion-input port,
    an input port of the master's instance ``inst``."""
    port = bond.motion_in.split(".", 1)[1]
    return [inst.input_slice.start + k for v, k in inst.input_pos.items() if v.rsplit(".", 1) in
            ([port, "phi"], [port, "w"], [port, "s"], [port, "v"])]


def feedthrough_block(fmu, inp, out, point: np.ndarray) -> np.ndarray:
    """``D_i``: d outputs / d inputs at the current point of ``fmu`` (inputs ``point``): the FMU's own directional
    derivatives, one unit seed per input, where it declares them (the toolkit's FMUs, from their physics), else
    forward differences; the inputs are left at ``point``."""
    fmu.set(inp, point)
    if getattr(fmu, "provides_directional_derivative", False):
        D = np.zeros((len(out.names), point.size))
        seed = np.zeros(point.size)
        for j in range(point.size):
            seed[j] = 1.0
            D[:, j] = fmu.directional_derivative(out, inp, seed)
            seed[j] = 0.0
        return D
    base = np.array(fmu.get(out), dtype=float)  # a copy: get() may return the wrapper's own buffer
    D = np.zeros((base.size, point.size))
    dp = perturbation(point)
    for j in range(point.size):
        x = point.copy()
        x[j] += dp[j]
        fmu.set(inp, x)
        D[:, j] = (np.asarray(fmu.get(out), dtype=float) - base) / dp[j]
    fmu.set(inp, point)
    return D


def step_sensitivity(fmu, inp, out, start_state, held: np.ndarray, point: np.ndarray | None,
                     base: np.ndarray, t: float, h: float, *, step) -> np.ndarray:
    """``A_i``: d outputs(t+h) / d held inputs through the state of ``fmu``: for each input, roll back to
    ``start_state``, step on ``held`` with that input perturbed, set the point inputs ``point`` (None: the FMU
    has no feed-through, leave the inputs) and difference the outputs against ``base`` (the outputs of the
    unperturbed step with the same point inputs).  ``step(t, h)`` takes the FMU's step (the master's, which
    counts it)."""
    A = np.zeros((base.size, held.size))
    dh = perturbation(held)
    for j in range(held.size):
        x = held.copy()
        x[j] += dh[j]
        fmu.set_state(start_state)
        fmu.set(inp, x)
        step(t, h)
        if point is not None:
            fmu.set(inp, point)
        A[:, j] = (np.asarray(fmu.get(out), dtype=float) - base) / dh[j]
    return A


def assemble(A: np.ndarray, D: np.ndarray, src: np.ndarray, factor: np.ndarray) -> np.ndarray:
    """``S = C (I - D C)^-1 A`` (held inputs x held inputs): how the inputs recomputed from the outputs at t+h
    (``v = C y``, ``C[k, src_k] = fac_k``) respond to the held inputs.  ``J_G = diag(c) S`` with ``c`` the
    weight of the sample at t+h in each input's held value (:func:`target_weights`)."""
    n_y = A.shape[0]
    C = np.zeros((src.size, n_y))
    C[np.arange(src.size), src] = factor
    M = np.linalg.solve(np.eye(n_y) - D @ C, A)
    return C @ M


def singular_direction(M: np.ndarray) -> list[int]:
    """The entries that carry the singular direction of a square matrix ``M`` that ``np.linalg.solve`` refused:
    the right singular vector of its smallest singular value, its entries within half of its largest, largest
    first (for the message that names the bond of a singular coupling)."""
    with np.errstate(all="ignore"):
        try:
            v = np.abs(np.linalg.svd(np.nan_to_num(M))[2][-1])
        except np.linalg.LinAlgError:
            return []
    order = np.argsort(-v)
    return [int(k) for k in order if v[k] >= 0.5 * v[order[0]]]


def bond_gain(S: np.ndarray, inputs: list[int]) -> float:
    """The loop gain of one power bond over a step: max |S_kk| over its held inputs (effort and motion), the
    dimensionless share of a held value that comes back through the bond within the step (~ (omega h)^2 / 2
    for a spring between two inertias; large for a rigid element between inertias of different size)."""
    return float(np.max(np.abs(S[inputs, inputs]))) if inputs else 0.0


def target_weights(n_inputs: int, bonds, S: np.ndarray | None, positions) -> np.ndarray:
    """theta per held input: the fixed point holds ``(1 - theta) y(t) + theta y(t+h)``.  On each power bond
    ``(effort, [motion])`` the held effort gets ``1/2 + s`` and the held motion ``1/2 - s``, with
    ``s = THETA_SHIFT * min(1, gain)`` (:func:`bond_gain` of ``S``; ``S`` None, before any estimate:
    ``THETA_SHIFT``); every other input 1/2 (the trapezoid); the bond positions the FMUs advance themselves 0
    (they keep their value at t)."""
    theta = np.full(n_inputs, 0.5)
    for effort, motion in bonds:
        s = THETA_SHIFT if S is None else THETA_SHIFT * min(1.0, bond_gain(S, [effort, *motion]))
        theta[effort] = 0.5 + s
        theta[np.asarray(motion, dtype=np.intp)] = 0.5 - s
    theta[np.asarray(positions, dtype=np.intp)] = 0.0
    return theta


def contraction(r0: np.ndarray, r1: np.ndarray, scale: np.ndarray) -> float:
    """max |r1| / max |r0| in the units of ``scale`` (per input); 0 when the predictor was already consistent."""
    a = float(np.max(np.abs(r0) / scale)) if r0.size else 0.0
    b = float(np.max(np.abs(r1) / scale)) if r1.size else 0.0
    if not math.isfinite(b):
        return math.inf
    return b / a if a > 1e-12 else 0.0


def needs_halving(rho: float, r1: np.ndarray, scale: np.ndarray) -> bool:
    """A step whose correction, with Jacobians estimated in this very step, leaves more than
    :data:`CONTRACTION` of the predictor's residual and more than :data:`HALVING_RESIDUAL` of the held values:
    the outputs do not respond linearly to the inputs over the step (a clearance closes or opens within it, an
    impact), so one Newton step cannot find the fixed point; the step is taken again as two halves."""
    return rho > CONTRACTION and (not math.isfinite(rho) or float(np.max(np.abs(r1) / scale)) > HALVING_RESIDUAL)
