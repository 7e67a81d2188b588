"""Knife drive for book-block spine processing (seed 003, Poliudov & Knysh; spec knife_drive.md).

Equations (source numbering):
  (1)/(2) feed force per cut  F_T(t) = A1 t + A2 t^2 + A3 t^3 + A4 t^4, 0 <= t <= T_cut, with A from four
          equally spaced samples F_T1..F_T4 at t_k = k*T_cut/4 (closed form, fit_poly);
  (3)-(6) entry ramp  K1 = min(tau/T_entry, 1), T_entry = B/(V_B tan beta), tau = time since the block
          arrived (spec's recommended reading of the off-by-one in (4), A6); F = P(t)*K1 in the cut, 0 in
          the pause (A4); exit ramp K2 neglected as in the source (A7);
  (7)-(9) M_dist = 0.5*R*F_T*(cos beta + f sin beta sin(gamma + alpha3))  (magnitudes added, A8; the 0.5
          and the constant arm R are kept as printed, A9);
  (11)    J_red*dphi'' + b_red*dphi' + C_red*dphi = M_dist(t), dphi(0) = dphi'(0) = 0 (A12);
  §2.8    p = sqrt(C_red/J_red), n = p*mu_red/(4 pi), b_red = 2 n J_red;
  §2.9    C_red = G pi d^4/(16 l): two identical shafts (G pi d^4/(32 l) each) in parallel;
  (12)    J_red*omega^2/2 = integral of M_dist over the cut, crank angles [phi_s, pi], K1 = t_K/T_entry held
          (1 on the stable section).  How it is read: eq. (12b) as printed substitutes t = phi/omega, i.e.
          it counts the polynomial's time from crank angle 0 (reduced_inertia_12b).  Eq. (1) counts it from
          the start of the cut (F_T(0) = 0: no constant term, the knife meets the block at t = 0) and fits it
          on [0, T_cut] only; with phi_s > 0 the printed form evaluates the quartic on [phi_s, pi]/omega,
          outside the fitted interval (for phi_s = pi/2: [T_cut, 2 T_cut]), where it falls steeply, and a
          kinetic energy comes out negative (J_red = -0.0357 kg.m2 for the KnifeDesign defaults).  So (12)
          is read with the cut's own time, t = (phi - phi_s)/omega, which turns each (pi^k - phi_s^k) of
          (12b) into (pi - phi_s)^k (reduced_inertia_cut; 3.98e-3 kg.m2 for the defaults).  Both are the
          same when the crank angle is counted from the start of the cut (phi_s = 0), so the printed form
          is this one with the seed's angle origin at the cut's start; the symbol clash of its lower limit
          phi_1 with the knife's angle phi_1 (spec A13, A16) points the same way.  The design check and
          systems/spine_knife.py use reduced_inertia_cut; reduced_inertia_12b is kept to show the printed form.
Time base (A15, §2.13): one plunge per crank revolution, cut over crank angles [phi_s, pi]:
  omega = (pi - phi_s)/T_cut, T_cycle = 2 pi/omega, T_pause = T_cycle - T_cut, N_B = 1/T_cycle.
Resonance (A14): Hz on both sides, f_n = p/(2 pi) against harmonics i*N_B; near-resonant when
  |f_n/N_B - i| <= band for the nearest i >= 1 (band = fraction of the plunge frequency, default 0.1).

KnifeLoad model: port knife motion IN (crank angle phi, speed).  The cut is tied to the crank angle:
  theta = phi mod 2 pi, cutting while phi_s <= theta <= pi, local cut time t = T_cut*(theta - phi_s)/(pi - phi_s)
  (so the force follows crank position; at the nominal speed omega = (pi - phi_s)/T_cut it is exactly
  eq. (1) in time).  knife.tau = -M_dist: the reaction of the cutting on the driving crank, resisting
  forward (positive) rotation (A11); the model assumes forward rotation and does not flip the sign with w.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import variants
from .base import Model, ParameterError, Params, param

# inverse of V[k][j] = k**j (k, j = 1..4): A_j = h**-j * sum_k VINV[j][k] F_k   (spec §2.2)
VINV = ((4.0, -3.0, 4.0 / 3.0, -0.25),
        (-13.0 / 3.0, 19.0 / 4.0, -7.0 / 3.0, 11.0 / 24.0),
        (1.5, -2.0, 7.0 / 6.0, -0.25),
        (-1.0 / 6.0, 0.25, -1.0 / 6.0, 1.0 / 24.0))


def fit_poly(F, T_cut: float) -> tuple[float, float, float, float]:
    """Coefficients A1..A4 of eq. (1) through samples F_T1..F_T4 at t_k = k*T_cut/4 (eq. 2, closed form)."""
    if not T_cut > 0.0:
        raise ValueError(f"T_cut = {T_cut!r} s must be > 0")
    h = T_cut / 4.0
    return tuple(sum(VINV[j][k] * F[k] for k in range(4)) / h ** (j + 1) for j in range(4))  # type: ignore


def poly_force(t: float, A) -> float:
    """Eq. (1)."""
    return t * (A[0] + t * (A[1] + t * (A[2] + t * A[3])))


def entry_time(B: float, V_B: float, beta: float) -> float:
    """Eq. (3): T_entry = B/(V_B tan beta)."""
    return B / (V_B * math.tan(beta))


def ramp(tau: float, T_entry: float) -> float:
    """Entry ramp K1 (eq. 5 as recommended): 0 before the block, tau/T_entry on entry, 1 when stable."""
    if tau <= 0.0:
        return 0.0
    return min(tau / T_entry, 1.0)


def feed_force(tau: float, A, T_cut: float, T_pause: float, T_entry: float) -> float:
    """Eq. (6) as a piecewise time series: tau = time since the first plunge into the block."""
    if tau < 0.0:
        return 0.0
    cycle = T_cut + T_pause
    t = tau - math.floor(tau / cycle) * cycle
    return poly_force(t, A) * ramp(tau, T_entry) if t <= T_cut else 0.0


def k_geo(beta: float, gamma: float, alpha3: float, f: float) -> float:
    """Eqs. (7)-(8): F_dist/F_T = cos beta + f sin beta sin(gamma + alpha3)."""
    return math.cos(beta) + f * math.sin(beta) * math.sin(gamma + alpha3)


def dist_moment(F_T: float, R: float, kg: float) -> float:
    """Eq. (9): M_dist = 0.5 R k_geo F_T."""
    return 0.5 * R * kg * F_T


def shaft_stiffness(G: float, d: float, l: float, shafts: int = 2) -> float:
    """Torsional stiffness of ``shafts`` identical solid shafts in parallel: shafts*G*pi*d^4/(32 l).
    shafts = 2 is the source's C_red = G pi d^4/(16 l) (§2.9)."""
    return shafts * G * math.pi * d ** 4 / (32.0 * l)


