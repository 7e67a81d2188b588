"""``synth sectors``: synthesis of the eccentric round gear sectors of paper A (seed 002, eq. 25).

    synth sectors [--residuals r24,r18,r23,r21 | lsq] [--D-Ci ..] [--v1 ..] ... [--json]

Solves for eps1, eps2, kappa, beta0 and prints them with all residuals r17..r24, whether the solver
converged and whether the pair is feasible: buildable (pivots inside the sectors, the crank angle monotonic)
and meeting every condition r17..r24 to --junction-tol, the four not solved for included (the seed's
combined law joins its phases only where all of them hold; the seed's data over-determine its system, so
--not-given frees the conditions of the quantities it names and prints the pair's own values of them).
Given quantities not typed take the values of a worked example: the forward kinematics of eps1 = 0.3, eps2 = 0.3, kappa = 1.5, beta0 = 0.8 rad,
delta0 = -1.2 rad, D_Ci = 1.68 (so the default problem has that exact solution).  A given quantity out of
its range, or no feasible solution: one line on stderr, exit code 2.
"""
from __future__ import annotations

import argparse
import json
import math
import sys

from fmus.physics import gear_sectors as gs
from harness.synthesis import fail, typed

EXAMPLE = dict(eps1=0.3, eps2=0.3, kappa=1.5, beta0=0.8, delta0=-1.2, D_Ci=1.68)
GIVEN = ("D_Ci", "v1", "v2", "w2", "l_i", "phi12", "phiC12", "c1", "delta0")
HELP = {"D_Ci": "cylinder diameter / (r_K i_CK)", "v1": "uniform surface speed invariant",
        "v2": "bed speed invariant at point 2", "w2": "bed acceleration invariant at point 2",
        "l_i": "centre distance / R_B with impression on", "phi12": "crank angle of the phase [rad]",
        "phiC12": "cylinder rotation on the phase [rad]", "c1": "character coefficient of eq. (24)",
        "delta0": "angle of O_B C_B at point 2 [rad]"}


OPTIONAL = ("v1", "v2", "w2", "l_i", "phi12", "phiC12", "c1")   # may be left out (D_Ci and delta0 may not)


def example_task() -> gs.SectorTask:
    e = EXAMPLE
    return gs.task_from_geometry(e["eps1"], e["eps2"], e["kappa"], e["beta0"], e["delta0"], D_Ci=e["D_Ci"])


def register(subparsers) -> argparse.ArgumentParser:
    ap = subparsers.add_parser("sectors", help="solve the eccentric gear-sector synthesis (paper A, eq. 25)",
                               description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--residuals", default=",".join(gs.DEFAULT_SET),
                    help="four of r17..r24 separated by commas, or 'lsq' (least squares over all); "
                         "default %(default)s")
    for name in GIVEN:
        ap.add_argument(f"--{name.replace('_', '-')}", dest=name, type=float, default=None,
                        help=f"{HELP[name]} (default: worked example)")
    ap.add_argument("--not-given", default="", metavar="NAMES",
                    help="given quantities to leave out, separated by commas (of " + ", ".join(OPTIONAL) + "): "
                         "the conditions that need them are not required for 'feasible', and the pair's own "
                         "values are printed instead (the seed's data over-determine its system (25))")
    ap.add_argument("--junction-tol", type=float, default=gs.JUNCTION_TOL,
                    help="largest |residual| of a condition not solved for that still counts as met "
                         "(default %(default)g)")
    ap.add_argument("--R-B", dest="R_B", type=float, default=None,
                    help="pitch radius of the driven sector [m]: also print the sizes the seed derives from it "
                         "(e1 = eps1 R_B, e2 = eps2 R_B, R_A = kappa R_B); default: the ratios only")
    ap.add_argument("--json", action="store_true", help="print the result as JSON")
    ap.set_defaults(func=run)
    return ap


def run(args) -> int:
    base = example_task()
    values = {n: (getattr(args, n) if getattr(args, n, None) is not None else getattr(base, n)) for n in GIVEN}
    left_out = tuple(n.strip() for n in args.not_given.split(",") if n.strip())
    bad = [n for n in left_out if n not in OPTIONAL]
    if bad:
        return fail("sectors", f"--not-given {args.not_given}: {', '.join(bad)} cannot be left out (allowed: "
                               f"{', '.join(OPTIONAL)})")
    use = "lsq" if args.residuals.strip() == "lsq" else tuple(s.strip() for s in args.residuals.split(","))
    for name in GIVEN:   # NaN means "not given": only through --not-given
        lo, hi = gs.GIVEN_RANGES[name]
        v = values[name]
        if math.isnan(v) or gs.out_of_range(gs.SectorTask(**{**{n: math.nan for n in GIVEN}, name: v})):
            return fail("sectors", f"{typed(name, v)}: {HELP[name]} outside the allowed range ({lo:g}, {hi:.6g})")
    values.update({n: math.nan for n in left_out})
    task = gs.SectorTask(**values)
    if args.R_B is not None and not (0.0 < args.R_B < math.inf):
        return fail("sectors", f"{typed('R_B', args.R_B, 'm')}: pitch radius of the driven sector outside the "
                               f"allowed range (0, inf) m")
    if not args.junction_tol > 0.0:
        return fail("sectors", f"{typed('junction_tol', args.junction_tol)} outside the allowed range (0, inf)")
    try:
        sol = gs.solve_sectors(task, use, junction_tol=args.junction_tol)
    except ValueError as e:
        return fail("sectors", str(e))
    sizes = {} if args.R_B is None else {"R_B": args.R_B, "e1": sol.eps1 * args.R_B, "e2": sol.eps2 * args.R_B,
                                         "R_A": sol.kappa * args.R_B}
    own = gs.task_from_geometry(*sol.x, task.delta0, D_Ci=task.D_Ci)      # what the pair itself has
    produced = {n: float(getattr(own, n)) for n in left_out}
    if args.json:
        def plain(d):
            return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in d.items()}
        out = {"given": plain(values), **sol.as_dict(), **({"sizes_m": sizes} if sizes else {}),
               **({"not_given_the_pairs_own": produced} if produced else {})}
        out["residuals"] = plain(out["residuals"])
        print(json.dumps(out, indent=2))
    else:
        print(f"residual set: {','.join(sol.used)}")
        for n in gs.UNKNOWNS:
            print(f"  {n:7s} = {getattr(sol, n): .10g}")
        if sizes:
            print("sizes: " + ", ".join(f"{k} = {v:.6g} m" for k, v in sizes.items()))
        print("residuals:")
        for n, r in sol.residuals.items():
            shown = "  not given" if math.isnan(r) and n not in sol.used else f"{r: .3e}"
            print(f"  {n}{'*' if n in sol.used else ' '} = {shown}   {gs.RESIDUAL_MEANING[n]}")
        if produced:
            print("not given, the pair's own: " + ", ".join(f"{k} = {v:.6g}" for k, v in produced.items()))
        print("  (* solved for; feasible needs every residual within the junction tolerance)")
        print(f"converged: {sol.converged}  feasible: {sol.feasible}  ({sol.message})")
    if not (sol.converged and sol.feasible):
        return fail("sectors", f"no feasible solution: {sol.message}")
    return 0


def main(argv=None) -> int:
    from harness.synthesis import standalone

    return standalone(register, argv)


if __name__ == "__main__":
    sys.exit(main())
