"""Coupling stability of the two-inertia benchmark: amplification matrices, stability boundaries, study CLI.

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
as the masters of :mod:`harness.masters` compute it.  ``z_k = [x_k, x_{k-1}, ..., x_{k-q}]`` stacks the
coupled state ``x = (phi1, w1, phi2, w2)`` at the last ``q + 1`` communication points (``q`` = the
extrapolation order): the coupling outputs are linear functions of the consistent state (``tau_k`` is ``b``'s
output evaluated with the point inputs at ``t_k``), so the output history of the extrapolation is the state
history.  The extra dimensions only add eigenvalues 0.

* Held inputs (see :mod:`harness.extrapolation`): order 0 holds the newest sample; order ``q >= 1`` holds
  the degree-``q`` polynomial through the newest ``q + 1`` samples evaluated at the step MIDPOINT
  ``t_k + h/2``.  The weights are Lagrange weights computed from the nodes (:func:`lagrange_weights`).
  The reduced degree of the first ``q`` steps is a start-up transient and does not enter ``M``.
* ``jacobi``: both FMUs hold values extrapolated from the samples at ``t_k, t_{k-1}, ...``.
* ``gauss-seidel``: the FMU without direct feed-through goes first (``harness.graph.stepping_order``), i.e.
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

:func:`measured_boundary` bisects on actual runs ``run(h) -> DataFrame``.  Blow-up criterion (stated once,
:func:`is_unstable`): a run is unstable if it did not complete (``attrs["complete"] is False``: the master
stopped on a non-finite output or one beyond its blow-up limit) or any value is non-finite, or the
oscillation amplitude GROWS: over the analysed columns (default: every column whose name ends in ``.tau``,
``.f``, ``.w`` or ``.v`` -- torques and speeds, which a free rigid-body drift of the angles does not
affect), with each column's mean over the second half of the run removed, ``max |y|`` over the last quarter
of the run exceeds ``max |y|`` over the second quarter.  The run callable decides its length; the study uses
a fixed number of periods of the coupled natural frequency (``periods``, default 60) and at least
``min_steps`` (default 400) communication steps, so that near the boundary the ratio of the two windows,
about ``rho**(n/2)``, resolves ``rho`` to a few 1e-3.

Study CLI
---------
``python -m harness study stability two_inertia [--sweep inertia|stiffness] [--values ...] [--out DIR]``
(:func:`register` adds the ``study`` group; :func:`register_stability` adds ``stability`` to an existing
group).  For each sweep value and each method (jacobi / gauss-seidel x order 0, 1, 2) it finds the largest
stable macro step from the theory and from co-simulation runs of the FMUs (bisection, ``--no-measure`` skips
it), writes ``stability_two_inertia.csv`` and draws the stability map (PNG + SVG).

``python -m harness study stability {bed_drive,spine_knife,feeder_gto52,proof_press} [--sweep INST.PARAM]
[--values ...] [--masters ...] [--orders ...] [--quick]``: the same map for a press drive, measured only (the
drives are nonlinear): for each value of the coupling parameter (default per drive in :data:`PRESS_STUDIES`,
e.g. ``fourbar.rocker_inertia`` of the bed drive) and each master x order, the largest stable communication step by doubling/halving from
the default step and bisection on runs, judged against a reference run (criterion and search: the
press-drive section below).  Writes ``stability_<system>_<inst>_<param>.csv`` and the map with the system's
default step marked (:func:`plot_press_map`).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Callable, Mapping

import numpy as np
from scipy.linalg import expm

MASTER_NAMES = ("jacobi", "gauss-seidel")
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
    key = {"gs": "gauss-seidel", "gauss seidel": "gauss-seidel", "gaussseidel": "gauss-seidel"}.get(key, key)
    if key not in MASTER_NAMES:
        raise ValueError(f"master = {master!r} is not admissible: must be one of {', '.join(MASTER_NAMES)}")
    return key


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


# -- measured boundary ----------------------------------------------------------------------------------------
GROWTH_SUFFIXES = (".tau", ".f", ".w", ".v")


def growth_ratio(df, columns=None) -> float:
    """Amplitude growth of a run: max over columns of max|y - mean| over the last quarter divided by the same
    over the second quarter (mean over the second half).  inf for an incomplete or non-finite run."""
    if not df.attrs.get("complete", True):
        return math.inf
    if columns is None:
        columns = [c for c in df.columns if str(c).endswith(GROWTH_SUFFIXES)] or list(df.columns)
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise ValueError(f"column {missing[0]!r} is not in the result (columns: {', '.join(map(str, df.columns))})")
    y = df[list(columns)].to_numpy(dtype=float)
    n = len(y)
    if n < 8:
        raise ValueError(f"a run of {n} points is too short to judge growth: need at least 8 communication points")
    if not np.all(np.isfinite(y)):
        return math.inf
    y = y - y[n // 2:].mean(axis=0)
    early = np.max(np.abs(y[n // 4:n // 2]), axis=0)
    late = np.max(np.abs(y[3 * n // 4:]), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(early > 0, late / np.where(early > 0, early, 1.0), np.where(late > 0, math.inf, 0.0))
    return float(np.max(r))


def is_unstable(df, columns=None, threshold: float = 1.0) -> bool:
    """The blow-up criterion of the module docstring: incomplete/non-finite run or growth ratio > threshold."""
    return growth_ratio(df, columns) > threshold


def measured_boundary(run: Callable[[float], "object"], h_lo: float, h_hi: float, rtol: float = 0.005,
                      columns=None, threshold: float = 1.0, max_runs: int = 40, *,
                      judge: Callable[["object"], bool] | None = None, checked: bool = False,
                      bracket: list | None = None) -> float:
    """Largest stable step by bisection on co-simulation runs: ``run(h)`` returns a result DataFrame,
    judged by :func:`is_unstable` (or by ``judge(df) -> unstable?``).  ``run(h_lo)`` must be stable and
    ``run(h_hi)`` unstable (``checked=True``: the caller has already run both, they are not re-run);
    bisection stops at a relative bracket width ``rtol`` and returns the bracket midpoint.  ``bracket``: a
    list that receives the final ``[lo, hi]`` and the number of runs made."""
    lo, hi = _check_h(h_lo), _check_h(h_hi)
    if not hi > lo:
        raise ValueError(f"h_hi = {h_hi!r} must be larger than h_lo = {h_lo!r}")

    def unstable(h):
        df = run(h)
        return judge(df) if judge is not None else is_unstable(df, columns, threshold)

    runs = 0
    if not checked:
        if unstable(lo):
            raise ValueError(f"h_lo = {lo!r}: the run is already unstable; give a smaller h_lo")
        if not unstable(hi):
            raise ValueError(f"h_hi = {hi!r}: the run is still stable; give a larger h_hi")
        runs = 2
    while hi - lo > rtol * hi:
        if runs >= max_runs:
            raise ValueError(f"measured_boundary: no bracket of relative width {rtol} after {max_runs} runs")
        mid = 0.5 * (lo + hi)
        if unstable(mid):
            hi = mid
        else:
            lo = mid
        runs += 1
    if bracket is not None:
        bracket[:] = [lo, hi, runs]
    return 0.5 * (lo + hi)


def two_inertia_run(params, master: str, order: int, periods: float = 60.0, min_steps: int = 400,
                    system="two_inertia", fmu_dir=None, w0: float = 1.0):
    """A ``run(h)`` callable for :func:`measured_boundary`: co-simulates the two-inertia system with the
    parameters ``params`` (Inertia starting at speed ``w0``) over ``periods`` periods of the coupled natural
    frequency and at least ``min_steps`` steps.  ``fmu_dir``: folder with Inertia.fmu/SpringInertia.fmu
    (default: the system's own FMU resolution)."""
    from harness import load, simulate
    from harness.model import Instance

    p = _as_params(params)
    master, order = _master(master), _order(order)
    base = load(system)
    if fmu_dir is not None:
        fmu_dir = Path(fmu_dir)
        inst = []
        for i in base.instances:
            name = str(i.fmu)
            inst.append(Instance(i.name, fmu_dir / f"{name}.fmu" if not name.endswith(".fmu") else i.fmu,
                                 dict(i.parameters)))
        base = replace(base, instances=inst)
    ip = p.instance_parameters()
    ip["a"]["w0"] = float(w0)
    parameters = {f"{i}.{k}": v for i, d in ip.items() for k, v in d.items()}
    omega = p.natural_frequency()
    span = periods * 2.0 * math.pi / omega

    def run(h):
        n = max(int(min_steps), int(math.ceil(span / h)))
        stop = n * h
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return simulate(base, stop_time=stop, step=h, master=master, extrapolation=order,
                            parameters=parameters, outputs=["a.flange.w", "b.drive.tau"], on_error="return")

    return run


# -- the study ------------------------------------------------------------------------------------------------
STUDY_ZETA = 0.1
STUDY_BASE = TwoInertia(J1=0.01, J2=0.01, c=100.0, c1=20.0).with_modal_damping(STUDY_ZETA)
"""Benchmark of the stability map: the chain ground - c1 - J1 | c, d | J2 (Inertia with a ground spring,
SpringInertia free) with Rayleigh damping giving a damping ratio of 0.1 in BOTH modes.  The damping makes
small steps stable (spectral radius < 1: without it Jacobi with zero-order hold is unstable at every step),
and the ground spring removes the free rigid-body mode, so the boundary is a clean crossing of 1."""


def _inertia_variant(base: TwoInertia, r: float) -> TwoInertia:
    return replace(base, J2=base.J1 * r, d=0.0, d1=0.0, d2=0.0).with_modal_damping(STUDY_ZETA)


def _stiffness_variant(base: TwoInertia, r: float) -> TwoInertia:
    return replace(base, c=base.c1 * r, d=0.0, d1=0.0, d2=0.0).with_modal_damping(STUDY_ZETA)


SWEEPS = {"inertia": ("J2/J1", _inertia_variant), "stiffness": ("c/c1", _stiffness_variant)}
DEFAULT_VALUES = {"inertia": (0.2, 0.5, 1.0, 2.0, 5.0), "stiffness": (1.0, 2.0, 5.0, 10.0, 20.0)}


def stability_table(base: TwoInertia = STUDY_BASE, sweep: str = "inertia", values=None, measure: bool = True,
                    fmu_dir=None, periods: float = 60.0, rtol: float = 0.005, progress=None):
    """DataFrame: one row per (sweep value, master, order) with the theory boundary h_theory (RK4 map),
    h_exact (matrix-exponential map), h_measured (bisection on runs, NaN without ``measure``) [s], and the
    relative difference."""
    import pandas as pd

    if sweep not in SWEEPS:
        raise ValueError(f"sweep = {sweep!r} is not admissible: must be one of {', '.join(SWEEPS)}")
    label, make = SWEEPS[sweep]
    values = list(values) if values is not None else list(DEFAULT_VALUES[sweep])
    for v in values:
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"sweep value {v!r} is not admissible: must be a positive number ({label})")
    rows = []
    for v in values:
        p = make(base, float(v))
        omega = p.natural_frequency()
        for master in MASTER_NAMES:
            for order in ORDERS:
                h_th = stability_boundary(p, master, order, integrator="rk4")
                h_ex = stability_boundary(p, master, order, integrator="exact")
                h_me = math.nan
                if measure and math.isfinite(h_th) and h_th > 1e-3 / omega * 1.0001:
                    run = two_inertia_run(p, master, order, periods=periods, fmu_dir=fmu_dir)
                    try:
                        h_me = measured_boundary(run, 0.6 * h_th, 1.5 * h_th, rtol=rtol)
                    except ValueError as e:
                        if progress:
                            progress(f"  measured boundary not bracketed: {e}")
                rows.append(dict(sweep=sweep, ratio_name=label, ratio=float(v), master=master, order=order,
                                 omega=omega, h_theory=h_th, h_exact=h_ex, h_measured=h_me,
                                 rel_diff=(h_me - h_th) / h_th if math.isfinite(h_th) else math.nan,
                                 **{f"p_{k}": val for k, val in asdict(p).items()}))
                if progress:
                    progress(f"{label} = {v:g}  {master:12s} order {order}: theory {h_th:.5g} s, "
                             f"exact-subsystem {h_ex:.5g} s, measured {h_me:.5g} s")
    return pd.DataFrame(rows)