def reduced_inertia_12b(A, omega, phi_s, R, beta, gamma, alpha3, f, K1: float = 1.0) -> float:
    """Eq. (12b) as printed (t = phi/omega from crank angle 0; K1 = t_K1/T_entry held, 1 when stable)."""
    w = omega
    poly = (A[0] / (2 * w) * (math.pi ** 2 - phi_s ** 2) + A[1] / (3 * w ** 2) * (math.pi ** 3 - phi_s ** 3)
            + A[2] / (4 * w ** 3) * (math.pi ** 4 - phi_s ** 4) + A[3] / (5 * w ** 4) * (math.pi ** 5 - phi_s ** 5))
    return R * K1 / w ** 2 * k_geo(beta, gamma, alpha3, f) * poly


def reduced_inertia_cut(A, omega, phi_s, R, beta, gamma, alpha3, f, K1: float = 1.0) -> float:
    """Energy definition (12a) with polynomial time from the start of the cut, t = (phi - phi_s)/omega:
    J = (2/omega^2) * 0.5 R k_geo K1 * omega * sum_j A_j T^(j+1)/(j+1), T = (pi - phi_s)/omega."""
    T = (math.pi - phi_s) / omega
    energy = 0.5 * R * k_geo(beta, gamma, alpha3, f) * K1 * omega * sum(A[j] * T ** (j + 2) / (j + 2) for j in range(4))
    return 2.0 * energy / omega ** 2


