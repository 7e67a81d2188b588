"""``synth groove --seed-figures DIR``: seed 001's statements on the combined mechanism against ours.

The seed (Kolomiets & Stetsiv) states, without the numbers behind them:
* the rocker-slider stage (K1)-(K5) turns a harmonic carriage law into a rocker acceleration "of the type"
  eps = C[1 - (2k)^n], n a power coefficient of the result (its Fig. 4: K0, 0000, 1,3, 1,5);
* the synthesised LCSM against the base four-bar for law 1,5 (its Fig. 7: kulisa angle and acceleration);
* the method gives "a cycle pause of up to 80 deg", "dimensions smaller by 14-31 %" and "energy intensity
  smaller by 12-38 %" than existing devices.
This module computes each from the equations in fmus.physics.groove, draws Figs. 2, 4 and 7, and prints them
beside the seed's words.  What the seed does not give (the stage's lengths, the compared devices, what "size"
and "energy intensity" measure) is chosen here and said so in the output.

Laws 1,3 and 1,5 are catalogue laws of Tir & Senyk [10] that the seed names but does not define
(fmus.physics.laws.SEED_UNDEFINED): they are not drawn or computed.  Where the seed uses them, the laws it does
define take their place on the charts, named as what they are: K0 (harmonic, as 1,3 and 1,5 are) and C0
(cycloidal); the power-type form is drawn only as the seed uses it, the type of the rocker's law, with the n
fitted to that law ('power' in fmus.physics.laws).
"""
from __future__ import annotations

import copy
import math

import numpy as np

from fmus.physics import groove
from fmus.physics.laws import SEED_UNDEFINED, TWO_PI, get_law

FIG4_SEED = ("K0", "0000", "1,3", "1,5")
"""The carriage laws of the seed's Fig. 4, curves 1-4; those in SEED_UNDEFINED are named, not drawn."""
LAWS = ("K0", "C0")
"""The laws the seed defines that its statements on the combined mechanism are computed for (its Fig. 7 uses
1,5, which it does not define): K0 of the harmonic group and C0 of the cycloidal one."""


def drawable(names) -> tuple[list, list]:
    """(the laws we can build, the seed's names we cannot: SEED_UNDEFINED)."""
    return [n for n in names if n not in SEED_UNDEFINED], [n for n in names if n in SEED_UNDEFINED]


def fit_power(law) -> tuple[float, float]:
    """(n, worst misfit) of the rocker acceleration c(k)/c(0) against 1 - (2k)^n on the first half 0 <= k <= 1/2
    (least squares in n by golden section on [0.2, 8]); the misfit is in units of c(0)."""
    k = np.linspace(0.0, 0.5, 2001)
    c = law(k)[2]
    y = c / c[0]

    def err(n):
        return float(np.sum((y - (1.0 - (2.0 * k) ** n)) ** 2))

    lo, hi = 0.2, 8.0
    r = (math.sqrt(5.0) - 1.0) / 2.0
    for _ in range(80):
        m1, m2 = hi - r * (hi - lo), lo + r * (hi - lo)
        if err(m1) < err(m2):
            hi = m2
        else:
            lo = m1
    n = 0.5 * (lo + hi)
    return n, float(np.max(np.abs(y - (1.0 - (2.0 * k) ** n))))


def motion(kl: groove.KulisaLaw, n: int = 7200):
    """Kulisa angle and its first two derivatives in phi over one turn from the forward stroke's start."""
    phi = kl.cycle.phi_start + np.linspace(0.0, TWO_PI, n, endpoint=False)
    g, g1, g2 = kl(phi)
    return phi, g, g1, g2


