"""``synth knife``: design check of the book-block knife drive (seed 003, Poliudov & Knysh).

    synth knife [--F-T1 N ... --T-cut s --phi-s rad ... --G Pa --d m --l m --J-red kg.m2] [--json]
    synth knife --system spine_knife [--json]

Prints the derived quantities (A1..A4, time base, T_entry, C_red, J_red by eq. 12b as printed and from
the start of the cut, p, f_n, n, max |dphi| of eq. 11) and the seed's design rules: T_pause/T_cut > 2.5,
f_n in 800..1200 Hz, f_n away from every harmonic i*N_B (band as a fraction of N_B), C_red > 2e4 N.m/rad.
Exit code 0 when every rule holds, 1 when one fails, 2 for bad input.  The seed gives no numbers: the
defaults are the documented KnifeLoad defaults plus two steel shafts d = 50 mm, l = 0.6 m in parallel.

``--system`` checks a system as built instead: the cut from its KnifeLoad instance, the shafts (G, d, l,
psi) and the inertia reduced to the knife (J_red) from its ParallelShafts instance, the seed's two shafts in
parallel (a system without one is refused: the seed's rules are about that design); other options given
with it are refused.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import fields, replace

from fmus.physics import knife as kn
from harness.synthesis import fail, typed

UNITS = {"F_T1": "N", "F_T2": "N", "F_T3": "N", "F_T4": "N", "T_cut": "s", "phi_s": "rad", "beta": "rad",
         "gamma": "rad", "alpha3": "rad", "f": "1", "R": "m", "B": "m", "V_B": "m/s", "G": "Pa", "d": "m",
         "l": "m", "mu_red": "1", "J_red": "kg.m2", "band": "1"}
POSITIVE = ("T_cut", "R", "B", "V_B", "G", "d", "l", "J_red")


def register(subparsers) -> argparse.ArgumentParser:
    ap = subparsers.add_parser("knife", help="design check of the knife drive (seed 003)", description=__doc__,
                               formatter_class=argparse.RawDescriptionHelpFormatter)
    base = kn.KnifeDesign()
    for f in fields(kn.KnifeDesign):
        if f.name == "jred_from":
            ap.add_argument("--jred-from", choices=("cut", "12b"), default=base.jred_from,
                            help="J_red from the load energy with t from the start of the cut, or eq. (12b) as printed")
            continue
        ap.add_argument(f"--{f.name.replace('_', '-')}", dest=f.name, type=float, default=getattr(base, f.name),
                        help=f"[{UNITS[f.name]}] (default {getattr(base, f.name)})")
    ap.add_argument("--system", default=None,
                    help="check this system's design (its KnifeLoad and ParallelShafts; default: the options' values)")
    ap.add_argument("--json", action="store_true", help="print the report as JSON")
    ap.set_defaults(func=run)
    return ap


def design_from_system(system) -> kn.KnifeDesign:
    """The design check's inputs from a system as built: the cut from its KnifeLoad instance, the shafts and
    J_red from its ParallelShafts instance (``ValueError`` in one line when either is missing)."""
    from harness.model import model_name

    found = {}
    for inst in system.instances:
        found.setdefault(model_name(inst.fmu), inst)
    missing = [m for m in ("KnifeLoad", "ParallelShafts") if m not in found]
    if missing:
        raise ValueError(f"system {system.name} has no {' and no '.join(missing)} instance: the seed's design "
                         f"check needs the knife's cut and its two shafts in parallel")
    load = {**{s.name: s.default for s in kn.KnifeLoadParams.specs()}, **found["KnifeLoad"].parameters}
    shaft = found["ParallelShafts"].parameters
    names = {f.name for f in fields(kn.KnifeDesign)}
    values = {k: float(v) for k, v in load.items() if k in names}
    values.update({k: float(shaft[k]) for k in ("G", "d", "l", "J_red") if k in shaft})
    if "psi" in shaft:
        values["mu_red"] = float(shaft["psi"])
    return replace(kn.KnifeDesign(), **values)


def run(args) -> int:
    values = {f.name: getattr(args, f.name) for f in fields(kn.KnifeDesign)}
    if args.system is not None:
        base = kn.KnifeDesign()
        given = [n for n, v in values.items() if v != getattr(base, n)]
        if given:
            return fail("knife", f"--system {args.system} takes its design from the system; refused: "
                                 f"{', '.join('--' + n.replace('_', '-') for n in given)}")
        from harness.run import load

        try:
            values = {f.name: getattr(d, f.name) for d in [design_from_system(load(args.system))]
                      for f in fields(kn.KnifeDesign)}
        except Exception as e:          # an unknown system, or one without the seed's design: one line
            return fail("knife", str(e))
    for name in POSITIVE:
        v = values[name]
        if v is not None and not (math.isfinite(v) and v > 0.0):
            return fail("knife", f"{typed(name, v, UNITS[name])} must be > 0")
    if not 0.0 <= values["phi_s"] < math.pi:
        return fail("knife", f"{typed('phi_s', values['phi_s'], 'rad')} must lie in [0, pi)")
    if not 0.0 < values["beta"] < math.pi / 2:
        return fail("knife", f"{typed('beta', values['beta'], 'rad')} must lie in (0, pi/2)")
    rep = kn.design_report(replace(kn.KnifeDesign(), **values))
    if args.json:
        out = {k: v for k, v in rep.items() if k != "rules"}
        out["rules"] = [{"rule": r, "value": v, "ok": ok} for r, v, ok in rep["rules"]]
        print(json.dumps(out, indent=2))
    else:
        a = rep["A"]
        print(f"A1..A4 = {a[0]:.6g} N/s, {a[1]:.6g} N/s2, {a[2]:.6g} N/s3, {a[3]:.6g} N/s4")
        print(f"omega = {rep['omega']:.6g} rad/s   N_B = {rep['N_B']:.6g} 1/s   T_pause = {rep['T_pause']:.6g} s   "
              f"T_entry = {rep['T_entry']:.6g} s")
        print(f"J_red: eq. (12b) as printed = {rep['J_red_12b']:.6g} kg.m2, from the cut start = {rep['J_red_cut']:.6g} "
              f"kg.m2, used = {rep['J_red']:.6g} kg.m2")
        print(f"C_red = {rep['C_red']:.6g} N.m/rad   p = {rep['p']:.6g} rad/s   f_n = {rep['f_n']:.6g} Hz   "
              f"n = {rep.get('n', float('nan')):.6g} 1/s   max|dphi| = {rep.get('max_dphi', float('nan')):.4g} rad")
        print(f"{'design rule':45s} {'value':>14s}  ok")
        for rule, value, ok in rep["rules"]:
            print(f"{rule:45s} {value:14.6g}  {'yes' if ok else 'NO'}")
    return 0 if rep["ok"] else 1


def main(argv=None) -> int:
    from harness.synthesis import standalone

    return standalone(register, argv)


if __name__ == "__main__":
    sys.exit(main())