def natural_frequency(C_red: float, J_red: float) -> float:
    """p = sqrt(C_red/J_red) [rad/s]."""
    return math.sqrt(C_red / J_red)


def damping_coefficient(p: float, mu_red: float) -> float:
    """n = p mu_red/(4 pi) [1/s] (§2.8)."""
    return p * mu_red / (4.0 * math.pi)


def time_base(T_cut: float, phi_s: float) -> dict[str, float]:
    """§2.13 (A15): omega, T_cycle, T_pause, N_B for one plunge per revolution, cut over [phi_s, pi]."""
    omega = (math.pi - phi_s) / T_cut
    T_cycle = 2.0 * math.pi / omega
    return {"omega": omega, "T_cycle": T_cycle, "T_pause": T_cycle - T_cut, "N_B": 1.0 / T_cycle}


def resonance_check(f_n: float, N_B: float, band: float = 0.1) -> dict:
    """Nearest harmonic i*N_B of the plunge frequency to f_n and whether it lies within band*N_B."""
    r = f_n / N_B
    i = max(1, round(r))
    detune = abs(r - i)
    return {"harmonic": i, "detuning": detune, "near_resonance": detune <= band}


def response(J_red: float, C_red: float, mu_red: float, moment, t_end: float, max_step: float | None = None,
             t_eval=None):
    """Eq. (11) from rest with scipy solve_ivp; ``moment(t)`` is M_dist.  Returns (t, dphi, dphi_dot)."""
    from scipy.integrate import solve_ivp   # here: every FMU bundles this module, most never call it

    p = natural_frequency(C_red, J_red)
    n = damping_coefficient(p, mu_red)
    if max_step is None:
        max_step = 2.0 * math.pi / p / 40.0

    def rhs(t, y):
        return (y[1], moment(t) / J_red - 2.0 * n * y[1] - p * p * y[0])

    sol = solve_ivp(rhs, (0.0, t_end), (0.0, 0.0), method="RK45", max_step=max_step, rtol=1e-8, atol=1e-12,
                    t_eval=t_eval)
    return sol.t, sol.y[0], sol.y[1]


@dataclass(frozen=True)
class KnifeDesign:
    """Inputs of the design check (defaults: the KnifeLoad defaults plus the shafts of systems/spine_knife.py,
    two steel shafts d = 50 mm, l = 0.6 m in parallel; the seed gives none)."""
    F_T1: float = 150.0
    F_T2: float = 260.0
    F_T3: float = 280.0
    F_T4: float = 120.0
    T_cut: float = 0.025
    phi_s: float = math.pi / 2
    beta: float = 0.35
    gamma: float = 0.5
    alpha3: float = 0.35
    f: float = 0.3
    R: float = 0.05
    B: float = 0.03
    V_B: float = 0.5
    G: float = 8.1e10
    d: float = 0.05
    l: float = 0.6
    mu_red: float = 0.5
    J_red: float | None = None          # None: from the load energy (jred_from)
    jred_from: str = "cut"              # "cut" (t from the start of the cut) or "12b" (as printed)
    band: float = 0.1