def base_motion(a, lam2: float, phi):
    """The base four-bar's kulisa angle and its derivatives (central differences of the closed form)."""
    h = 1e-5
    g = np.unwrap(groove.base_fourbar_angle(phi, a.lambda1, lam2, a.lambda3, a.assembly))
    gp = np.unwrap(groove.base_fourbar_angle(phi + h, a.lambda1, lam2, a.lambda3, a.assembly))
    gm = np.unwrap(groove.base_fourbar_angle(phi - h, a.lambda1, lam2, a.lambda3, a.assembly))
    gp = g + np.remainder(gp - g + math.pi, TWO_PI) - math.pi
    gm = g + np.remainder(gm - g + math.pi, TWO_PI) - math.pi
    return g, (gp - gm) / (2 * h), (gp - 2 * g + gm) / h ** 2


def energy_figures(g1, g2) -> dict:
    """Per unit inertia J of the driven link and unit crank speed: the peak acceleration |eps|/w^2, the peak
    inertia power |w eps|/w^3 and the work the drive puts into the link's inertia in one turn, the integral
    of max(0, g' g'') dphi (the kinetic energy it must raise twice a cycle, lost where not recovered)."""
    p = g1 * g2
    return dict(peak_eps=float(np.max(np.abs(g2))), peak_power=float(np.max(np.abs(p))),
                work=float(np.sum(np.maximum(p, 0.0)) * TWO_PI / len(p)))


def footprint(a, lam2: float, B) -> float:
    """Area (in r^2) of the box holding the crank circle, the pivots and the stone pin's path B (frame F2)."""
    xs = np.concatenate([B[:, 0], [-a.lambda1 - 1.0, -a.lambda1 + 1.0, 0.0]])
    ys = np.concatenate([B[:, 1], [-1.0, 1.0, 0.0]])
    return float((xs.max() - xs.min()) * (ys.max() - ys.min()))


def compare_with_base(a, law: str, lam2: float, dwell_deg: float) -> dict:
    """The combined LCSM (carriage law ``law`` through the stage) against the base four-bar of the same
    lambda1, lambda2, lambda3: energy figures and footprints, and the reductions in per cent (positive = less)."""
    lf = get_law(law)
    kl, _ = groove.combined_kulisa_law(a.lambda1, lam2, a.lambda3, lf, lf, math.radians(dwell_deg), a.assembly)
    phi, g, g1, g2 = motion(kl)
    p = groove.synthesize(phi, g, g1, g2, a.lambda1, lam2, groove.base_branch(a.lambda1, lam2, a.lambda3, a.assembly))
    bg, bg1, bg2 = base_motion(a, lam2, phi)
    ours, base = energy_figures(g1, g2), energy_figures(bg1, bg2)
    bB = a.lambda3 * np.stack([np.cos(bg), np.sin(bg)], axis=1)
    out = dict(lambda2=lam2, dwell_deg=dwell_deg, swing_deg=math.degrees(kl.swing))
    for k in ours:
        out[f"{k}_reduction_pct"] = 100.0 * (1.0 - ours[k] / base[k])
    out["footprint_reduction_pct"] = 100.0 * (1.0 - footprint(a, lam2, p.B) / footprint(a, lam2, bB))
    out["rho_max_over_lambda3"] = float(np.max(p.rho) / a.lambda3)
    return out


def seed_interval(a, law: str, dwell_deg: float, max_pressure_deg: float = 90.0):
    """The lambda2 interval the seed's criteria admit for the combined mechanism (None if there is none); with
    ``max_pressure_deg`` below 90, the toolkit's pressure-angle limit as well.  ``a.scan_lambda2`` is ``synth groove``'s
    lambda2 scan (passed in by the command, which imports this module: no import circle)."""
    b = copy.copy(a)
    b.slider_stage, b.dwell, b.max_pressure_angle, b.law_return = True, dwell_deg, max_pressure_deg, None
    try:
        s = a.scan_lambda2(b, law)
    except ValueError:
        return None
    return s["seed_interval"] if max_pressure_deg >= 90.0 else [s["lambda2_min"], s["lambda2_max"]]


