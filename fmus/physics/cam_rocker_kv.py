"""Level 2 of the cam-corrected rocker with the Kelvin-Voigt contact law (fmus.physics.cam_rocker, ``fidelity``
2, ``contact_law`` Kelvin-Voigt): exponential Rosenbrock steps (order 3) of at most EXP_STEP_PHASE/omega_c in the
contact mode of each step's start, and contact events located by bisection inside the step.

A mixin of :class:`fmus.physics.cam_rocker.CamRockerModel`: its methods read the model's parameters ``p``,
kinematics and pin geometry (``_kin``, ``_pin_stiffness``, ``lever``) and contact memory.
"""
from __future__ import annotations

import math

import numpy as np

from . import contact, groove, integrate

EXP_STEP_PHASE = 0.5         # level 2, Kelvin-Voigt: exponential step x contact frequency (rad)
EVENT_TOLERANCE = 1e-10      # [s] width to which a contact event is located inside a step
MAX_EVENTS_PER_STEP = 64     # beyond it (a chattering contact) the steps go on without locating


class KelvinVoigtPin:
    """The Kelvin-Voigt play at the stone pin or roller, integrated with exponential steps (module docstring)."""

    def _kv_coefficients(self, phi: float, w: float) -> tuple:
        """(G, G' w, k R^2, c R^2, k R clearance/2) of the Kelvin-Voigt play at crank angle phi, then the rates
        in time at crank speed w of all but the first (G's is G' w itself): the contact torque on a wall
        ``mode`` is k R^2 (G - gamma) + c R^2 (G' w - omega) - mode k R clearance/2.  The values are those of
        :meth:`_kin` and :meth:`_pin_stiffness` (the same operations); the rates come from G'' and the lever's
        rate R' in closed form, with
        dk/dR = -2 k^2 R / stiffness (the transmission in series with the contact) and
        c R^2 = 2 zeta sqrt(k J) |R|."""
        p, ns = self.p, self.m
        g, g1, g2 = self.kinematics(phi)
        if p.mechanism == 0:
            rho, rho1 = groove.stone_radius_rate_scalar(phi, g, g1, p.lambda1, p.lambda2, self.branch, ns)
            R, r_t = p.crank_radius * rho, p.crank_radius * rho1 * w
        else:
            R, r_t = p.follower_arm, 0.0
        k, m = self._pin_stiffness(R)
        c = contact.kelvin_voigt_damping(k, m, p.restitution, ns, self._kv_zeta)
        kr2, cr2 = k * R * R, c * R * R
        k_r = -2.0 * k * k * R / p.stiffness
        if ns.scalar:
            cr2_r = 0.5 * cr2 * k_r / k + (cr2 / R if R != 0.0 else 0.0)
        else:
            cr2_r = 0.5 * cr2 * k_r / k + ns.where(R != 0.0, cr2 / ns.where(R != 0.0, R, 1.0), 0.0)
        return (g, g1 * w, kr2, cr2, 0.5 * k * R * p.clearance,
                g2 * w * w, (k_r * R * R + 2.0 * k * R) * r_t, cr2_r * r_t, 0.5 * p.clearance * (k_r * R + k) * r_t)

    def _kv_mode(self, gamma, omega, co) -> tuple[float, float]:
        """(side, mode) of the Kelvin-Voigt play at one instant (``co``: _kv_coefficients): side = the wall
        touched (geometric, +1/-1, 0), mode = the wall that pushes (side, unless the no-pull force is clipped
        to 0 there: then 0)."""
        g, gw, kr2, cr2, krh, _, _, _, _ = co
        qr = kr2 * (g - gamma)                      # k R q, with q = R (G - gamma)
        m = self.m
        if not m.scalar:
            side = m.where(qr > krh, 1.0, m.where(qr < -krh, -1.0, 0.0))
            torque = qr - side * krh + cr2 * (gw - omega)
            return side, m.where(side * torque > 0.0, side, 0.0)
        if qr > krh:
            side = 1.0
        elif qr < -krh:
            side = -1.0
        else:
            return 0.0, 0.0
        torque = qr - side * krh + cr2 * (gw - omega)   # R times the wall's force k pen + c pen_dot, signed
        return side, (side if side * torque > 0.0 else 0.0)

    def _kv_acceleration(self, gamma, omega, tau, co, mode) -> float:
        """Rocker acceleration [rad/s2] with the Kelvin-Voigt play held in ``mode`` (0 free, +1/-1 pushing on
        that wall; the force law extended linearly beyond the mode's bounds, so that the step's Jacobian and
        time derivative are smooth)."""
        m = self.m
        if m.scalar and mode == 0.0:
            return tau / self.p.rocker_inertia
        g, gw, kr2, cr2, krh, _, _, _, _ = co
        pushed = (kr2 * (g - gamma) + cr2 * (gw - omega) - mode * krh + tau) / self.p.rocker_inertia
        return pushed if m.scalar else m.where(mode == 0.0, tau / self.p.rocker_inertia, pushed)

    def _kv_jet(self, gamma, omega, tau, co, mode):
        """(acceleration, its derivatives in gamma, omega and time) of :meth:`_kv_acceleration` at one instant,
        in closed form (exprb32_pair's ``jet``); None where the lever's rate is not finite (the stone at the end
        of its groove's reach): the step then takes differences."""
        a0 = self._kv_acceleration(gamma, omega, tau, co, mode)
        m = self.m
        if m.scalar and mode == 0.0:
            return a0, 0.0, 0.0, 0.0
        J = self.p.rocker_inertia
        g, gw, kr2, cr2, _, gw_t, kr2_t, cr2_t, krh_t = co
        a_t = (kr2_t * (g - gamma) + kr2 * gw + cr2_t * (gw - omega) + cr2 * gw_t - mode * krh_t) / J
        if m.scalar:
            return (a0, -kr2 / J, -cr2 / J, a_t) if math.isfinite(a_t) else None
        free = mode == 0.0      # a batch: the free variants' rates, and a_t's finiteness in the jet's mask
        return (a0, m.where(free, 0.0, -kr2 / J), m.where(free, 0.0, -cr2 / J), m.where(free, 0.0, a_t))

    def _advance_kelvin_voigt(self, t0, h, x, u):
        """Level 2 with the Kelvin-Voigt law: exponential Rosenbrock steps (integrate.exprb32_pair) of
        (gamma, omega) in the contact mode of the step's start, at most EXP_STEP_PHASE / omega_c long (the
        contact mode exact on its linearisation); when the mode (free, clipped or pushing on a wall) or the
        wall touched differs at the step's end, the change is located by bisection of the step to
        EVENT_TOLERANCE, the step is taken up to it in the old mode and the contact memory is updated there
        (onset: impacts + 1, v_impact = the penetration rate; separation: flag 0).  A change that comes and
        goes within one step is not seen (as at RK4's sub-step boundaries)."""
        phi0, w, tau = u[0], u[1], u[2]
        at_angle = {}       # once per crank angle (a dict: functools.cache would cost ~2 us to make, each step)

        def coefficients(t):
            phi = phi0 + w * (t - t0)
            co = at_angle.get(phi)
            if co is None:
                co = at_angle[phi] = self._kv_coefficients(phi, w)
            return co

        def step(t, dt, gamma, omega, mode):
            def acc(tt, g, om):
                return self._kv_acceleration(g, om, tau, coefficients(tt), mode)
            jet = self._kv_jet(gamma, omega, tau, coefficients(t), mode)
            return integrate.exprb32_pair(acc, t, dt, gamma, omega, jet)

        def onset_speed(t, gamma, omega):
            g, gw = coefficients(t)[:2]
            return abs(self.lever(phi0 + w * (t - t0), g) * (gw - omega))

        x = np.array(x, dtype=float)
        gamma, omega = float(x[0]), float(x[1])
        n = integrate.substeps(h, self._exp_step)
        events = 0
        t, i = t0, 0
        while i < n:
            t_end = t0 + (i + 1) * h / n if i < n - 1 else t0 + h
            if t_end - t <= 1e-3 * EVENT_TOLERANCE:  # a change located at the sub-step's very end: none of it left
                t, i = t_end, i + 1
                continue
            side, mode = self._kv_mode(gamma, omega, coefficients(t))
            g1, o1 = step(t, t_end - t, gamma, omega, mode)
            side1, mode1 = self._kv_mode(g1, o1, coefficients(t_end))
            if (side1, mode1) == (side, mode) or events >= MAX_EVENTS_PER_STEP:
                gamma, omega, t, i = g1, o1, t_end, i + 1
                if side1 == 0.0:
                    x[4] = 0.0
                elif x[4] == 0.0:       # (only after MAX_EVENTS_PER_STEP): an onset seen at the boundary
                    x[4], x[3], x[2] = 1.0, x[3] + 1.0, onset_speed(t, gamma, omega)
                continue
            lo, hi = 0.0, t_end - t        # the change lies in (lo, hi]: bisection on the step length
            while hi - lo > EVENT_TOLERANCE:
                mid = 0.5 * (lo + hi)
                gm, om = step(t, mid, gamma, omega, mode)
                if self._kv_mode(gm, om, coefficients(t + mid)) == (side, mode):
                    lo = mid
                else:
                    hi = mid
            gamma, omega = step(t, hi, gamma, omega, mode)
            t += hi
            events += 1
            side1, _ = self._kv_mode(gamma, omega, coefficients(t))
            if side1 == 0.0:
                x[4] = 0.0
            elif side == 0.0:              # onset on a wall
                x[4], x[3], x[2] = 1.0, x[3] + 1.0, onset_speed(t, gamma, omega)
            elif side1 != side:            # straight through the play within the located instant
                x[3] += 1.0
        x[0], x[1] = gamma, omega
        return x
