"""Clearance contact laws (fmus.physics.contact): impacts keep the published Hunt-Crossley-family laws, a
persistent contact gets a bounded damping, and the sub-step rule keeps RK4 inside its stability region.

Expected values come from the published laws written out here (Hunt-Crossley 3(1-e)/2, Lankarani-Nikravesh
3(1-e^2)/4, Flores et al. 8(1-e)/(5e), each over the approach speed v0), from closed forms derived in the
docstrings, and from scipy's solve_ivp; never from the module under test.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fmus.physics import contact

HC_FAMILY = [contact.HUNT_CROSSLEY, contact.LANKARANI_NIKRAVESH, contact.FLORES]


def published_c(law: int, e: float) -> float:
    """C = chi * v0 of the published laws."""
    return {contact.HUNT_CROSSLEY: 3.0 * (1.0 - e) / 2.0,
            contact.LANKARANI_NIKRAVESH: 3.0 * (1.0 - e * e) / 4.0,
            contact.FLORES: 8.0 * (1.0 - e) / (5.0 * e)}[law]


def published_force(law, e, v0, k, n, pen, pen_dot):
    """The textbook law F = k pen^n (1 + C pen_dot / v0), no pull."""
    return max(k * pen ** n * (1.0 + published_c(law, e) * pen_dot / v0), 0.0)


@pytest.mark.parametrize("law", HC_FAMILY)
@pytest.mark.parametrize("e", [0.05, 0.2, 0.5, 0.9, 0.99])
@pytest.mark.parametrize("n", [1.0, 1.5])
def test_a_free_impact_follows_the_published_law(law, e, n):
    """A free impact integrated with the textbook law: at every point of the compression and of the
    restitution the shared law gives the textbook force (its energy-calibrated v0 never engages, because
    the elastic energy of a free impact never exceeds the kinetic energy it came in with: v_E < v0)."""
    k, m, v0 = 2e5 if n == 1.0 else 5e9, 0.03, 0.015

    def rhs(t, z):
        return [z[1], -published_force(law, e, v0, k, n, max(z[0], 0.0), z[1]) / m]
    leave = lambda t, z: z[0]                                          # noqa: E731
    leave.terminal, leave.direction = True, -1
    period = 2 * math.pi * math.sqrt(m / k) if n == 1.0 else 1e-3
    sol = solve_ivp(rhs, (0.0, 20 * period), [0.0, v0], events=leave, rtol=1e-10, atol=1e-18,
                    max_step=period / 400, dense_output=True)
    ts = np.linspace(0.0, sol.t[-1], 400)[1:-1]
    pen, pen_dot = sol.sol(ts)
    assert np.all(pen > 0.0)
    f_max = max(published_force(law, e, v0, k, n, p, pd) for p, pd in zip(pen, pen_dot))
    for p, pd in zip(pen, pen_dot):
        assert math.sqrt(2 * k * p ** (n + 1) / ((n + 1) * m)) < v0          # elastic energy < m v0^2 / 2
        ref = published_force(law, e, v0, k, n, p, pd)
        got = -contact.contact_force(p, pd, 0.0, k, law, e, v0, m, n)
        assert got == pytest.approx(ref, rel=1e-12, abs=1e-13 * f_max)     # rounding only


@pytest.mark.parametrize("law", HC_FAMILY)
@pytest.mark.parametrize("n", [1.0, 1.5])
@pytest.mark.parametrize("v_impact", [0.0, 1e-9, 1e-6, 1e-5])
def test_persistent_contact_damping_is_bounded_whatever_the_approach_speed(law, n, v_impact):
    """A contact loaded to pen after a (near) zero-speed take-up.  Calibrated on the energy it holds,
    v0 = v_E = sqrt(2 k pen^(n+1) / ((n+1) m)), the damping coefficient is
        c = C k pen^n / v_E = C sqrt((n+1) k m pen^(n-1) / 2),
    independent of the approach speed (the textbook law would give C k pen^n / v_impact, unbounded)."""
    e, k, m = 0.2, (2e5 if n == 1.0 else 5e9), 0.03
    pen = 5e-6
    d = 1e-9                                                           # pen_dot: both signs, no clipping
    f_plus = -contact.contact_force(pen, d, 0.0, k, law, e, v_impact, m, n)
    f_minus = -contact.contact_force(pen, -d, 0.0, k, law, e, v_impact, m, n)
    c = (f_plus - f_minus) / (2 * d)
    expected = published_c(law, e) * math.sqrt((n + 1) * k * m * pen ** (n - 1) / 2)
    assert c == pytest.approx(expected, rel=1e-6)
    assert 0.5 * (f_plus + f_minus) == pytest.approx(k * pen ** n, rel=1e-12)   # the elastic part is untouched
    # damping ratio at the linearised stiffness n k pen^(n-1): C/2 * sqrt((n+1)/(2n)), e.g. 3.2 for Flores
    zeta = c / (2 * math.sqrt(n * k * pen ** (n - 1) * m))
    assert zeta == pytest.approx(published_c(law, e) / 2 * math.sqrt((n + 1) / (2 * n)), rel=1e-6)


@pytest.mark.parametrize("law", sorted(contact.LAWS))
@pytest.mark.parametrize("e", [0.02, 0.2, 0.7])
def test_damping_rate_never_exceeds_the_bound_that_sizes_the_sub_step(law, e):
    """Over random states (penetration, its rate, approach speed) the damping rate (dF/dpen_dot)/m stays
    below damping_per_frequency times the linearised contact frequency sqrt(n k pen^(n-1)/m); the bound
    itself is the closed form 2 zeta (Kelvin-Voigt) or C sqrt((n+1)/(2n))."""
    rng = np.random.default_rng(7)
    for n in ((1.0,) if law == contact.KELVIN_VOIGT else (1.0, 1.5)):
        k, m = (2e5 if n == 1.0 else 5e9), 0.03
        bound = contact.damping_per_frequency(law, e, n)
        if law == contact.KELVIN_VOIGT:
            assert bound == pytest.approx(2 * contact.kelvin_voigt_zeta(e), rel=1e-15)
        else:
            assert bound == pytest.approx(published_c(law, e) * math.sqrt((n + 1) / (2 * n)), rel=1e-12)
        for _ in range(300):
            pen = 10 ** rng.uniform(-10, -4)
            v_imp = rng.choice([0.0, 10 ** rng.uniform(-9, 0)])
            pd = 10 ** rng.uniform(-9, -1) * rng.choice([-1.0, 1.0])
            dd = 0.1 * abs(pd)                                         # F is linear in pen_dot
            f1 = -contact.contact_force(pen, pd + dd, 0.0, k, law, e, v_imp, m, n)
            f0 = -contact.contact_force(pen, pd - dd, 0.0, k, law, e, v_imp, m, n)
            if f1 == 0.0 or f0 == 0.0:                                 # clipped: no damping there
                continue
            rate = (f1 - f0) / (2 * dd) / m
            assert rate <= bound * math.sqrt(n * k * pen ** (n - 1) / m) * (1 + 1e-6)


@pytest.mark.parametrize("law", sorted(contact.LAWS))
@pytest.mark.parametrize("e", [0.01, 0.05, 0.2, 0.9])
def test_max_substep_keeps_rk4_stable_for_the_bounded_damping(law, e):
    """RK4's amplification on the real axis, R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24, has |R| < 1 for
    -2.785 < z < 0: the sub-step times the largest damping rate stays inside, and the stiffness rule
    0.1/omega is kept where the damping allows it."""
    omega = 1e4
    dt = contact.max_substep(omega, law, e)
    z = -contact.damping_per_frequency(law, e) * omega * dt
    assert abs(1 + z + z ** 2 / 2 + z ** 3 / 6 + z ** 4 / 24) < 1.0 and z > -2.785
    assert dt <= 0.1 / omega
    if contact.damping_per_frequency(law, e) <= 10.0:
        assert dt == 0.1 / omega


@pytest.mark.parametrize("law", sorted(contact.LAWS))
@pytest.mark.parametrize("e", [0.2, 0.5, 0.9, 1.0])
def test_a_free_impact_on_a_wall_only_pushes_and_ends_within_half_a_period(law, e):
    """Issue 31: a mass m striking a wall through each law the FMUs use (linear, n = 1; x = penetration).
    The force never pulls the mass into the wall; the contact ends where the law's force k x + c x'
    (Kelvin-Voigt) or k x (1 + chi x') returns to zero, with e < 1 before the half-period pi/omega of the
    undamped contact, omega = sqrt(k/m), with e = 1 exactly at it (Kelvin-Voigt; the Hunt-Crossley family's
    force k x (1 + chi x') stays positive down to x = 0 and its contact lasts longer than pi/omega at e = 0.2:
    1.035 Hunt-Crossley, 1.015 Lankarani-Nikravesh, 1.367 Flores, measured);
    the Kelvin-Voigt exit speed is e v0 (its no-pull calibration; the Hunt-Crossley family's e is the
    published approximation, not checked here)."""
    k, m, v0 = 2e5, 0.03, 0.5
    omega = math.sqrt(k / m)
    c = contact.kelvin_voigt_damping(k, m, e)
    chi = 0.0 if law == contact.KELVIN_VOIGT else contact.hysteresis_factor(law, e, v0)

    def law_force(z):                                # the law before clipping, pushing the mass out
        return k * z[0] + c * z[1] if law == contact.KELVIN_VOIGT else k * z[0] * (1.0 + chi * z[1])

    def rhs(t, z):
        return [z[1], contact.contact_force(z[0], z[1], 0.0, k, law, e, v0, m) / m]
    ends = lambda t, z: law_force(z)                                  # noqa: E731
    ends.terminal, ends.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 2 * math.pi / omega), [0.0, v0], events=ends, rtol=1e-11, atol=1e-16,
                    max_step=0.002 / omega, dense_output=True)
    t_end = float(sol.t_events[0][0])
    push = np.array([-contact.contact_force(x, xd, 0.0, k, law, e, v0, m)
                     for x, xd in sol.sol(np.linspace(0.0, t_end, 2000)).T])
    assert push[:-1].min() >= 0.0 and abs(push[-1]) <= 1e-12 * push.max()   # the end: rounding only
    x, xd = sol.sol(t_end)
    if e < 1.0 and law == contact.KELVIN_VOIGT:
        # the force, not the penetration, ends the contact: x > 0 there, and just after it the law is clipped
        assert x > 0.0 and t_end < math.pi / omega
        assert contact.contact_force(x + xd * 1e-9 / omega, xd, 0.0, k, law, e, v0, m) == 0.0
    elif e == 1.0:
        assert t_end == pytest.approx(math.pi / omega, rel=1e-7)
    if law == contact.KELVIN_VOIGT:
        assert -xd == pytest.approx(e * v0, rel=1e-6)