def max_dwell(a, law: str, max_pressure_deg: float = 90.0, tol: float = 1.0) -> tuple[float, list]:
    """The largest dwell [deg] for which some lambda2 gives a groove (bisection on 0-360 deg), and that dwell's
    interval.  The dwell takes half its angle from each stroke's phase, so it cannot exceed twice the shorter
    phase of the base four-bar."""
    lo, hi, iv = 0.0, 360.0, seed_interval(a, law, 0.0, max_pressure_deg)
    if iv is None:
        return math.nan, []
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        got = seed_interval(a, law, mid, max_pressure_deg)
        if got is None:
            hi = mid
        else:
            lo, iv = mid, got
    return lo, iv


def largest_roller(a, law: str, lam2: float, step: float = 2.5e-4, top: float = 0.06) -> float:
    """The largest roller radius [m] such that it and every smaller one (on a grid of ``step``, up to ``top``)
    undercut no groove wall, the kulisa following ``law`` forward and returning as the base four-bar does (the
    seed's return stroke).  Counted up from the smallest: near a branch's end the roller's own circle takes the
    first roller radius of the path, so a larger roller can pass over a sharp bend there that a smaller one
    cannot follow; the first failure decides."""
    kl = groove.kulisa_law_base_return(a.lambda1, lam2, a.lambda3, get_law(law), math.radians(a.dwell), a.assembly)
    p = groove.synthesize_law(kl, a.lambda1, lam2, a.points, groove.base_branch(a.lambda1, lam2, a.lambda3, a.assembly))
    rr = step
    while rr <= top + 1e-12:
        if "undercut" in groove.assess(p, a.crank_radius, rr, math.pi / 2)["all_failed"]:
            return rr - step
        rr += step
    return top


def least_pressure(a, law: str, dwell_deg: float, samples: int = 41) -> tuple[float, float]:
    """(lambda2, deg): the groove whose largest pressure angle is least, over the lambda2 the seed's criteria
    admit at this dwell (sampled); the seed checks the angle against jamming but gives no allowable value."""
    iv = seed_interval(a, law, dwell_deg)
    if iv is None:
        return math.nan, math.nan
    lf = get_law(law)
    best = (math.nan, math.inf)
    for l2 in np.linspace(iv[0] + 1e-3, iv[1] - 1e-3, samples):
        kl, _ = groove.combined_kulisa_law(a.lambda1, l2, a.lambda3, lf, lf, math.radians(dwell_deg), a.assembly)
        p = groove.synthesize_law(kl, a.lambda1, l2, a.points, groove.base_branch(a.lambda1, l2, a.lambda3, a.assembly))
        th = math.degrees(groove.assess(p, a.crank_radius, a.roller_radius, math.pi / 2)["pressure_angle_max"])
        if th < best[1]:
            best = (float(l2), th)
    return best


