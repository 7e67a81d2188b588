"""Tier 1: the equation layer in-process, against closed forms."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fmus.physics import integrate
from fmus.physics.elements import InertiaModel, InertiaParams, SpringInertiaModel, SpringInertiaParams


def test_substep_count_lands_exactly_on_the_step_end():
    assert integrate.substeps(1e-3, 1e-4) == 10
    assert integrate.substeps(1e-3, 3e-4) == 4
    assert integrate.substeps(1e-3, math.inf) == 1
    with pytest.raises(ValueError, match="positive"):
        integrate.substeps(0.0, 1.0)


@pytest.mark.parametrize("method", ["rk4", "implicit_midpoint"])
def test_integrators_reach_their_order_on_a_harmonic_oscillator(method):
    """Global error of one run over 2 s must fall by 2**p when the sub-step halves."""
    w = 3.0

    def f(t, x, u, t0):
        return np.array([x[1], -w * w * x[0]])

    step = getattr(integrate, method)
    errors = []
    for n in (20, 40, 80):
        x = step(f, 0.0, 2.0, np.array([1.0, 0.0]), (), 2.0 / n)
        errors.append(abs(x[0] - math.cos(w * 2.0)))
    order = math.log2(errors[0] / errors[1]), math.log2(errors[1] / errors[2])
    expected = 4 if method == "rk4" else 2
    assert min(order) == pytest.approx(expected, abs=0.3)


def test_inertia_with_ground_spring_oscillates_at_the_natural_frequency():
    p = InertiaParams(J=0.02, c_ground=50.0, phi0=0.1)
    m = InertiaModel(p)
    wn = math.sqrt(p.c_ground / p.J)
    x = m.initial_state([0.0])
    h = 1e-3
    for k in range(500):
        x = integrate.rk4(m.derivatives, k * h, h, x, [0.0], h / 10)
    t = 500 * h
    assert x[0] == pytest.approx(0.1 * math.cos(wn * t), abs=1e-9)
    assert m.energy(x) == pytest.approx(0.5 * p.c_ground * 0.1 ** 2, rel=1e-8)


def test_spring_inertia_torque_is_the_spring_law_and_energy_is_conserved_with_fixed_drive():
    p = SpringInertiaParams(J=0.01, c=200.0, d=0.0)
    m = SpringInertiaModel(p)
    u = [0.05, 0.0]
    x = m.initial_state(u)
    assert m.output(0.0, x, u)[0] == pytest.approx(-200.0 * 0.05)  # reaction on the driver
    e0 = m.energy(x, u)
    for k in range(1000):
        x = m.advance(k * 1e-4, 1e-4, x, u)
    assert m.energy(x, u) == pytest.approx(e0, rel=1e-9)
    # the inertia oscillates about the drive angle with the closed-form law
    wn = math.sqrt(p.c / p.J)
    assert x[0] == pytest.approx(0.05 * (1 - math.cos(wn * 0.1)), abs=1e-9)
