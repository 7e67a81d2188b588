"""Coupling stability of the two-inertia benchmark in theory: amplification matrices and stability boundaries.

Coupling stability of the two-inertia benchmark: amplification matrices, stability boundaries, study CLI.

The benchmark (``systems/two_inertia.py``) splits two inertias across the FMU boundary with
force-displacement coupling:

* FMU ``a`` = ``Inertia`` (:class:`fmus.physics.elements.InertiaModel`), state ``(phi1, w1)``, motion out,
  input the held torque ``tau``:  ``J1 w1' = -c1 phi1 - d1 w1 + tau`` (``c1, d1`` = its ``c_ground,
  d_ground``; the constant ``tau_drive`` only adds an affine forcing and does not change stability);
* FMU ``b`` = ``SpringInertia`` (:class:`fmus.physics.elements.SpringInertiaModel`), state ``(phi2, w2)``,
  motion in (held ``phi_in, w_in``): ``J2 w2' = c (phi_in - phi2) + d (w_in - w2) - c2 phi2 - d2 w2``; its
  output ``tau = -(c (phi_in - phi2) + d (w_in - w2))`` is a direct function of the inputs.

Amplification matrix
--------------------
:func:`amplification_matrix` is the exact one-step map ``z_{k+1} = M z_k`` of the coupled discrete system
as the masters of :mod:`harness.master` compute it.  ``z_k = [x_k, x_{k-1}, ..., x_{k-q}]`` stacks the
coupled state ``x = (phi1, w1, phi2, w2)`` at the last ``q + 1`` communication points (``q`` = the
extrapolation order): the coupling outputs are linear functions of the consistent state (``tau_k`` is ``b``'s
output evaluated with the point inputs at ``t_k``), so the output history of the extrapolation is the state
history.  The extra dimensions only add eigenvalues 0.

* Held inputs (see :mod:`harness.master.extrapolation`): order 0 holds the newest sample; order ``q >= 1`` holds
  the degree-``q`` polynomial through the newest ``q + 1`` samples evaluated at the step MIDPOINT
  ``t_k + h/2``.  The weights are Lagrange weights computed from the nodes (:func:`lagrange_weights`).
  The reduced degree of the first ``q`` steps is a start-up transient and does not enter ``M``.
* ``jacobi``: both FMUs hold values extrapolated from the samples at ``t_k, t_{k-1}, ...``.
* ``gauss-seidel``: the FMU without direct feed-through goes first (``harness.master.graph.stepping_order``), i.e.
  ``a`` (Inertia) steps on the torque extrapolated from ``t_k, t_{k-1}, ...``; then ``b`` (SpringInertia)
  holds the motion polynomial through ``a``'s NEW sample at ``t_{k+1}`` and ``t_k, ...`` (order 0: the new
  value itself; order >= 1: interpolation at the midpoint).
* Each subsystem over a step with its input held: ``x+ = Phi x + Gamma u`` with ``[[Phi, Gamma], [0, I]]``
  the one-step map of the subsystem augmented by its held input (``u' = 0``).  ``integrator="exact"`` uses
  the matrix exponential of the augmented matrix.  ``integrator="rk4"`` (default) reproduces what the FMUs
  really do: :meth:`fmus.physics.base.Model.advance` takes ``n = integrate.substeps(h, max_substep)``
  classical RK4 sub-steps, and the RK4 map of a linear system is exactly the degree-4 Taylor polynomial of
  ``exp(A dt)`` (applied ``n`` times).  Both elementary models have ``substep_limit() = inf``: ONE RK4 step
  per communication step.  Near the coupling-stability boundary ``omega h`` is of order 1, where RK4 and the
  exponential differ by several per cent in the boundary, so the RK4 map is the default (the choice is
  tested in tests/test_stability.py).

Stability boundary
------------------
:func:`stability_boundary` (theory) scans ``spectral_radius`` on a log grid over ``[h_lo, h_hi]`` and bisects
the FIRST step where it exceeds ``1 + tol`` (``tol`` = 1e-9 absorbs round-off for neutrally stable undamped
maps).  A free-free system keeps an eigenvalue 1 (rest at any constant angle is a fixed point of every
master, because the extrapolation weights sum to 1): the spectral radius is then 1 at best, never below.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Mapping

import numpy as np
from scipy.linalg import expm


MASTER_NAMES = ("jacobi", "gauss-seidel", "jacobian")
ORDERS = (0, 1, 2)
INTEGRATORS = ("rk4", "exact")


# -- the benchmark --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TwoInertia:
    """Parameters of the split two-inertia system (SI units).

    ``J1, c1, d1``: Inertia ``a`` (J, c_ground, d_ground); ``J2, c, d, c2, d2``: SpringInertia ``b`` (J, c, d,
    c_ground, d_ground).  Defaults are those of ``systems/two_inertia.py``."""
    J1: float = 0.01
    J2: float = 0.02
    c: float = 100.0
    d: float = 0.0
    c1: float = 0.0
    d1: float = 0.0
    c2: float = 0.0
    d2: float = 0.0

    def __post_init__(self):
        for name in ("J1", "J2"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"parameter {name} = {v!r} is not admissible: must be > 0 kg.m2")
        for name, unit in (("c", "N.m/rad"), ("d", "N.m.s/rad"), ("c1", "N.m/rad"), ("d1", "N.m.s/rad"),
                           ("c2", "N.m/rad"), ("d2", "N.m.s/rad")):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"parameter {name} = {v!r} is not admissible: must be >= 0 {unit}")

    # the FMU parameter sets ---------------------------------------------------------------------------------
    def instance_parameters(self) -> dict[str, dict[str, float]]:
        """``{"a": {...}, "b": {...}}``: parameters of the Inertia and SpringInertia instances."""
        return {"a": {"J": self.J1, "c_ground": self.c1, "d_ground": self.d1},
                "b": {"J": self.J2, "c": self.c, "d": self.d, "c_ground": self.c2, "d_ground": self.d2}}

    def models(self):
        """The pure physics models (``InertiaModel``, ``SpringInertiaModel``) with these parameters."""
        from fmus.physics.elements import InertiaModel, InertiaParams, SpringInertiaModel, SpringInertiaParams

        ip = self.instance_parameters()
        return InertiaModel(InertiaParams(**ip["a"])), SpringInertiaModel(SpringInertiaParams(**ip["b"]))

    @classmethod
    def from_mapping(cls, values: Mapping[str, float]) -> "TwoInertia":
        """From ``{"a.J": .., "b.c": ..}`` (system parameter names) or the field names themselves."""
        alias = {"a.J": "J1", "a.c_ground": "c1", "a.d_ground": "d1", "b.J": "J2", "b.c": "c", "b.d": "d",
                 "b.c_ground": "c2", "b.d_ground": "d2"}
        kw = {}
        for k, v in values.items():
            name = alias.get(k, k)
            if name not in cls.__dataclass_fields__:
                raise ValueError(f"parameter {k!r} is not a two-inertia parameter "
                                 f"(use {', '.join(cls.__dataclass_fields__)} or {', '.join(alias)})")
            kw[name] = float(v)
        return cls(**kw)

    # continuous-time matrices -----------------------------------------------------------------------------
    def subsystem_a(self) -> tuple[np.ndarray, np.ndarray]:
        """(A, B) of the Inertia: x = (phi1, w1), u = tau."""
        A = np.array([[0.0, 1.0], [-self.c1 / self.J1, -self.d1 / self.J1]])
        B = np.array([[0.0], [1.0 / self.J1]])
        return A, B

    def subsystem_b(self) -> tuple[np.ndarray, np.ndarray]:
        """(A, B) of the SpringInertia: x = (phi2, w2), u = (phi_in, w_in)."""
        A = np.array([[0.0, 1.0], [-(self.c + self.c2) / self.J2, -(self.d + self.d2) / self.J2]])
        B = np.array([[0.0, 0.0], [self.c / self.J2, self.d / self.J2]])
        return A, B

    def coupled(self) -> np.ndarray:
        """The monolithic system matrix of x = (phi1, w1, phi2, w2)."""
        J1, J2, c, d = self.J1, self.J2, self.c, self.d
        return np.array([
            [0.0, 1.0, 0.0, 0.0],
            [-(c + self.c1) / J1, -(d + self.d1) / J1, c / J1, d / J1],
            [0.0, 0.0, 0.0, 1.0],
            [c / J2, d / J2, -(c + self.c2) / J2, -(d + self.d2) / J2]])

    def torque_row(self) -> np.ndarray:
        """tau = row @ x: the SpringInertia's output with consistent inputs (phi_in = phi1, w_in = w1)."""
        return np.array([-self.c, -self.d, self.c, self.d])

    def natural_frequency(self) -> float:
        """Largest undamped natural frequency of the coupled system [rad/s]."""
        J1, J2, c = self.J1, self.J2, self.c
        K = np.array([[c + self.c1, -c], [-c, c + self.c2]])
        Minv = np.diag([1.0 / J1, 1.0 / J2])
        lam = np.linalg.eigvals(Minv @ K).real
        return float(math.sqrt(max(lam.max(), 0.0)))

    def natural_frequencies(self) -> tuple[float, float]:
        """Both undamped natural frequencies (low, high) of the coupled system [rad/s]."""
        K = np.array([[self.c + self.c1, -self.c], [-self.c, self.c + self.c2]])
        lam = np.sort(np.linalg.eigvals(np.diag([1.0 / self.J1, 1.0 / self.J2]) @ K).real)
        return float(math.sqrt(max(lam[0], 0.0))), float(math.sqrt(max(lam[1], 0.0)))

    def with_modal_damping(self, zeta: float) -> "TwoInertia":
        """The same system with Rayleigh damping D = alpha M + beta K giving damping ratio ``zeta`` in BOTH
        modes: d = beta c, d1 = beta c1 + alpha J1, d2 = beta c2 + alpha J2 (needs two distinct frequencies
        > 0, i.e. at least one ground spring)."""
        if not (isinstance(zeta, (int, float)) and math.isfinite(zeta) and zeta >= 0):
            raise ValueError(f"parameter zeta = {zeta!r} is not admissible: must be >= 0")
        w1, w2 = self.natural_frequencies()
        if not (w1 > 0 and w2 > w1 * (1 + 1e-9)):
            raise ValueError(f"with_modal_damping: natural frequencies {w1:g}, {w2:g} rad/s must be distinct and "
                             f"> 0 (give c1 or c2 > 0)")
        alpha, beta = np.linalg.solve([[0.5 / w1, 0.5 * w1], [0.5 / w2, 0.5 * w2]], [zeta, zeta])
        return replace(self, d=float(beta * self.c), d1=float(beta * self.c1 + alpha * self.J1),
                       d2=float(beta * self.c2 + alpha * self.J2))

    def energy(self, x: np.ndarray) -> np.ndarray:
        """Total mechanical energy [J] of states x = (phi1, w1, phi2, w2) (last axis)."""
        x = np.asarray(x, dtype=float)
        p1, w1, p2, w2 = x[..., 0], x[..., 1], x[..., 2], x[..., 3]
        return (0.5 * self.J1 * w1 ** 2 + 0.5 * self.J2 * w2 ** 2 + 0.5 * self.c * (p1 - p2) ** 2
                + 0.5 * self.c1 * p1 ** 2 + 0.5 * self.c2 * p2 ** 2)


