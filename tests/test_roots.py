"""fmus.physics.roots.brentq gives SciPy's brentq's floats, bit for bit (the bed drive's parameters come from it)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import optimize

from fmus.physics import fourbar, roots

FUNCTIONS = [
    lambda x: x ** 3 - 2 * x - 5,
    lambda x: math.cos(x) - x,
    lambda x: math.exp(x) - 3.0,
    lambda x: math.atan(x - 0.3) * 1e-6,
    lambda x: (x - 0.7) ** 7,                    # flat root: many bisections
    lambda x: math.tanh(50 * (x - 0.123456789)),
]


def outcome(brentq, f, a, b, xtol, rtol):
    """The root, or "no convergence" (SciPy's too stops after 100 iterations on a flat root)."""
    try:
        return brentq(f, a, b, xtol=xtol, rtol=rtol)
    except RuntimeError:
        return "no convergence"


@pytest.mark.parametrize("k", range(len(FUNCTIONS)))
def test_same_root_as_scipy_on_many_brackets(k):
    f = FUNCTIONS[k]
    rng = np.random.default_rng(k)
    compared = 0
    for _ in range(200):
        a, b = sorted(rng.uniform(-4.0, 4.0, 2))
        if not f(a) * f(b) < 0:
            continue
        for xtol, rtol in ((2e-12, 8.881784197001252e-16), (1e-15, 1e-15), (1e-6, 1e-10)):
            assert outcome(roots.brentq, f, a, b, xtol, rtol) == outcome(optimize.brentq, f, a, b, xtol, rtol)
            compared += 1
    assert compared > 30


def test_same_extreme_rocker_positions_as_scipy():
    for b, f_, r, branch in ((1.91579, 2.10526, 2.25263, -1), (1.91579, 2.10526, 2.25263, 1), (3.0, 3.5, 2.0, 1)):
        v = lambda x: float(fourbar.kinematics(x, 1.0, b, f_, r, branch)[1])  # noqa: E731
        grid = np.linspace(0.0, 2 * np.pi, 721)
        for lo, hi in zip(grid[:-1], grid[1:]):
            if v(lo) * v(hi) < 0:
                assert roots.brentq(v, lo, hi, xtol=1e-15, rtol=1e-15) == optimize.brentq(v, lo, hi, xtol=1e-15,
                                                                                           rtol=1e-15)


def test_refuses_what_scipy_refuses():
    with pytest.raises(ValueError, match="opposite signs"):
        roots.brentq(lambda x: x * x + 1, -1.0, 1.0)
    with pytest.raises(ValueError, match="xtol"):
        roots.brentq(lambda x: x, -1.0, 1.0, xtol=0.0)
    with pytest.raises(RuntimeError, match="no convergence"):
        roots.brentq(lambda x: (x - 0.7) ** 7, -4.0, 4.0, xtol=1e-300, rtol=1e-15, maxiter=3)
