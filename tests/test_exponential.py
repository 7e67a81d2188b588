"""The exponential Rosenbrock integrator (fmus.physics.integrate.phi_matrices_2x2, exprb32_pair) and FourBar's
fidelity 1, which uses it instead of RK4 sub-steps sized for the coupler mode (issue 21)."""
import math

import numpy as np
import pytest
import scipy.linalg

from fmus.physics.fourbar import FourBarModel, FourBarParams
from fmus.physics.integrate import exprb32_pair, phi_matrices_2x2, substeps


@pytest.mark.parametrize("seed", range(4))
def test_phi_matrices_match_the_augmented_matrix_exponential(seed):
    """A f + B g + C k is the exact increment of y' = J y + f + g t + k t^2/2 (scipy's expm of the augmented
    5x5 matrix), for singular, tiny, stiff, oscillatory and overdamped J."""
    rng = np.random.default_rng(seed)
    cases = [np.zeros((2, 2)), np.array([[0.0, 1.0], [-5e6, -200.0]]), np.array([[0.0, 1.0], [-1e4, -200.0]]),
             np.array([[0.0, 1.0], [0.0, 0.0]])] + [rng.normal(size=(2, 2)) * 10 ** rng.uniform(-3, 4)
                                                   for _ in range(40)]
    for J in cases:
        for h in (1e-9, 1e-5, 2e-4, 1e-2):
            if np.max(np.abs(h * np.linalg.eigvals(J))) > 20:   # expm's own error grows there
                continue
            f, g, k = rng.normal(size=(3, 2))
            aug = np.zeros((5, 5))
            aug[:2, :2], aug[:2, 2], aug[:2, 3], aug[:2, 4], aug[3, 2], aug[4, 3] = J, f, g, k, 1.0, 1.0
            exact = (scipy.linalg.expm(h * aug) @ np.array([0.0, 0.0, 1.0, 0.0, 0.0]))[:2]
            a, b, c = (np.array(m).reshape(2, 2) for m in phi_matrices_2x2(*J.ravel(), h))
            got = a @ f + b @ g + c @ k
            assert np.max(np.abs(got - exact)) <= 1e-11 * np.max(np.abs(exact)) + 1e-300, (J, h)


def _integrate(acc, t_end, n, q, v, jet=None):
    """n exprb32 steps; ``jet(t, q, v)`` the rates' derivatives in closed form (None: differences)."""
    dt = t_end / n
    for i in range(n):
        q, v = exprb32_pair(acc, i * dt, dt, q, v, jet and jet(i * dt, q, v))
    return q, v