def _as_params(params) -> TwoInertia:
    if isinstance(params, TwoInertia):
        return params
    if isinstance(params, Mapping):
        return TwoInertia.from_mapping(params)
    raise ValueError(f"params = {params!r} is not admissible: give a TwoInertia or a mapping of its parameters")


def _check_h(h) -> float:
    if isinstance(h, bool) or not isinstance(h, (int, float)) or not math.isfinite(h) or h <= 0:
        raise ValueError(f"step h = {h!r} is not admissible: must be a positive finite number [s]")
    return float(h)


def _master(master: str) -> str:
    key = str(master).strip().lower().replace("_", "-")
    key = {"gs": "gauss-seidel", "gauss seidel": "gauss-seidel", "gaussseidel": "gauss-seidel",
           "iterative": "jacobian"}.get(key, key)  # converged, the iterative master is the same fixed point
    if key not in MASTER_NAMES:
        raise ValueError(f"master = {master!r} is not admissible: must be one of {', '.join(MASTER_NAMES)}")
    return key


def orders_for(master: str, orders=ORDERS) -> tuple[int, ...]:
    """The extrapolation orders a map measures for ``master``: ``jacobian`` solves one fixed point whatever the
    predictor (the order only sets its first guess), so it is measured once, at order 1."""
    return (1,) if master == "jacobian" else tuple(orders)