def design_report(d: KnifeDesign, with_response: bool = True) -> dict:
    """The seed's design rules (P1-P4) checked for a design; returns values and pass/fail per rule."""
    A = fit_poly((d.F_T1, d.F_T2, d.F_T3, d.F_T4), d.T_cut)
    tb = time_base(d.T_cut, d.phi_s)
    args = (A, tb["omega"], d.phi_s, d.R, d.beta, d.gamma, d.alpha3, d.f)
    J_12b, J_cut = reduced_inertia_12b(*args), reduced_inertia_cut(*args)
    J = d.J_red if d.J_red is not None else (J_cut if d.jred_from == "cut" else J_12b)
    C = shaft_stiffness(d.G, d.d, d.l)
    out = {"A": A, **tb, "T_entry": entry_time(d.B, d.V_B, d.beta), "J_red_12b": J_12b, "J_red_cut": J_cut,
           "J_red": J, "C_red": C, "ratio": tb["T_pause"] / d.T_cut}
    rules = [("T_pause/T_cut > 2.5", out["ratio"], out["ratio"] > 2.5)]
    if J > 0.0:
        p = natural_frequency(C, J)
        f_n = p / (2.0 * math.pi)
        res = resonance_check(f_n, tb["N_B"], d.band)
        out.update(p=p, f_n=f_n, n=damping_coefficient(p, d.mu_red), resonance=res)
        rules.append(("f_n in 800..1200 Hz", f_n, 800.0 <= f_n <= 1200.0))
        rules.append((f"no harmonic i*N_B within {d.band:g}*N_B of f_n", res["detuning"], not res["near_resonance"]))
        if with_response:
            kg = k_geo(d.beta, d.gamma, d.alpha3, d.f)
            Te = out["T_entry"]
            T_end = Te + 3.0 * tb["T_cycle"]
            _, dphi, _ = response(J, C, d.mu_red,
                                  lambda t: dist_moment(feed_force(t, A, d.T_cut, tb["T_pause"], Te), d.R, kg), T_end)
            out["max_dphi"] = float(np.max(np.abs(dphi)))
    else:
        out.update(p=float("nan"), f_n=float("nan"))
        rules.append(("J_red > 0", J, False))
    rules.append(("C_red > 2e4 N.m/rad", C, C > 2.0e4))
    out["rules"] = rules
    out["ok"] = all(r[2] for r in rules)
    return out


# ---------------------------------------------------------------------------------------------- component
@dataclass(frozen=True)
class KnifeLoadParams(Params):
    T_cut: float = param(0.025, "s", "cutting period; time base of the force samples (t_k = k T_cut/4)",
                         low=0.0, low_open=True)
    F_T1: float = param(150.0, "N", "feed force sample at t = T_cut/4 (stable cutting)")
    F_T2: float = param(260.0, "N", "feed force sample at t = T_cut/2")
    F_T3: float = param(280.0, "N", "feed force sample at t = 3 T_cut/4")
    F_T4: float = param(120.0, "N", "feed force sample at t = T_cut (force drops to 0 after the cut)")
    beta: float = param(0.35, "rad", "angle knife edge - block travel direction", low=0.0, low_open=True,
                        high=math.pi / 2)
    gamma: float = param(0.5, "rad", "angle knife trajectory plane - block spine", low=0.0, high=math.pi / 2)
    alpha3: float = param(0.35, "rad", "knife sharpening angle", low=0.0, high=math.pi / 2)
    f: float = param(0.3, "1", "friction coefficient block - knife", low=0.0)
    R: float = param(0.05, "m", "crank length = lever arm of the disturbance force", low=0.0, low_open=True)
    B: float = param(0.03, "m", "block (spine) width crossed by the knife edge", low=0.0, low_open=True)
    V_B: float = param(0.5, "m/s", "block travel speed", low=0.0, low_open=True)
    phi_s: float = param(math.pi / 2, "rad", "crank angle at the start of the cut (cut over [phi_s, pi])",
                         low=0.0, high=math.pi)
    t_block: float = param(0.0, "s", "time at which the block reaches the knife (start of the entry ramp)")
    fidelity: int = param(1, "", "0: stable cutting only (K1 = 1); 1: with the entry ramp K1 of eq. (6)",
                          choices=(0, 1))

    def check(self) -> None:
        if not self.phi_s < math.pi:
            raise ParameterError("phi_s", self.phi_s, "must be < pi rad (the cut ends at pi)")