# -- the figures ---------------------------------------------------------------------------------------------
def fig2(stage: groove.RockerSlider, stem) -> list:
    """Seed Fig. 2, the calculation scheme of the rocker-slider contour, at the stroke's two ends."""
    import matplotlib.pyplot as plt
    from harness.reporting.charts import save_figure

    fig, ax = plt.subplots(figsize=(7, 4.5))
    R, e = stage.R, stage.e
    ax.axhline(e, color="0.5", lw=0.8, ls="--")
    ax.text(stage.s0 + 0.1, e + 0.03, "guide y = e", color="0.4", fontsize=8)
    notes = []
    for s, style, name in ((stage.s0, "-", "start (a = 0)"), (stage.s0 - stage.S, ":", "end (a = 1)")):
        g = float(stage.angle(s)[0])
        D = (R * math.cos(g), R * math.sin(g))
        ax.plot([0, D[0], s], [0, D[1], e], "k" + style, marker="o", label=name)
        ax.text(D[0], D[1] + 0.06, "D", ha="center")
        ax.text(s, e + 0.06, "E", ha="center")
        notes.append(f"{name}: s = {s:.3f}, gamma = {math.degrees(g):.1f} deg (K5), mu = "
                     f"{math.degrees(float(stage.transmission(s))):.1f} deg (K3), theta = "
                     f"{math.degrees(float(stage.pressure(s))):.2f} deg (K4)")
    ax.text(0.02, 0.04, "\n".join(notes), transform=ax.transAxes, fontsize=7, va="bottom")
    ax.text(0.08, -0.1, "O2", ha="center")
    ax.annotate("", xy=(stage.s0 - stage.S, e - 0.2), xytext=(stage.s0, e - 0.2), arrowprops=dict(arrowstyle="<->"))
    ax.text(stage.s0 - stage.S / 2, e - 0.32, f"stroke S = {stage.S:.3f}", ha="center", fontsize=8)
    ax.set_ylim(-0.75, e + 0.3)
    ax.set_aspect("equal")
    ax.set_xlabel("x along the guide [R]")
    ax.set_ylabel("y [R]")
    ax.set_title(f"Seed 001 Fig. 2 (ours): rocker-slider stage (K1)-(K5), R = {R:g}, L = {stage.L:g}, "
                 f"e = {e:.3f}", fontsize=9)
    ax.legend(fontsize=8, loc="upper left")
    return save_figure(fig, stem)


def fig4(stage: groove.RockerSlider, stem) -> list:
    """Seed Fig. 4: the rocker's acceleration invariant against k for the harmonic carriage laws we can build,
    each beside the power-type form C[1 - (2k)^n] with the n fitted to it (the seed's "of the type")."""
    import matplotlib.pyplot as plt
    from harness.reporting.charts import save_figure

    k = np.linspace(0.0, 1.0, 1001)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    built, missing = drawable(FIG4_SEED)
    for name in built:
        i = FIG4_SEED.index(name) + 1
        law = stage.rocker_law(get_law(name))
        c = law(k)[2]
        our = " (our reading)" if name == "0000" else ""
        if abs(c[0]) < 1e-9:
            ax.plot(k, c, label=f"{i} - {name}{our} through the stage: c(0) = 0, not of the type")
            continue
        n = fit_power(law)[0]
        line, = ax.plot(k, c, label=f"{i} - {name}{our} through the stage")
        ax.plot(k, c[0] / power_peak(n) * get_law("power", n=n)(k)[2], ":", color=line.get_color(),
                label=f"power-type C[1-(2k)^n], C = its c(0), n = {n:.2f} fitted on k <= 1/2")
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_xlabel("relative time k")
    ax.set_ylabel("rocker acceleration invariant d2(gamma/swing)/dk2")
    curves = " and ".join(f"{FIG4_SEED.index(m) + 1} ({m})" for m in missing)
    ax.set_title(f"Seed 001 Fig. 4 (ours): rocker of the stage, swing {math.degrees(stage.swing()):.1f} deg\n"
                 f"the seed's curves {curves}: laws of Tir & Senyk [10] not defined in our copy, not drawn",
                 fontsize=9)
    ax.legend(fontsize=8, loc="lower left")
    return save_figure(fig, stem)


def power_peak(n: float) -> float:
    """c(0) of the power-type law of coefficient n (its C), so that a fitted form can be scaled to a curve."""
    return float(get_law("power", n=n)(np.array([0.0]))[2][0])