def plot_stability_map(table, path_stem: Path) -> list[Path]:
    """Step limit vs sweep parameter: theory lines, measured markers; writes <stem>.png and <stem>.svg."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    colors = {0: "tab:blue", 1: "tab:orange", 2: "tab:green"}
    styles = {"jacobi": "-", "gauss-seidel": "--"}
    markers = {"jacobi": "o", "gauss-seidel": "s"}
    for (master, order), g in table.groupby(["master", "order"], sort=False):
        g = g.sort_values("ratio")
        y = (g["h_theory"] * g["omega"]).to_numpy()
        ax.plot(g["ratio"], y, styles[master], color=colors[order], label=f"{master}, order {order} (theory)")
        m = g["h_measured"].notna()
        if m.any():
            ax.plot(g["ratio"][m], (g["h_measured"] * g["omega"])[m], markers[master], color=colors[order],
                    mfc="none", ms=7)
    ax.plot([], [], "ko", mfc="none", label="measured (co-simulation, bisection)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

    ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))

    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_formatter(FormatStrFormatter("%g"))
        axis.set_minor_formatter(NullFormatter())
    ax.set_xticks(sorted(table["ratio"].unique()))
    ax.set_xlabel(str(table["ratio_name"].iloc[0]))
    ax.set_ylabel(r"largest stable macro step  $\omega\,H$  [1]")
    ax.set_title("Two-inertia coupling: stability map")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    out = []
    for ext in ("png", "svg"):
        f = path_stem.with_suffix(f".{ext}")
        fig.savefig(f, dpi=150)
        out.append(f)
    plt.close(fig)
    return out


# -- press drives -----------------------------------------------------------------------------------------------
# The press drives are nonlinear, forced and never at rest, so the growth criterion of the linear benchmark
# (amplitude of the last quarter against the second quarter) is blind there: load events (a cut starting, an
# impact) change the amplitude of a perfectly stable run.  Their criterion is a deviation from a reference:
#
#   reference  the same system and parameters at the system's default step (``experiment.step``) with
#              gauss-seidel, order 0 (halved up to 3 times if that run does not complete);
#   unstable   the run did not complete (FMU error, non-finite output, an output beyond the master's blow-up
#              limit) or, on any analysed column (names ending in .tau .f .w .v), the largest deviation from
#              the reference (linearly interpolated to the run's communication points) over the LAST QUARTER
#              of the run exceeds ``tol`` (default 1) times that column's own variation in the reference
#              (max |y_ref - mean y_ref| over the run; floored at 1e-6 max |y_ref| + 1e-12 so that a column
#              that is physically zero does not turn round-off into a blow-up).
#
# A deviation as large as the signal itself is a blow-up, not a discretisation error: every run compares the
# same physical window [0, T], T = max(duration, periods * 2 pi / omega) with omega an estimate of the stiffest
# coupled mode from the parameters (``PressStudy.omega``), so a weakly unstable step whose growth over T stays
# below the signal size counts as stable -- the measured boundary is the largest step whose co-simulation stays
# usable over T.  The search: the default step is judged first, then doubled (or halved) until the verdict
# changes (at most up to ``cap`` x the default step, and never fewer than 16 steps in T), then bisected
# (:func:`measured_boundary`) to a relative bracket width ``rtol``.
PRESS_MASTERS = ("jacobi", "gauss-seidel")
"""Default masters of the press maps; ``jacobi-sampled`` (libcosim/FMPy style) via ``--masters``."""


@dataclass(frozen=True)
class PressStudy:
    """Defaults of the stability map of one press drive: the swept parameter (the stiffness that couples two
    FMUs), its values, the physical run length [s] and an estimate of the stiffest coupled mode [rad/s] from
    the parameters (``omega(p)`` with ``p("inst.param") -> value``; a LOWER estimate lengthens the runs)."""
    system: str
    sweep: str
    values: tuple
    quick_values: tuple
    duration: float
    omega: Callable
    doc: str


def _torsion(p, inst):
    return p(f"{inst}.G") * math.pi * p(f"{inst}.d") ** 4 / (32.0 * p(f"{inst}.l"))


PRESS_STUDIES = {
    # Measured with --quick (jacobi, order 0): the step limit hardly moves with the rack mesh (c_mesh 5e6..1e8:
    # 5.5e-4..6.3e-4 s), the coupler, shaft or belt stiffness (no change), but scales with the ring + rocker
    # inertia on the four-bar's motion OUTPUT side of the reversing pair (0.1 -> 1.3e-4 s, 0.5 -> 6.0e-4 s,
    # 2.5 -> 2.1e-3 s): the rigid differential hands the effort of the bed's side straight back, so the
    # inertia ratio across that FMU boundary sets the limit (the force-displacement coupling's mass ratio).
    "bed_drive": PressStudy(
        "bed_drive", "fourbar.rocker_inertia", (0.1, 0.25, 0.5, 1.0, 2.5), (0.1, 0.5, 2.5), 0.1,
        lambda p: math.sqrt(p("fourbar.coupler_stiffness") * p("fourbar.rocker_length") ** 2
                            / p("fourbar.rocker_inertia")),
        "inertia of the ring gear and rocker [kg.m2] on the four-bar's motion-output port (FourBar), coupled "
        "through the rigid James differential to the bed; omega ~ sqrt(c_coupler l_rocker^2 / J_rocker)"),
    "spine_knife": PressStudy(
        "spine_knife", "shaft.d", (0.02, 0.025, 0.03, 0.04, 0.05), (0.02, 0.03, 0.05), 0.05,
        lambda p: math.sqrt(_torsion(p, "shaft") * (1.0 / p("shaft.J_flywheel") + 1.0 / p("shaft.J_crank"))),
        "driving-shaft diameter d [m] (torsional stiffness G pi d^4 / (32 l)) of the FlywheelShaft that drives "
        "the linkage; omega ~ sqrt(c1 (1/J_flywheel + 1/J_crank))"),
    "feeder_gto52": PressStudy(
        "feeder_gto52", "feeder.stiffness", (1000.0, 2000.0, 5000.0, 10000.0, 20000.0), (1000.0, 5000.0, 20000.0),
        0.1, lambda p: math.sqrt(p("feeder.stiffness") / p("feeder.rocker_inertia")),
        "transmission (conrod / slotted-rocker) stiffness [N.m/rad] of the CamRocker, whose crank torque "
        "couples it to the flywheel shaft; omega ~ sqrt(stiffness / rocker_inertia)"),
    "proof_press": PressStudy(
        "proof_press", "press.c_cyl", (5e4, 1e5, 2e5, 5e5, 1e6), (5e4, 2e5, 1e6), 0.2,
        lambda p: math.sqrt(p("press.c_cyl") / p("press.J_cyl")),
        "torsional stiffness sectors -> cylinder c_cyl [N.m/rad] of GearSectors, whose crank torque couples "
        "it to the flywheel shaft; omega ~ sqrt(c_cyl / J_cyl)"),
}


def _parameter_table(system) -> dict:
    """``{"inst.param": (value, model_variable)}`` of every Real parameter of the system's FMUs: the system's
    value, else the FMU's start value."""
    from harness.model import model_description, resolve_fmu

    out = {}
    for inst in system.instances:
        md = model_description(resolve_fmu(inst.fmu))
        for v in md.modelVariables:
            if v.causality != "parameter":
                continue
            val = inst.parameters.get(v.name, v.start)
            out[f"{inst.name}.{v.name}"] = (val, v)
    return out


