"""Level 3 of the cam-corrected rocker (fmus.physics.cam_rocker, ``fidelity`` 3, slotted rocker only): seed 000's
two clearances.  The stone is a body of its own that slides along the slot; the conrod eye and the roller in
the groove are two joints with their own plays, contact laws and reduced masses (the equations are in
fmus.physics.cam_rocker's module docstring).

A mixin of :class:`fmus.physics.cam_rocker.CamRockerModel`: its methods read the model's parameters ``p``,
kinematics, groove branch and contact memory.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from . import contact, groove, integrate


class SlidingStone:
    """The stone with two jointed clearances: its frame, joint forces, accelerations, sub-steps and Jacobian."""

    def _frame(self, phi: float, w: float) -> tuple:
        """What level 3's joints take from the crank angle alone (a pure function of phi and w, so
        ``_advance_two_clearances`` evaluates it once per distinct sub-step time): the crank pin A and its
        velocity terms, the profile point B_g and its unit normal n_g."""
        p = self.p
        r = p.crank_radius
        cp, sp = math.cos(phi), math.sin(phi)
        g, g1, _ = self.kinematics(phi)
        rk, rk1, _ = groove.stone_scalar(phi, g, g1, p.lambda1, p.lambda2, self.branch)
        cg, sg = math.cos(g), math.sin(g)
        tx, ty = rk1 * cg - rk * g1 * sg, rk1 * sg + rk * g1 * cg       # profile tangent dB_g/dphi / r
        tn = math.hypot(tx, ty)
        nx, ny = (-ty / tn, tx / tn) if tn > 0.0 else (-sg, cg)
        return r * (cp - p.lambda1), r * sp, r * w * sp, r * w * cp, r * rk * cg, r * rk * sg, nx, ny

    def _joints(self, phi: float, w: float, gamma: float, omega: float, rho: float, rho_rate: float, x,
                frame=None):
        """The two joints of level 3 at crank angle phi: (F_p, F_g, (Fx, Fy), e_c, (d_p, d_p rate), (d_g, d_g rate)).

        F_p, F_g are the contact laws' signed forces along the conrod direction e_c (from crank pin A to B)
        and the profile normal n_g; (Fx, Fy) their sum on the stone.  ``frame`` is ``_frame(phi, w)`` when
        the caller has it."""
        p = self.p
        ax, ay, rws, rwc, gx, gy, nx, ny = frame or self._frame(phi, w)
        c, s = math.cos(gamma), math.sin(gamma)
        bx, by = rho * c, rho * s
        vbx, vby = rho_rate * c - rho * omega * s, rho_rate * s + rho * omega * c
        dx, dy = bx - ax, by - ay
        dist = math.hypot(dx, dy)
        ex, ey = dx / dist, dy / dist
        d_p = dist - p.lambda2 * p.crank_radius
        d_p_rate = ex * (vbx + rws) + ey * (vby - rwc)
        d_g = (bx - gx) * nx + (by - gy) * ny
        d_g_rate = vbx * nx + vby * ny                                   # B_g moves along the profile
        j_t = p.rocker_inertia + p.stone_mass * rho * rho

        def reduced_mass(ux, uy):
            eu, en = ux * c + uy * s, -ux * s + uy * c
            return 1.0 / (eu * eu / p.stone_mass + en * en * rho * rho / j_t)

        k_p = 1.0 / (1.0 / p.contact_stiffness + rho * rho / p.stiffness)
        f_p = contact.contact_force(d_p, d_p_rate, p.clearance, k_p, p.contact_law, p.restitution,
                                    x[2] if x[4] != 0.0 else abs(d_p_rate), reduced_mass(ex, ey), p.contact_exponent)
        f_g = contact.contact_force(d_g, d_g_rate, p.groove_clearance, p.groove_stiffness, p.contact_law,
                                    p.restitution, x[7] if x[9] != 0.0 else abs(d_g_rate), reduced_mass(nx, ny),
                                    p.contact_exponent)
        return f_p, f_g, (f_p * ex + f_g * nx, f_p * ey + f_g * ny), (ex, ey), (d_p, d_p_rate), (d_g, d_g_rate)

    def _accelerations(self, phi, w, tau_load, gamma, omega, rho, rho_rate, x, frame=None) -> tuple[float, float]:
        """(d omega/dt, d2 rho_s/dt2) of level 3."""
        p = self.p
        _, _, (fx, fy), _, _, _ = self._joints(phi, w, gamma, omega, rho, rho_rate, x, frame)
        c, s = math.cos(gamma), math.sin(gamma)
        f_n, f_u = -fx * s + fy * c, fx * c + fy * s
        m = p.stone_mass
        return ((tau_load + rho * f_n - 2.0 * m * rho * rho_rate * omega) / (p.rocker_inertia + m * rho * rho),
                f_u / m + rho * omega * omega)

    def _update_joints(self, phi: float, w: float, x: np.ndarray, frame=None) -> None:
        _, _, _, _, (d_p, d_p_rate), (d_g, d_g_rate) = self._joints(phi, w, x[0], x[1], x[5], x[6], x, frame)
        for (d, rate, play), (v, n, flag) in (((d_p, d_p_rate, self.p.clearance), (2, 3, 4)),
                                              ((d_g, d_g_rate, self.p.groove_clearance), (7, 8, 9))):
            pen, pen_rate, side = contact.penetration(d, rate, play)
            if side == 0.0:
                x[flag] = 0.0
            elif x[flag] == 0.0:
                x[flag], x[n], x[v] = 1.0, x[n] + 1.0, abs(pen_rate)

    def _advance_two_clearances(self, t0, h, x, u):
        n = integrate.substeps(h, self.max_substep)
        dt = h / n
        phi0, w, tau = u[0], u[1], u[2]
        # _frame per crank angle, once: RK4's mid stages share one, a sub-step's end is the next start
        frame = functools.cache(lambda phi: self._frame(phi, w))

        def acc(t, gamma, omega, rho, rho_rate):
            phi = phi0 + w * (t - t0)
            return self._accelerations(phi, w, tau, gamma, omega, rho, rho_rate, x, frame(phi))

        for i in range(n):
            t = t0 + i * dt
            phi = phi0 + w * (t - t0)
            self._update_joints(phi, w, x, frame(phi))
            x[0], x[1], x[5], x[6] = integrate.rk4_two(acc, t, dt, x[0], x[1], x[5], x[6])
        phi = phi0 + w * h
        self._update_joints(phi, w, x, frame(phi))
        return x

    # -- level 2, Kelvin-Voigt contact: exponential steps between located contact events ---------------------

    def _two_clearance_jacobian(self, x, u, D) -> None:
        """Rows crank.tau, pin_force and groove_force of level 3's D (the states' outputs have slope 0, the
        pressure angle's row is set by the caller).  With the stone's pose (gamma, omega, rho_s, its rate) held:
        * the conrod eye: A = r (cos phi - lambda1, sin phi) moves at A' = r (-sin, cos), so d_p' = -e.A' and
          e' = -(A' - (e.A') e)/|B - A|; the eye's rate e.(v_B - v_A) moves with e' and v_A' = -w A, and with
          crank.w through -e.A'; the reduced mass 1/((e.u)^2/m_s + (rho_s e.n)^2/J_t) with e;
        * the groove: B_g moves along its own tangent, so d_g' = (B - B_g).n_g' and (d_g rate)' = v_B.n_g'
          (no crank.w in either); n_g = (-t_y, t_x)/|t| turns with the profile tangent
          t = rho' u + rho G' n, t' = (rho'' - rho G'^2) u + (2 rho' G' + rho G'') n (groove.stone_slopes_scalar's
          rho''), n_g' = (I - n_g n_g^T)(-t'_y, t'_x)/|t|; its reduced mass with n_g;
        * each force's slopes in its play, rate and reduced mass: :meth:`_force_slopes`;
        * crank.tau = -F_p r (cos(phi) e_y - sin(phi) e_x)."""
        p = self.p
        phi, w = float(u[0]), float(u[1])
        r, ms = p.crank_radius, p.stone_mass
        gamma, omega, rho, rho_rate = float(x[0]), float(x[1]), float(x[5]), float(x[6])
        frame = self._frame(phi, w)
        ax, ay, rws, rwc, gx, gy, nx, ny = frame
        c, s_ = math.cos(gamma), math.sin(gamma)
        bx, by = rho * c, rho * s_
        vbx, vby = rho_rate * c - rho * omega * s_, rho_rate * s_ + rho * omega * c
        jt = p.rocker_inertia + ms * rho * rho

        def mass_and_slope(ex, ey, ex1, ey1):
            eu, en = ex * c + ey * s_, -ex * s_ + ey * c
            eu1, en1 = ex1 * c + ey1 * s_, -ex1 * s_ + ey1 * c
            m = 1.0 / (eu * eu / ms + en * en * rho * rho / jt)
            return m, -m * m * (2.0 * eu * eu1 / ms + 2.0 * en * en1 * rho * rho / jt)

        # the conrod eye
        cp, sp = math.cos(phi), math.sin(phi)
        dx, dy = bx - ax, by - ay
        dist = math.hypot(dx, dy)
        ex, ey = dx / dist, dy / dist
        a1x, a1y = -r * sp, r * cp                     # dA/dphi
        ea1 = ex * a1x + ey * a1y
        ex1, ey1 = -(a1x - ea1 * ex) / dist, -(a1y - ea1 * ey) / dist
        rvx, rvy = vbx + rws, vby - rwc                # v_B - v_A
        d_p = dist - p.lambda2 * r
        rate_p = ex * rvx + ey * rvy
        rate_p_phi = ex1 * rvx + ey1 * rvy + ex * (r * w * cp) + ey * (r * w * sp)   # -e.v_A', v_A' = -w A_rel
        rate_p_w = -ea1
        k_p = 1.0 / (1.0 / p.contact_stiffness + rho * rho / p.stiffness)
        m_p, m_p_phi = mass_and_slope(ex, ey, ex1, ey1)
        F_p, Fp_d, Fp_rate, Fp_m = self._force_slopes(d_p, rate_p, p.clearance, k_p, m_p, x[2], x[4])
        dF_p = (Fp_d * (-ea1) + Fp_rate * rate_p_phi + Fp_m * m_p_phi, Fp_rate * rate_p_w)
        lever = r * (cp * ey - sp * ex)
        lever_phi = r * (-sp * ey - cp * ex + cp * ey1 - sp * ex1)
        D[0, :2] = (-(dF_p[0] * lever + F_p * lever_phi), -dF_p[1] * lever)
        if F_p != 0.0:
            D[5, :2] = (math.copysign(1.0, F_p) * dF_p[0], math.copysign(1.0, F_p) * dF_p[1])
        # the roller in the groove
        g, g1, g2 = self.kinematics(phi)
        rk, rk1, _ = groove.stone_scalar(phi, g, g1, p.lambda1, p.lambda2, self.branch)
        rk2, _ = groove.stone_slopes_scalar(phi, g, g1, g2, p.lambda1, p.lambda2, self.branch)
        cg, sg = math.cos(g), math.sin(g)
        tx, ty = rk1 * cg - rk * g1 * sg, rk1 * sg + rk * g1 * cg
        tn = math.hypot(tx, ty)
        if tn > 0.0:
            tu, tnn = rk2 - rk * g1 * g1, 2.0 * rk1 * g1 + rk * g2          # t' in the slot's (u, n) basis
            t1x, t1y = tu * cg - tnn * sg, tu * sg + tnn * cg
            wx, wy = -t1y / tn, t1x / tn
            wn = wx * nx + wy * ny
            nx1, ny1 = wx - wn * nx, wy - wn * ny
        else:                                          # the fallback normal (-sin G, cos G) turns with G
            nx1, ny1 = -cg * g1, -sg * g1
        d_g = (bx - gx) * nx + (by - gy) * ny
        rate_g = vbx * nx + vby * ny
        m_g, m_g_phi = mass_and_slope(nx, ny, nx1, ny1)
        F_g, Fg_d, Fg_rate, Fg_m = self._force_slopes(d_g, rate_g, p.groove_clearance, p.groove_stiffness, m_g,
                                                      x[7], x[9])
        dF_g = (Fg_d * ((bx - gx) * nx1 + (by - gy) * ny1) + Fg_rate * (vbx * nx1 + vby * ny1)
                + Fg_m * m_g_phi)
        if F_g != 0.0:
            D[8, 0] = math.copysign(1.0, F_g) * dF_g