def fig7(a, lam2: float, stem) -> list:
    """Seed Fig. 7: kulisa angle and acceleration invariant of the LCSM (1) and the base four-bar (2).  The seed
    draws it for law 1,5, which it does not define: ours for K0 and C0 (:data:`LAWS`)."""
    import matplotlib.pyplot as plt
    from harness.reporting.charts import save_figure

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    runs = []
    for name in LAWS:
        lf = get_law(name)
        kl, _ = groove.combined_kulisa_law(a.lambda1, lam2, a.lambda3, lf, lf, math.radians(a.dwell), a.assembly)
        runs.append((name, motion(kl)))
    phi = runs[0][1][0]
    bg, _, bg2 = base_motion(a, lam2, phi)
    deg = np.degrees(phi - phi[0])
    g0 = min([bg.min()] + [r[1].min() for _, r in runs])
    for name, (_, g, _, g2) in runs:
        ax1.plot(deg, np.degrees(g - g0), label=f"1 - LCSM, law {name}")
        ax2.plot(deg, g2, label=f"1 - LCSM, law {name}")
    ax1.plot(deg, np.degrees(bg - g0), "k--", label="2 - base four-bar")
    ax2.plot(deg, bg2, "k--", label="2 - base four-bar")
    ax1.set_ylabel("kulisa angle gamma_b [deg]")
    ax1.legend(fontsize=8)
    ax2.set_ylabel("eps / w1^2 [rad/rad^2]")
    ax2.set_xlabel("crank angle from the forward stroke's start [deg]")
    ax2.text(0.02, 0.03, "the seed's law 1,5 (Tir & Senyk [10]) is not defined in our copy: not drawn",
             transform=ax2.transAxes, fontsize=7, va="bottom")
    ax1.set_title(f"Seed 001 Fig. 7 (ours): lambda1 = {a.lambda1:g}, lambda2 = {lam2:.4f}, lambda3 = {a.lambda3:g},"
                  f" dwell {a.dwell:g} deg", fontsize=9)
    return save_figure(fig, stem)