class KnifeLoadModel(Model):
    Params = KnifeLoadParams
    inputs = ("knife.phi", "knife.w")
    outputs = ("knife.tau", "feed_force", "cutting")
    states = ()

    def __init__(self, p: KnifeLoadParams):
        super().__init__(p)
        self.A = fit_poly((p.F_T1, p.F_T2, p.F_T3, p.F_T4), p.T_cut)
        self.T_entry = entry_time(p.B, p.V_B, p.beta)
        self.kg = k_geo(p.beta, p.gamma, p.alpha3, p.f)
        self.scale = p.T_cut / (math.pi - p.phi_s)

    def force(self, t: float, phi: float) -> tuple[float, float]:
        """(feed force, cutting flag) at time t and crank angle phi."""
        p = self.p
        if not self.m.scalar:
            return self._forces(t, phi)
        theta = phi % (2.0 * math.pi)
        if not (p.phi_s <= theta <= math.pi):
            return 0.0, 0.0
        K1 = ramp(t - p.t_block, self.T_entry) if p.fidelity >= 1 else 1.0
        if K1 == 0.0:
            return 0.0, 0.0
        return poly_force((theta - p.phi_s) * self.scale, self.A) * K1, 1.0

    def _forces(self, t, phi):
        """:meth:`force` of a batch of variants (arrays): the same branches as masks."""
        p, m = self.p, self.m
        theta = phi % (2.0 * math.pi)
        inside = (p.phi_s <= theta) & (theta <= math.pi)
        if p.fidelity >= 1:
            tau = t - p.t_block
            K1 = m.where(tau <= 0.0, 0.0, m.minimum(tau / self.T_entry, 1.0))
        else:
            K1 = 1.0
        cutting = inside & (K1 != 0.0)
        F = poly_force((theta - p.phi_s) * self.scale, self.A) * K1
        return m.where(cutting, F, 0.0), m.where(cutting, 1.0, 0.0)

    def output(self, t, x, u):
        F, cut = self.force(t, u[0])
        return (-dist_moment(F, self.p.R, self.kg), F, cut)

    def output_jacobian(self, t, x, u):
        """dF/dphi = K1 * scale * F_T'(tau) inside the cut (the polynomial of eq. (1) differentiated), 0 outside;
        the load does not depend on the speed."""
        p = self.p
        theta = u[0] % (2.0 * math.pi)
        K1 = ramp(t - p.t_block, self.T_entry) if p.fidelity >= 1 else 1.0
        dF = 0.0
        if p.phi_s <= theta <= math.pi and K1 != 0.0:
            tau, A = (theta - p.phi_s) * self.scale, self.A
            dF = (A[0] + tau * (2.0 * A[1] + tau * (3.0 * A[2] + tau * 4.0 * A[3]))) * self.scale * K1
        return np.array([[-dist_moment(dF, p.R, self.kg), 0.0], [dF, 0.0], [0.0, 0.0]])


def dist_force(F_T: float, kg: float) -> float:
    """Eqs. (7)-(8): F_dist = F' + F_fr = F_T k_geo (magnitudes added, A8)."""
    return F_T * kg


class KnifeLoadBatch(variants.Vectorised):
    """Variants of :class:`KnifeLoadModel` together: the cutting force law on arrays (it has no state)."""
    attributes = ("T_entry", "kg", "scale")

    def __init__(self, models):
        super().__init__(models)
        self.v.A = tuple(np.array([m.A[j] for m in self.models]) for j in range(4))

    def output(self, t, X, U, rows=None):
        return self.v.m.stack(self.v.output(t, X, U))

    def advance(self, t0, h, X, U):
        return X


KnifeLoadModel.Batch = KnifeLoadBatch