def _order(order) -> int:
    if isinstance(order, bool) or order not in ORDERS:
        raise ValueError(f"order = {order!r} is not admissible: must be one of 0, 1, 2")
    return int(order)


# -- building blocks ------------------------------------------------------------------------------------------
def lagrange_weights(nodes, s: float) -> np.ndarray:
    """Weights w with p(s) = sum_j w_j y_j for the polynomial through (nodes_j, y_j)."""
    nodes = [float(n) for n in nodes]
    w = np.ones(len(nodes))
    for j, nj in enumerate(nodes):
        for m, nm in enumerate(nodes):
            if m != j:
                w[j] *= (s - nm) / (nj - nm)
    return w


def hold_weights(master: str, order: int) -> tuple[np.ndarray, np.ndarray]:
    """(weights of the torque held by ``a``, weights of the motion held by ``b``).

    Torque weights apply to the samples at t_k, t_{k-1}, ... (newest first).  Motion weights apply to
    t_k, t_{k-1}, ... for jacobi and to t_{k+1}, t_k, ... for gauss-seidel (``a`` has already stepped)."""
    master, order = _master(master), _order(order)
    s = 0.5 if order >= 1 else 0.0     # evaluation point in units of h from t_k (midpoint for order >= 1)
    back = [-float(j) for j in range(order + 1)]
    wt = lagrange_weights(back, s) if order else np.ones(1)
    if master == "jacobi":
        wm = wt.copy()
    else:
        fwd = [1.0 - j for j in range(order + 1)]
        wm = lagrange_weights(fwd, s) if order else np.ones(1)
    return wt, wm