# -- the report ----------------------------------------------------------------------------------------------
def report(a, folder, scan) -> str:
    """Compute everything, write the figures into ``folder`` and return the table as text; ``scan(args, law)``
    is the command's lambda2 scan."""
    from pathlib import Path

    folder = Path(folder)
    a = copy.copy(a)
    a.scan_lambda2 = scan
    lines = [f"seed 001, combined mechanism: r = {a.crank_radius:g} m, lambda1 = {a.lambda1:g}, "
             f"lambda3 = {a.lambda3:g}; stage: rocker R = 1, tie rod L = 2.5 R (ours: the seed gives none), "
             f"e from the anti-jamming condition",
             f"the seed's laws {', '.join(drawable(FIG4_SEED)[1])} (its Figs. 4 and 7) are catalogue laws of Tir & "
             f"Senyk [10] it does not define (not in our copy): not computed; its statements are computed for "
             f"{' and '.join(LAWS)}"]
    ivs = {name: seed_interval(a, name, a.dwell) for name in LAWS}
    if ivs[LAWS[0]] is None:
        raise ValueError(f"law {LAWS[0]} with the slider stage: no lambda2 meets the seed's criteria at dwell "
                         f"{a.dwell:g} deg")
    iv0 = ivs[LAWS[0]]
    lam2 = 0.5 * (iv0[0] + iv0[1])
    stage = groove.rocker_slider_for_swing(groove.base_design(a.lambda1, lam2, a.lambda3, a.assembly)["swing"])
    th = np.degrees(np.abs(stage.pressure(np.linspace(stage.s0 - stage.S, stage.s0, 2001))))
    for name, iv in ivs.items():
        lines.append(f"law {name}, dwell {a.dwell:g} deg: lambda2 by the seed's criteria "
                     + (f"[{iv[0]:.4f}, {iv[1]:.4f}]" if iv else "none"))
    lines.append(f"figures at the middle of {LAWS[0]}'s interval, lambda2 = {lam2:.4f} (swing "
                 f"{math.degrees(stage.swing()):.2f} deg, e = {stage.e:.4f}, S = {stage.S:.4f}, largest carriage "
                 f"pressure angle (K4) {th.max():.2f} deg)")
    lines.append("")
    lines.append("Fig. 4 -- seed: harmonic carriage laws (K0, 0000, 1,3, 1,5) give a rocker acceleration of the type "
                 "C[1 - (2k)^n], n a power coefficient of the rocker's law")
    built, missing = drawable(FIG4_SEED)
    for name in built:
        law = stage.rocker_law(get_law(name))
        c0 = float(law(np.array([0.0]))[2][0])
        our = " (our reading of 0000)" if name == "0000" else ""
        if abs(c0) < 1e-9:
            lines.append(f"  {name:>5}: rocker c(0) = 0: not of that type (C would be 0){our}")
            continue
        n, mis = fit_power(law)
        lines.append(f"  {name:>5}: rocker c(0) = {c0:.4f}, power-type fit n = {n:.3f}, worst misfit {mis:.4f} of "
                     f"c(0){our}")
    for name in missing:
        lines.append(f"  {name:>5}: not defined in our copy (catalogue law of Tir & Senyk [10])")
    lines.append("")
    lines.append("Sharpening and undercut -- seed: harmonic laws (K0, 1,4 ...) give smooth profiles; cycloidal (C0, Shun, "
                 "2,12) a sharpening at the end of the forward stroke; polydynamic (3,8) undercut")
    lines.append("  largest roller radius [mm] that undercuts no wall, to 0.25 mm, at most 60 (law forward, the base "
                 "four-bar's return; 1,4, 2,12, Shun and 3,8 are not defined in our copy, the 3-4-5 polynomial "
                 "'polydynamic' is the toolkit's placeholder of that group):")
    for l2 in (4.1, 4.5):
        cells = [f"{name} {1000 * largest_roller(a, name, l2):.2f}" for name in ("K0", "C0", "polydynamic")]
        lines.append(f"    lambda2 = {l2:g}: " + ", ".join(cells))
    lines.append("")
    lines.append("Cycle pause -- seed: 'a cycle pause of up to 80 deg'")
    for name in LAWS:
        d, iv = max_dwell(a, name)
        lines.append(f"  {name:>5}: largest dwell with a groove by the seed's criteria: {d:.0f} deg "
                     f"(lambda2 [{iv[0]:.4f}, {iv[1]:.4f}] there)" if iv else f"  {name:>5}: no groove at all")
    for name in LAWS:
        for dwell in (0.0, 80.0):
            l2, th = least_pressure(a, name, dwell)
            lines.append(f"  {name}, dwell {dwell:g} deg: the least largest groove pressure angle over lambda2 is "
                         f"{th:.1f} deg (at lambda2 = {l2:.3f})")
    lines.append("")
    lines.append("Size and energy -- seed: 'dimensions smaller by 14-31 %, energy intensity smaller by 12-38 %' "
                 "(against existing devices); ours: each law against the base four-bar of the same lambdas")
    for name in LAWS:
        for dwell in (0.0, 80.0):
            iv = ivs[name] if dwell == a.dwell else seed_interval(a, name, dwell)
            if iv is None:
                lines.append(f"  {name}, dwell {dwell:g} deg: no groove by the seed's criteria")
                continue
            lines.append(f"  {name}, dwell {dwell:g} deg (lambda2 [{iv[0]:.4f}, {iv[1]:.4f}]), reductions in %: "
                         "lambda2, swing [deg], peak acceleration, peak inertia power, inertia work per turn, footprint")
            for l2 in np.linspace(iv[0] + 0.01, iv[1] - 0.01, 5):
                r = compare_with_base(a, name, l2, dwell)
                lines.append(f"    {l2:.3f} {r['swing_deg']:6.1f} {r['peak_eps_reduction_pct']:7.1f} "
                             f"{r['peak_power_reduction_pct']:7.1f} {r['work_reduction_pct']:7.1f} "
                             f"{r['footprint_reduction_pct']:7.1f}")
    folder.mkdir(parents=True, exist_ok=True)
    paths = fig2(stage, folder / "seed001_fig2") + fig4(stage, folder / "seed001_fig4") + \
        fig7(a, lam2, folder / "seed001_fig7")
    lines.append("")
    lines.append("figures: " + ", ".join(str(p) for p in paths if p.suffix == ".png"))
    return "\n".join(lines)