def test_exprb32_is_exact_on_a_stiff_linear_oscillator_with_quadratic_forcing():
    """q'' = -k q - c q' + f0 + f1 t + f2 t^2/2 with k = 1e8 (omega dt = 200 at dt = 0.02): one step lands on the
    closed form (scipy expm of the augmented matrix), where an explicit method would explode."""
    k, c, f0, f1, f2 = 1e8, 50.0, 3.0, -2.0, 7.0

    def acc(t, q, v):
        return -k * q - c * v + f0 + f1 * t + 0.5 * f2 * t * t
    aug = np.zeros((5, 5))
    aug[:2, :2] = [[0.0, 1.0], [-k, -c]]
    aug[1, 2:] = f0, f1, f2
    aug[3, 2] = aug[4, 3] = 1.0
    exact = scipy.linalg.expm(0.02 * aug) @ np.array([1e-3, -0.5, 1.0, 0.0, 0.0])
    q, v = exprb32_pair(acc, 0.0, 0.02, 1e-3, -0.5)
    assert q == pytest.approx(exact[0], rel=1e-6, abs=1e-12)
    assert v == pytest.approx(exact[1], rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("closed", [False, True], ids=["differences", "jet"])
def test_exprb32_reaches_order_3_on_a_nonlinear_closed_form(closed):
    """q'' = 2 q^3, q(0) = 1, q'(0) = 1 has q = 1/(1 - t): halving the step divides the error by 2^3, with the
    rates' derivatives by differences and in closed form (``jet``)."""
    def acc(t, q, v):
        return 2.0 * q ** 3

    def jet(t, q, v):
        return 2.0 * q ** 3, 6.0 * q * q, 0.0, 0.0
    errors = []
    for n in (20, 40, 80, 160):
        q, v = _integrate(acc, 0.5, n, 1.0, 1.0, jet if closed else None)
        errors.append(abs(q - 2.0) + abs(v - 4.0))
    orders = [math.log2(errors[i] / errors[i + 1]) for i in range(3)]
    assert all(2.8 < p < 3.3 for p in orders), orders


@pytest.mark.parametrize("closed", [False, True], ids=["differences", "jet"])
def test_exprb32_reaches_order_3_on_a_forced_oscillator_with_a_closed_form(closed):
    """q'' = -w0^2 q + sin(W t) from rest: q = (sin(W t) - (W / w0) sin(w0 t)) / (w0^2 - W^2)."""
    w0, W = 30.0, 7.0

    def acc(t, q, v):
        return -w0 * w0 * q + math.sin(W * t)

    def jet(t, q, v):
        return acc(t, q, v), -w0 * w0, 0.0, W * math.cos(W * t)

    def exact(t):
        return ((math.sin(W * t) - W / w0 * math.sin(w0 * t)) / (w0 * w0 - W * W),
                (W * math.cos(W * t) - W * math.cos(w0 * t)) / (w0 * w0 - W * W))
    errors = []
    for n in (25, 50, 100, 200):
        q, v = _integrate(acc, 1.0, n, 0.0, 0.0, jet if closed else None)
        qe, ve = exact(1.0)
        errors.append(abs(q - qe) + abs(v - ve) / w0)
    orders = [math.log2(errors[i] / errors[i + 1]) for i in range(3)]
    assert all(2.7 < p < 3.4 for p in orders), orders


BED_FOURBAR = dict(crank_length=0.1, coupler_length=0.191579, frame_length=0.210526, rocker_length=0.225263,
                   fidelity=1, coupler_stiffness=5e7, coupler_damping=2e3, rocker_inertia=0.5, clearance=0.0)


@pytest.mark.parametrize("params, h, tol", [
    (BED_FOURBAR, 2e-4, 3e-9),                                                    # bed_drive's four-bar and step
    (dict(fidelity=1, coupler_stiffness=1e6, coupler_damping=5.0), 1e-4, 3e-7),   # seed-000 rocker, light damping
])
def test_fourbar_fidelity1_matches_the_former_rk4_substeps(params, h, tol):
    """Over a crank turn under a varying load, the exponential steps (one per communication step here) stay
    within ``tol`` rad of the rocker angle of RK4 on 20 times finer sub-steps than the former ones (0.1/omega),
    and so does the former integrator.  Measured: bed_drive's four-bar 1.45e-9 rad (2.2e-10 m at the rocker
    pin; the former RK4 4.8e-11 rad), the lightly damped seed-000 rocker 1.46e-7 rad (former 2.3e-9 rad)."""
    model = FourBarModel(FourBarParams(**params))
    n_old = substeps(h, model.max_substep)
    assert n_old > 1                               # the former integrator did need sub-steps here
    w = 2 * math.pi
    u = [0.3, w, 0.0]
    x_new = x_old = x_fine = model.initial_state(u)
    worst_new = worst_old = 0.0
    for k in range(int(round(1.0 / h))):
        t = k * h
        u = [0.3 + w * t, w, -20.0 * (1.0 + math.sin(3 * w * t))]
        x_new = model.advance(t, h, x_new, u)
        x_old = model._elastic_steps(t, h, n_old, x_old, u)
        x_fine = model._elastic_steps(t, h, 20 * n_old, x_fine, u)
        worst_new = max(worst_new, abs(x_new[0] - x_fine[0]))
        worst_old = max(worst_old, abs(x_old[0] - x_fine[0]))
    assert worst_new < tol
    assert worst_old < tol


PARALLELOGRAM_BELT = dict(crank_length=0.1, coupler_length=0.3, frame_length=0.3, rocker_length=0.1, fidelity=1,
                          coupler_stiffness=5e6, coupler_damping=50.0, belt_stiffness=3e3, belt_damping=4.0)


@pytest.mark.parametrize("params", [BED_FOURBAR, dict(BED_FOURBAR, friction_ratio=0.1), PARALLELOGRAM_BELT,
                                    dict(fidelity=1, coupler_stiffness=1e6, coupler_damping=5.0)])
def test_fourbar_jet_is_the_derivative_of_the_acceleration(params):
    """FourBar 1's closed-form rates (_acc_jet_at: d/dpsi, d/dw, d/dt of the rocker's acceleration through the
    coupler's stretch and arms) against central differences of _acc_at over a crank turn, off the rigid
    motion: within 1e-6 (the differences' own error), the acceleration itself bit for bit."""
    m = FourBarModel(FourBarParams(**params))
    wc, tau = 6.0, -20.0
    for phi in np.linspace(0.0, 2 * math.pi, 181):
        psi, w = m.rigid(phi, wc)
        psi, w = psi + 1e-5, 1.1 * w

        def acc(dphi=0.0, dpsi=0.0, dw=0.0):
            return m._acc_at(phi + dphi, wc, tau, psi + dpsi, w + dw)
        a0, a_psi, a_w, a_t = m._acc_jet_at(phi, wc, tau, psi, w)
        assert a0 == acc()
        assert a_psi == pytest.approx((acc(dpsi=1e-6) - acc(dpsi=-1e-6)) / 2e-6, rel=1e-6)
        assert a_w == pytest.approx((acc(dw=1e-3) - acc(dw=-1e-3)) / 2e-3, rel=1e-6)
        assert a_t == pytest.approx(wc * (acc(dphi=1e-6) - acc(dphi=-1e-6)) / 2e-6, rel=1e-6, abs=1e-6 * abs(a_psi))


@pytest.mark.parametrize("seed", range(3))
def test_closed_form_phi_matrices_agree_with_the_series_on_every_branch(seed):
    """The closed form (complex pair, real pair; phi_k from the Taylor series below SERIES_RADIUS and from e^z
    above) against the scaled-and-squared series it falls back to, on matrices built around each switch:
    eigenvalue moduli across SERIES_RADIUS, gaps just above EIGEN_GAP, stiff and overdamped modes."""
    from fmus.physics import integrate
    from fmus.physics.integrate import phi_matrices_2x2_series

    rng = np.random.default_rng(seed)
    branches = {"complex-series": 0, "complex-exp": 0, "real-series": 0, "real-exp": 0}
    for _ in range(400):
        radius = integrate.SERIES_RADIUS * 10 ** rng.uniform(-1.5, 1.3)
        if rng.random() < 0.5:    # complex pair alpha +- i beta, beta at least half the gap bound
            beta = radius * rng.uniform(integrate.EIGEN_GAP, 1.0)
            alpha = rng.choice([-1.0, 1.0]) * math.sqrt(max(radius ** 2 - beta ** 2, 0.0))
            mu = (complex(alpha, beta), complex(alpha, -beta))
        else:
            mu1 = radius * rng.choice([-1.0, 1.0])
            mu = (mu1, mu1 - rng.choice([-1.0, 1.0]) * max(1.0, radius) * rng.uniform(1.01, 3.0) * integrate.EIGEN_GAP)
        if max(abs(m) for m in mu) > 30:
            continue
        h = 10 ** rng.uniform(-6, -2)
        tr, det = (mu[0] + mu[1]).real / h, (mu[0] * mu[1]).real / h ** 2
        J = (0.0, 1.0, -det, tr)   # companion form, as exprb32_pair builds it
        kind = ("complex" if isinstance(mu[0], complex) else "real") + (
            "-series" if max(abs(m) for m in mu) < integrate.SERIES_RADIUS else "-exp")
        branches[kind] += 1
        closed, series = phi_matrices_2x2(*J, h), phi_matrices_2x2_series(*J, h)
        for a, b in zip(closed, series):
            assert np.max(np.abs(np.subtract(a, b))) <= 1e-12 * np.max(np.abs(b)), (J, h, kind)
    assert min(branches.values()) > 10, branches


def test_last_call_memo_returns_the_previous_result_only_for_the_same_arguments():
    """physics.base.last_call (the outputs' memo): the same arguments twice call the function once; other
    arguments, and then the first ones again, call it anew (one entry, no stale result)."""
    from fmus.physics.base import last_call

    calls = []

    def f(a, b):
        calls.append((a, b))
        return a * b + len(calls)

    g = last_call(f)
    assert g(2.0, 3.0) == g(2.0, 3.0) == 7.0 and len(calls) == 1
    assert g(2.0, 4.0) == 10.0 and g(2.0, 3.0) == 9.0 and len(calls) == 3