def held_input_map(A: np.ndarray, B: np.ndarray, h: float, integrator: str = "exact",
                   substeps: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """(Phi, Gamma) of x' = A x + B u over one step h with u held constant.

    ``exact``: matrix exponential of the augmented matrix [[A, B], [0, 0]] h.  ``rk4``: ``substeps`` classical
    RK4 steps, whose map of a linear system is the degree-4 Taylor polynomial of exp(aug * h/n), to the n."""
    n, m = A.shape[0], B.shape[1]
    aug = np.zeros((n + m, n + m))
    aug[:n, :n] = A
    aug[:n, n:] = B
    if integrator == "exact":
        E = expm(aug * h)
    elif integrator == "rk4":
        if not (isinstance(substeps, (int, np.integer)) and substeps >= 1):
            raise ValueError(f"substeps = {substeps!r} is not admissible: must be an integer >= 1")
        Z = aug * (h / substeps)
        I = np.eye(n + m)
        Z2 = Z @ Z
        step = I + Z + Z2 / 2.0 + Z2 @ Z / 6.0 + Z2 @ Z2 / 24.0
        E = np.linalg.matrix_power(step, int(substeps))
    else:
        raise ValueError(f"integrator = {integrator!r} is not admissible: must be one of {', '.join(INTEGRATORS)}")
    return E[:n, :n], E[:n, n:]


def model_substeps(params, h: float) -> tuple[int, int]:
    """RK4 sub-steps per communication step (Inertia, SpringInertia) the physics models take at step h."""
    from fmus.physics.integrate import substeps

    p = _as_params(params)
    ma, mb = p.models()
    return substeps(h, ma.max_substep), substeps(h, mb.max_substep)


def subsystem_maps(params, h: float, integrator: str = "rk4"):
    """((PhiA, GammaA), (PhiB, GammaB)) of the two FMUs over one communication step h with held inputs."""
    p, h = _as_params(params), _check_h(h)
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator = {integrator!r} is not admissible: must be one of {', '.join(INTEGRATORS)}")
    na, nb = model_substeps(p, h) if integrator == "rk4" else (1, 1)
    return (held_input_map(*p.subsystem_a(), h, integrator, na),
            held_input_map(*p.subsystem_b(), h, integrator, nb))


# -- amplification matrices -----------------------------------------------------------------------------------
def amplification_matrix(params, h: float, master: str = "jacobi", order: int = 0,
                         integrator: str = "rk4") -> np.ndarray:
    """One-step map z_{k+1} = M z_k of the co-simulated two-inertia system (module docstring).

    ``z = [x_k, x_{k-1}, ..., x_{k-order}]`` with ``x = (phi1, w1, phi2, w2)``; ``M`` is 4(order+1) square."""
    p, h = _as_params(params), _check_h(h)
    master, order = _master(master), _order(order)
    (PA, GA), (PB, GB) = subsystem_maps(p, h, integrator)
    if master == "jacobian":
        return _implicit_matrix(p, (PA, GA), (PB, GB))  # 4 x 4: the predictor's order does not enter
    wt, wm = hold_weights(master, order)
    q = order + 1
    N = 4 * q
    E = [np.zeros((4, N)) for _ in range(q)]        # E[j] z = x_{k-j}
    for j in range(q):
        E[j][:, 4 * j:4 * j + 4] = np.eye(4)
    CA = np.zeros((2, 4))
    CA[0, 0] = CA[1, 1] = 1.0                        # (phi1, w1) = CA x
    CB = p.torque_row()[None, :]                     # tau = CB x
    SA, SB = CA, np.zeros((2, 4))
    SB[0, 2] = SB[1, 3] = 1.0                        # (phi2, w2) = SB x
    tau_held = sum(wt[j] * (CB @ E[j]) for j in range(q))               # 1 x N
    RA = PA @ (SA @ E[0]) + GA @ tau_held                                 # new (phi1, w1): 2 x N
    if master == "jacobi":
        motion_held = sum(wm[j] * (CA @ E[j]) for j in range(q))
    else:
        motion_held = wm[0] * RA + sum(wm[j] * (CA @ E[j - 1]) for j in range(1, q))
    RB = PB @ (SB @ E[0]) + GB @ motion_held                              # new (phi2, w2)
    M = np.zeros((N, N))
    M[0:2] = RA
    M[2:4] = RB
    for j in range(1, q):
        M[4 * j:4 * j + 4] = E[j - 1]
    return M


def _bond_shift(p: TwoInertia, mapA, mapB) -> float:
    """The shift s of theta on the pair's one bond, as the master computes it (harness.master.jacobian.target_weights):
    THETA_SHIFT * min(1, loop gain), the gain being max |S_kk| of ``S = C (I - D C)^-1 A`` over the held
    inputs ``u = (tau [a], phi_in, w_in [b])`` with outputs ``y = (phi1, w1, tau)`` at the step end."""
    from harness.master.jacobian import THETA_SHIFT, assemble, bond_gain

    (_, GA), (_, GB) = mapA, mapB
    row = p.torque_row()                                  # tau = row . (phi1, w1, phi2, w2)
    A = np.zeros((3, 3))
    A[0:2, 0] = GA[:, 0]                                  # a's motion through its state, from the held torque
    A[2, 1:3] = row[2:4] @ GB                             # b's torque through its state, from the held motion
    D = np.zeros((3, 3))
    D[2, 1:3] = row[0:2]                                  # b's torque directly from the motion at the point
    S = assemble(A, D, np.array([2, 0, 1]), np.ones(3))   # tau <- y[2], phi_in <- y[0], w_in <- y[1]
    return THETA_SHIFT * min(1.0, bond_gain(S, [0, 1, 2]))


def _implicit_matrix(p: TwoInertia, mapA, mapB) -> np.ndarray:
    """One-step map ``x_{k+1} = M x_k`` of the ``jacobian`` master's fixed point (harness.master.jacobian): each held
    input is ``(1 - theta) y_k + theta y_{k+1}`` of its source, with ``theta = 1/2 + s`` for the torque that
    ``a`` (motion-output side) holds and ``1/2 - s`` for the motion that ``b`` holds (``s``:
    :func:`_bond_shift`), solved for x_{k+1}.  For FMUs linear over a step (these two) the master's one
    Newton correction reaches this fixed point exactly, so this is its amplification matrix whatever the
    predictor's extrapolation order.  ``s = 0`` is the trapezoid (spectral radius 1 at every step for the
    undamped pair with exact subsystems); ``s > 0`` damps; a shift the other way, or holding the new sample
    itself for both, grows at every step."""
    (PA, GA), (PB, GB) = mapA, mapB
    shift = _bond_shift(p, mapA, mapB)
    te, tm = 0.5 + shift, 0.5 - shift
    CA = np.zeros((2, 4))
    CA[0, 0] = CA[1, 1] = 1.0
    CB = p.torque_row()[None, :]
    SB = np.zeros((2, 4))
    SB[0, 2] = SB[1, 3] = 1.0
    L = np.vstack([GA @ (te * CB), GB @ (tm * CA)])                      # x_{k+1} = L x_{k+1} + R x_k
    R = np.vstack([PA @ CA + GA @ ((1 - te) * CB), PB @ SB + GB @ ((1 - tm) * CA)])
    return np.linalg.solve(np.eye(4) - L, R)


def monolithic_matrix(params, h: float, integrator: str = "exact") -> np.ndarray:
    """One-step map of the coupled (monolithic) system: exp(A h), or one RK4 step with ``integrator="rk4"``."""
    p, h = _as_params(params), _check_h(h)
    A = p.coupled()
    Phi, _ = held_input_map(A, np.zeros((4, 1)), h, integrator, 1)
    return Phi


def rigid_shift(n_blocks: int) -> np.ndarray:
    """The vector adding the same constant to every angle of z (phi1, phi2 of every stacked state)."""
    s = np.zeros(4 * n_blocks)
    s[0::4] = 1.0
    s[2::4] = 1.0
    return s


def deflate_rigid(M: np.ndarray) -> np.ndarray:
    """The map on the quotient space z / span(s) (s = :func:`rigid_shift`), for a FREE system.

    Without ground springs every master maps "all angles + a constant" to itself (the extrapolation weights
    sum to 1), so ``M s = s``: an exact eigenvalue 1 (rest at any angle) that, for an undamped system, forms
    a Jordan block with the constant-speed mode.  eigvals of a defective eigenvalue are only accurate to
    ~sqrt(eps) = 1e-8, enough to fake an instability; so the eigenvalue 1 is removed exactly:
    with Q an orthonormal basis of s-perp, [s Q]^-1 M [s Q] = [[1, *], [0, Q^T M Q]]."""
    s = rigid_shift(M.shape[0] // 4)
    if not np.allclose(M @ s, s, rtol=0.0, atol=1e-9 * max(1.0, np.abs(M).max())):
        raise ValueError("deflate_rigid: the map does not keep a rigid shift of all angles (ground springs?)")
    s = s / np.linalg.norm(s)
    q, _ = np.linalg.qr(np.column_stack([s, np.eye(len(s))]))
    Q = q[:, 1:len(s)]
    return Q.T @ M @ Q


def spectral_radius(params_or_matrix, h: float | None = None, master: str = "jacobi", order: int = 0,
                    integrator: str = "rk4") -> float:
    """max |eig| of a matrix, or of :func:`amplification_matrix` (params, h, master, order, integrator).

    For a free system (c1 = c2 = 0) given by its parameters, the exact rigid-rest eigenvalue 1 is deflated
    (:func:`deflate_rigid`) and the result is max(1, radius of the rest), computed without the ~1e-8 error of
    a defective eigenvalue."""
    if isinstance(params_or_matrix, np.ndarray):
        return float(np.max(np.abs(np.linalg.eigvals(params_or_matrix))))
    if h is None:
        raise ValueError("spectral_radius: give the step h together with the parameters")
    p = _as_params(params_or_matrix)
    M = amplification_matrix(p, h, master, order, integrator)
    if p.c1 == 0.0 and p.c2 == 0.0:
        return max(1.0, float(np.max(np.abs(np.linalg.eigvals(deflate_rigid(M))))))
    return float(np.max(np.abs(np.linalg.eigvals(M))))


def stability_boundary(params, master: str = "jacobi", order: int = 0, h_lo: float | None = None,
                       h_hi: float | None = None, integrator: str = "rk4", tol: float = 1e-9,
                       rtol: float = 1e-6, grid: int = 200) -> float:
    """Largest h of the first stable interval: the first step in [h_lo, h_hi] where the spectral radius
    exceeds 1 + tol (log-grid scan, then bisection to relative width ``rtol``).

    Defaults: h_lo = 1e-3 / omega, h_hi = 10 / omega (omega: :meth:`TwoInertia.natural_frequency`).  Returns
    ``h_lo`` if already unstable there (e.g. undamped Jacobi with zero-order hold is unstable at every h)
    and ``inf`` if stable over the whole interval."""
    p = _as_params(params)
    master, order = _master(master), _order(order)
    omega = p.natural_frequency() or 1.0
    h_lo = _check_h(h_lo if h_lo is not None else 1e-3 / omega)
    h_hi = _check_h(h_hi if h_hi is not None else 10.0 / omega)
    if not h_hi > h_lo:
        raise ValueError(f"h_hi = {h_hi!r} must be larger than h_lo = {h_lo!r}")

    def unstable(h):
        return spectral_radius(p, h, master, order, integrator) > 1.0 + tol

    if unstable(h_lo):
        return h_lo
    hs = np.geomspace(h_lo, h_hi, grid)
    lo = h_lo
    for h in hs[1:]:
        if unstable(h):
            hi = float(h)
            break
        lo = float(h)
    else:
        return math.inf
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        if unstable(mid):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)