def check_sweep(system, sweep: str, values=None) -> None:
    """One-line ValueError unless ``sweep`` is ``INST.PARAM``, a Real parameter of an instance of ``system``,
    and every value a finite number."""
    from harness import load

    system = load(system)
    inst, dot, name = str(sweep).partition(".")
    if not dot or not inst or not name:
        raise ValueError(f"--sweep {sweep!r} is not admissible: write it INSTANCE.PARAMETER (e.g. bed.c_mesh)")
    names = [i.name for i in system.instances]
    if inst not in names:
        raise ValueError(f"--sweep {sweep}: system {system.name} has no instance {inst!r} "
                         f"(instances: {', '.join(names)})")
    table = _parameter_table(system)
    own = sorted(k.partition(".")[2] for k, (_, v) in table.items() if k.startswith(inst + ".") and v.type == "Real")
    if f"{inst}.{name}" not in table or table[f"{inst}.{name}"][1].type != "Real":
        raise ValueError(f"--sweep {sweep}: instance {inst} ({system.instance(inst).fmu}) has no Real parameter "
                         f"{name!r} (parameters: {', '.join(own)})")
    for v in values or ():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"--values: {v!r} is not admissible for {sweep}: must be a finite number")


def deviation_ratio(df, ref, columns=None) -> float:
    """Max over the analysed columns of max |y - y_ref| over the last quarter of ``df`` divided by the
    column's variation in the reference (see the press-drive criterion above); inf for an incomplete or
    non-finite run."""
    if not df.attrs.get("complete", True):
        return math.inf
    if columns is None:
        columns = [c for c in ref.columns if str(c).endswith(GROWTH_SUFFIXES)] or list(ref.columns)
    missing = [c for c in columns if c not in df.columns or c not in ref.columns]
    if missing:
        raise ValueError(f"column {missing[0]!r} is not in both the run and the reference")
    t = df.index.to_numpy(dtype=float)
    tr = ref.index.to_numpy(dtype=float)
    if t[-1] > tr[-1] * (1 + 1e-12):
        raise ValueError(f"the reference ends at {tr[-1]:g} s, before the run ({t[-1]:g} s)")
    n = len(t)
    if n < 8:
        raise ValueError(f"a run of {n} points is too short to judge: need at least 8 communication points")
    y = df[list(columns)].to_numpy(dtype=float)
    if not np.all(np.isfinite(y)):
        return math.inf
    worst = 0.0
    for j, c in enumerate(columns):
        yr_full = ref[c].to_numpy(dtype=float)
        yr = np.interp(t, tr, yr_full)
        scale = float(np.max(np.abs(yr - yr.mean())))
        scale = max(scale, 1e-6 * float(np.max(np.abs(yr_full))) + 1e-12)
        dev = float(np.max(np.abs(y[3 * n // 4:, j] - yr[3 * n // 4:])))
        worst = max(worst, dev / scale)
    return worst


def _quiet_simulate(*args, **kwargs):
    import warnings

    from harness import simulate

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(*args, **kwargs)


def _with_fmu_dir(system, fmu_dir):
    from harness import load
    from harness.model import Instance

    system = load(system)
    if fmu_dir is None:
        return system
    inst = [Instance(i.name, Path(fmu_dir) / f"{i.fmu}.fmu" if not str(i.fmu).endswith(".fmu") else i.fmu,
                     dict(i.parameters)) for i in system.instances]
    return replace(system, instances=inst)


class PressRun:
    """``run(h)`` for :func:`measured_boundary` on a press drive, plus its reference and judge.

    ``parameters``: overrides ``{"inst.param": value}``; ``duration``: the physical window T [s] every run
    covers (``n = floor(T / h)`` steps, at least 8)."""

    def __init__(self, system, master: str, order: int, parameters: Mapping | None = None,
                 duration: float = 0.1, fmu_dir=None, tol: float = 1.0, reference=None):
        from harness.masters import master_class

        self.system = _with_fmu_dir(system, fmu_dir)
        self.master = master_class(master).name
        self.order = _order(order)
        self.parameters = dict(parameters or {})
        self.duration = _check_h(duration)
        self.tol = float(tol)
        self.h_default = float(self.system.experiment.step)
        self.ref = reference if reference is not None else self.reference()
        self.runs = 0

    def reference(self):
        """Gauss-seidel, order 0 at the default step (halved up to 3 times until it completes)."""
        h = self.h_default
        for _ in range(4):
            n = int(math.ceil(self.duration / h - 1e-9))
            df = _quiet_simulate(self.system, stop_time=n * h, step=h, master="gauss-seidel", extrapolation=0,
                                 parameters=self.parameters, on_error="return")
            if df.attrs.get("complete", True):
                return df
            err = df.attrs.get("error", "")
            h *= 0.5
        sets = ", ".join(f"{k} = {v:g}" for k, v in self.parameters.items()) or "default parameters"
        raise ValueError(f"{self.system.name} ({sets}): the reference run failed even at step {2 * h:g} s: {err}")

    def n_steps(self, h: float) -> int:
        return max(8, int(math.floor(self.duration / h + 1e-9)))

    def __call__(self, h: float):
        h = _check_h(h)
        n = self.n_steps(h)
        self.runs += 1
        return _quiet_simulate(self.system, stop_time=n * h, step=h, master=self.master,
                               extrapolation=self.order, parameters=self.parameters, on_error="return")

    def judge(self, df) -> bool:
        """True if the run is unstable (deviation criterion of the press-drive section)."""
        return deviation_ratio(df, self.ref) > self.tol

    def unstable(self, h: float) -> bool:
        return self.judge(self(h))


def press_boundary(prun: PressRun, rtol: float = 0.02, cap: float = 64.0, floor: float = 1.0 / 16) -> dict:
    """Largest stable step of one method (search of the press-drive section).  Returns ``h_stable`` (largest
    step judged stable), ``h_unstable`` (smallest judged unstable), ``h_boundary`` (their midpoint; NaN if not
    bracketed), ``status`` (``bracketed``, ``stable to cap``, ``unstable at floor``) and ``runs``."""
    h0 = prun.h_default
    h_max = min(cap * h0, prun.duration / 16.0)
    h_min = floor * h0
    prun.runs = 0
    h = min(h0, h_max)
    if not prun.unstable(h):
        lo = h
        while True:
            if lo >= h_max * (1 - 1e-12):
                return dict(h_stable=lo, h_unstable=math.nan, h_boundary=math.nan, status="stable to cap",
                            runs=prun.runs)
            hi = min(2.0 * lo, h_max)
            if prun.unstable(hi):
                break
            lo = hi
    else:
        hi = h
        while True:
            if hi <= h_min * (1 + 1e-12):
                return dict(h_stable=math.nan, h_unstable=hi, h_boundary=math.nan, status="unstable at floor",
                            runs=prun.runs)
            lo = max(0.5 * hi, h_min)
            if not prun.unstable(lo):
                break
            hi = lo
    br: list = []
    hb = measured_boundary(prun, lo, hi, rtol=rtol, judge=prun.judge, checked=True, bracket=br)
    lo, hi = br[0], br[1]
    return dict(h_stable=lo, h_unstable=hi, h_boundary=hb, status="bracketed", runs=prun.runs)


def press_stability_table(system: str, sweep: str | None = None, values=None, masters=PRESS_MASTERS,
                          orders=ORDERS, periods: float = 10.0, duration: float | None = None, rtol: float = 0.03,
                          cap: float = 64.0, fmu_dir=None, quick: bool = False, progress=None):
    """DataFrame: one row per (value, master, order) with the largest stable communication step of a press
    drive (:func:`press_boundary`) as the coupling parameter ``sweep`` (``INST.PARAM``) takes ``values``."""
    import pandas as pd

    from harness import load
    from harness.masters import master_class

    if system not in PRESS_STUDIES:
        raise ValueError(f"system {system!r} has no stability study: use one of "
                         f"{', '.join(sorted(PRESS_STUDIES))} or two_inertia")
    study = PRESS_STUDIES[system]
    sweep = sweep or study.sweep
    if values is None:
        values = study.quick_values if quick else study.values
        if sweep != study.sweep:
            raise ValueError(f"--sweep {sweep}: give --values (defaults exist only for {study.sweep})")
    values = [float(v) for v in values]
    masters = [master_class(m).name for m in masters]
    orders = [_order(q) for q in orders]
    base = _with_fmu_dir(load(system), fmu_dir)
    check_sweep(base, sweep, values)
    table = _parameter_table(base)
    h_default = float(base.experiment.step)
    rows = []
    for v in values:
        def p(name, _v=v):
            return _v if name == sweep else float(table[name][0])

        try:
            omega = float(study.omega(p))
        except (KeyError, ValueError, ZeroDivisionError, TypeError):
            omega = math.nan
        T = duration if duration is not None else study.duration * (0.5 if quick else 1.0)
        if math.isfinite(omega) and omega > 0:
            T = max(T, periods * 2.0 * math.pi / omega)
        ref_run = PressRun(base, "gauss-seidel", 0, {sweep: v}, duration=T)
        for master in masters:
            for order in orders:
                prun = PressRun(base, master, order, {sweep: v}, duration=T, reference=ref_run.ref)
                r = press_boundary(prun, rtol=rtol, cap=cap)
                rows.append(dict(system=system, sweep=sweep, value=v, master=master, order=order,
                                 h_default=h_default, omega_est=omega, duration=T, **r))
                if progress:
                    progress(f"{sweep} = {v:g}  {master:14s} order {order}: {r['status']:17s} "
                             f"h_stable {r['h_stable']:.4g} s, h_unstable {r['h_unstable']:.4g} s "
                             f"({r['runs']} runs)")
    return pd.DataFrame(rows)


def plot_press_map(table, path_stem: Path) -> list[Path]:
    """Largest stable step vs the swept parameter for every method, the default step dashed; <stem>.png/.svg.
    A method stable up to the cap is drawn at the cap with an upward triangle; unstable at the floor with a
    downward one."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    colors = {0: "tab:blue", 1: "tab:orange", 2: "tab:green"}
    styles = {"jacobi": "-", "gauss-seidel": "--", "jacobi-sampled": ":"}
    markers = {"jacobi": "o", "gauss-seidel": "s", "jacobi-sampled": "d"}
    for (master, order), g in table.groupby(["master", "order"], sort=False):
        g = g.sort_values("value")
        y = np.where(g["status"] == "bracketed", g["h_boundary"],
                     np.where(g["status"] == "stable to cap", g["h_stable"], g["h_unstable"]))
        ax.plot(g["value"], y, styles.get(master, "-"), marker=markers.get(master, "o"), color=colors[order],
                mfc="none", ms=6, label=f"{master}, order {order}")
        for st_, mk in (("stable to cap", "^"), ("unstable at floor", "v")):
            m = (g["status"] == st_).to_numpy()
            if m.any():
                ax.plot(g["value"][m], y[m], mk, color=colors[order], ms=9)
    hd = float(table["h_default"].iloc[0])
    ax.axhline(hd, color="k", ls="-.", lw=1.0, label=f"system default step {hd:g} s")
    ax.set_xscale("log")
    ax.set_yscale("log")
    from matplotlib.ticker import FormatStrFormatter, NullFormatter

    ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xticks(sorted(table["value"].unique()))
    ax.set_xlabel(str(table["sweep"].iloc[0]))
    ax.set_ylabel("largest stable communication step  H  [s]")
    ax.set_title(f"{table['system'].iloc[0]}: stability map (bisection on co-simulation runs)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best", ncol=2)
    fig.tight_layout()
    out = []
    for ext in ("png", "svg"):
        f = path_stem.with_suffix(f".{ext}")
        fig.savefig(f, dpi=150)
        out.append(f)
    plt.close(fig)
    return out


STUDIES = {"two_inertia": "the two-inertia coupling benchmark (systems/two_inertia.py)",
           **{k: v.doc for k, v in PRESS_STUDIES.items()}}


def register_stability(study_subparsers) -> None:
    """Add ``stability`` to an existing ``study`` sub-parser group."""
    p = study_subparsers.add_parser(
        "stability", help="coupling-stability map (theory and measured)",
        description="Largest stable macro step of each master (jacobi, gauss-seidel, jacobi-sampled for press "
                    "drives) with extrapolation orders 0, 1, 2 versus a coupling parameter.  two_inertia: "
                    "amplification-matrix theory and bisection on co-simulations; press drives (bed_drive, "
                    "spine_knife, feeder_gto52, proof_press): bisection on co-simulations against a reference.")
    p.add_argument("benchmark", choices=sorted(STUDIES), help="system")
    p.add_argument("--sweep", default=None,
                   help="swept parameter: two_inertia: inertia (J2/J1) or stiffness (c/c1); press drive: "
                        "INSTANCE.PARAMETER (default: the system's coupling parameter, e.g. fourbar.rocker_inertia)")
    p.add_argument("--values", type=float, nargs="+", default=None, help="values of the swept parameter")
    p.add_argument("--masters", nargs="+", default=None, help="press drives: masters (default: "
                                                               + " ".join(PRESS_MASTERS) + "; also jacobi-sampled)")
    p.add_argument("--orders", type=int, nargs="+", default=None, help="extrapolation orders (default 0 1 2)")
    p.add_argument("--quick", action="store_true",
                   help="fewer values, shorter runs, coarser bisection (press drives: 3 values, half the run length, rtol 6 %%; "
                        "two_inertia: theory only)")
    p.add_argument("--rtol", type=float, default=None, help="relative width of the final bracket")
    p.add_argument("--no-measure", action="store_true", help="two_inertia: theory only (no co-simulation runs)")
    p.add_argument("--periods", type=float, default=None,
                   help="run length in periods of the (estimated) stiffest coupled mode (two_inertia 60, press 10)")
    p.add_argument("--out", type=Path, default=Path("results"), help="output folder (default: results/)")
    p.set_defaults(func=stability_cli)


def register(subparsers) -> None:
    """Create the ``study`` command group and add ``stability`` to it."""
    p = subparsers.add_parser("study", help="numerical studies (stability, ...)",
                              description="Numerical studies of the co-simulation masters.")
    study = p.add_subparsers(dest="study", metavar="STUDY", required=True)
    register_stability(study)
    return study


def stability_cli(args) -> int:
    import sys

    progress = lambda s: print(s, file=sys.stderr)  # noqa: E731
    out = Path(args.out)
    if args.benchmark == "two_inertia":
        sweep = args.sweep or "inertia"
        if sweep not in SWEEPS:
            raise ValueError(f"--sweep {sweep!r} is not admissible for two_inertia: must be one of "
                             f"{', '.join(SWEEPS)}")
        table = stability_table(sweep=sweep, values=args.values, measure=not (args.no_measure or args.quick),
                                periods=args.periods or 60.0, rtol=args.rtol or 0.005, progress=progress)
        stem = out / f"stability_two_inertia_{sweep}"
        out.mkdir(parents=True, exist_ok=True)
        table.to_csv(stem.with_suffix(".csv"), index=False)
        figs = plot_stability_map(table, stem)
    else:
        quick = bool(args.quick)
        table = press_stability_table(args.benchmark, sweep=args.sweep, values=args.values,
                                      masters=args.masters or PRESS_MASTERS, orders=args.orders or ORDERS,
                                      periods=args.periods or (5.0 if quick else 10.0),
                                      rtol=args.rtol or (0.06 if quick else 0.03), quick=quick,
                                      progress=progress)
        sweep = str(table["sweep"].iloc[0])
        stem = out / f"stability_{args.benchmark}_{sweep.replace('.', '_')}"
        out.mkdir(parents=True, exist_ok=True)
        table.to_csv(stem.with_suffix(".csv"), index=False)
        figs = plot_press_map(table, stem)
    print(f"wrote {stem.with_suffix('.csv')}, {', '.join(str(f) for f in figs)}")
    return 0


__all__ = ["TwoInertia", "amplification_matrix", "monolithic_matrix", "spectral_radius", "stability_boundary",
           "measured_boundary", "is_unstable", "growth_ratio", "two_inertia_run", "hold_weights",
           "lagrange_weights", "held_input_map", "subsystem_maps", "stability_table", "plot_stability_map",
           "register", "register_stability", "STUDY_BASE", "PressStudy", "PRESS_STUDIES", "PressRun",
           "press_boundary", "press_stability_table", "plot_press_map", "deviation_ratio", "check_sweep"]
