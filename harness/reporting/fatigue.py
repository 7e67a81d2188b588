"""Fatigue and strength of a drive's parts from a load history: the formulas of
../shared/reference/press-engineering-facts.md ("Fatigue and strength"), used by
:mod:`harness.reporting.quantities` on the steady cycles.

* :func:`damage_equivalent`: a rainflow count (ASTM E1049, by the maintained ``rainflow`` package) of the
  load's history gives ranges S_i with counts n_i (half cycles 0.5); the damage-equivalent range per machine
  cycle for a Wohler (S-N) slope m is S_eq = (sum n_i S_i^m / N_c)^(1/m), N_c the machine cycles counted.
  A sine of range 2A once per cycle gives S_eq = 2A; m about 3 for welded steel, 5 or more for machined
  shafts (the default here), 8-10 for some bolts and gears.
* :func:`shear_stress`: a solid round shaft of diameter d carrying torque T: tau = 16 T / (pi d^3).
* :func:`belt_capacity`: the largest torque a flat or V-belt transmits on a pulley of radius r before it slips
  (Euler-Eytelwein): T = F_1 (1 - exp(-mu' beta)) r, F_1 the allowable tight-side force, beta the wrap angle
  on the pulley that slips first (the smaller wrap), mu' = mu / sin(groove half-angle) for a V-belt (mu for a
  flat belt); the slip margin is T over the peak belt torque on that pulley.
"""
from __future__ import annotations

import math

import numpy as np

DEFAULT_SLOPE = 5.0      # Wohler slope of machined shafts (facts: 5 or more)


def rainflow_ranges(x) -> tuple[np.ndarray, np.ndarray]:
    """(ranges, counts) of the rainflow count of the history ``x`` (counts 1 for full cycles, 0.5 for half)."""
    import rainflow

    pairs = rainflow.count_cycles(np.asarray(x, dtype=float))
    if not pairs:
        return np.empty(0), np.empty(0)
    ranges, counts = (np.array(v, dtype=float) for v in zip(*pairs))
    return ranges, counts


def damage_equivalent(x, n_cycles: float, slope: float = DEFAULT_SLOPE) -> float:
    """S_eq = (sum n_i S_i^m / N_c)^(1/m) of the history ``x`` over ``n_cycles`` machine cycles (module
    docstring)."""
    if not n_cycles > 0:
        raise ValueError(f"damage_equivalent: {n_cycles} machine cycles (need > 0)")
    if not slope > 0:
        raise ValueError(f"damage_equivalent: Wohler slope {slope} (need > 0)")
    ranges, counts = rainflow_ranges(x)
    if ranges.size == 0:
        return 0.0
    top = float(np.max(ranges))
    if top == 0.0:
        return 0.0
    # scaled by the largest range: no overflow for large loads and slopes
    return top * (float(np.sum(counts * (ranges / top) ** slope)) / n_cycles) ** (1.0 / slope)


def shear_stress(torque, diameter: float):
    """tau = 16 T / (pi d^3) [Pa] of a solid round shaft of ``diameter`` [m] carrying ``torque`` [N.m]."""
    if not diameter > 0:
        raise ValueError(f"shear_stress: shaft diameter {diameter} m (need > 0)")
    return 16.0 * np.asarray(torque, dtype=float) / (math.pi * diameter ** 3)


def belt_capacity(tight_force: float, mu: float, wrap: float, radius: float, groove_angle: float = 0.0) -> float:
    """T = F_1 (1 - exp(-mu' beta)) r [N.m] (module docstring): ``wrap`` beta [rad], ``groove_angle`` the
    V-groove's full angle [rad] (0: a flat belt), mu' = mu / sin(groove_angle / 2)."""
    mu_eff = mu / math.sin(0.5 * groove_angle) if groove_angle > 0 else mu
    return tight_force * (1.0 - math.exp(-mu_eff * wrap)) * radius


__all__ = ["DEFAULT_SLOPE", "rainflow_ranges", "damage_equivalent", "shear_stress", "belt_capacity"]
