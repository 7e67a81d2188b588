"""The ``study stability`` command.

Study CLI
---------
``python -m harness study stability two_inertia [--sweep inertia|stiffness] [--values ...] [--out DIR]``
(:func:`register` adds the ``study`` group; :func:`register_stability` adds ``stability`` to an existing
group).  For each sweep value and each method (jacobi / gauss-seidel x order 0, 1, 2) it finds the largest
stable macro step from the theory and from co-simulation runs of the FMUs (bisection, ``--no-measure`` skips
it), writes ``stability_two_inertia.csv`` and draws the stability map (PNG + SVG).

``python -m harness study stability {bed_drive,spine_knife,feeder_gto52,proof_press} [--sweep INST.PARAM]
[--values ...] [--masters ...] [--orders ...] [--quick]``: the same map for a press drive, measured only (the
drives are nonlinear): for each value of the coupling parameter (default per drive in :data:`PRESS_STUDIES`,
e.g. ``fourbar.rocker_inertia`` of the bed drive) and each master x order, the largest stable communication step by doubling/halving from
the default step and bisection on runs, judged against a reference run (criterion and search: the
press-drive section below).  Writes ``stability_<system>_<inst>_<param>.csv`` and the map with the system's
default step marked (:func:`plot_press_map`).
"""
from __future__ import annotations

from pathlib import Path

from harness.studies.stability.measured import PERIODS, SWEEPS, plot_stability_map, stability_table
from harness.studies.stability.press import PRESS_MASTERS, PRESS_STUDIES, plot_press_map, press_stability_table
from harness.studies.stability.theory import ORDERS
from harness.studies.trial import StudyInterrupted, keep_interrupted, write_complete


STUDIES = {"two_inertia": "the two-inertia coupling benchmark (systems/two_inertia.py)",
           **{k: v.doc for k, v in PRESS_STUDIES.items()}}


def register_stability(study_subparsers) -> None:
    """Add ``stability`` to an existing ``study`` sub-parser group."""
    p = study_subparsers.add_parser(
        "stability", help="coupling-stability map (theory and measured)",
        description="Largest stable macro step of each master (jacobi, gauss-seidel, jacobi-sampled for press "
                    "drives) with extrapolation orders 0, 1, 2 versus a coupling parameter.  two_inertia: "
                    "amplification-matrix theory and bisection on co-simulations; press drives (bed_drive, "
                    "spine_knife, feeder_gto52, proof_press): bisection on co-simulations against a reference.")
    p.add_argument("benchmark", choices=sorted(STUDIES), help="system")
    p.add_argument("--sweep", default=None,
                   help="swept parameter: two_inertia: inertia (J2/J1) or stiffness (c/c1); press drive: "
                        "INSTANCE.PARAMETER (default: the system's coupling parameter, e.g. fourbar.rocker_inertia)")
    p.add_argument("--values", type=float, nargs="+", default=None,
                   help="values of the swept parameter (default: the sweep's own grid)")
    p.add_argument("--masters", nargs="+", default=None, help="press drives: masters (default: "
                                                               + " ".join(PRESS_MASTERS) + "; also jacobi-sampled)")
    p.add_argument("--orders", type=int, nargs="+", default=None, help="extrapolation orders (default: 0 1 2)")
    p.add_argument("--quick", action="store_true",
                   help="fewer values, shorter runs, coarser bisection (press drives: 3 values, half the run length, "
                        "rtol 6 %%; two_inertia: theory only)")
    p.add_argument("--rtol", type=float, default=None,
                   help="relative width of the final bracket (default: two_inertia 0.005; press drives 0.03, 0.06 "
                        "with --quick)")
    p.add_argument("--no-measure", action="store_true", help="two_inertia: theory only (no co-simulation runs)")
    p.add_argument("--periods", type=float, default=None,
                   help="run length in periods of the (estimated) stiffest coupled mode (default: two_inertia 90, "
                        "press drives 10)")
    p.add_argument("--out", type=Path, default=Path("results"), help="output folder (default: results/)")
    p.set_defaults(func=stability_cli)


def register(subparsers) -> None:
    """Create the ``study`` command group and add ``stability`` to it."""
    p = subparsers.add_parser("study", help="numerical studies (stability, ...)",
                              description="Numerical studies of the co-simulation masters.")
    study = p.add_subparsers(dest="study", metavar="STUDY", required=True)
    register_stability(study)
    return study


def stability_cli(args) -> int:
    import sys

    progress = lambda s: print(s, file=sys.stderr)  # noqa: E731
    out = Path(args.out)
    if args.benchmark == "two_inertia":
        sweep = args.sweep or "inertia"
        if sweep not in SWEEPS:
            raise ValueError(f"--sweep {sweep!r} is not admissible for two_inertia: must be one of "
                             f"{', '.join(SWEEPS)}")
        stem = out / f"stability_two_inertia_{sweep}"
        make = lambda: stability_table(sweep=sweep, values=args.values,  # noqa: E731
                                       measure=not (args.no_measure or args.quick), periods=args.periods or PERIODS,
                                       rtol=args.rtol or 0.005, progress=progress)
        plot = plot_stability_map
    else:
        quick = bool(args.quick)
        sweep = args.sweep or PRESS_STUDIES[args.benchmark].sweep
        stem = out / f"stability_{args.benchmark}_{sweep.replace('.', '_')}"
        make = lambda: press_stability_table(args.benchmark, sweep=args.sweep, values=args.values,  # noqa: E731
                                             masters=args.masters or PRESS_MASTERS, orders=args.orders or ORDERS,
                                             periods=args.periods or (5.0 if quick else 10.0),
                                             rtol=args.rtol or (0.06 if quick else 0.03), quick=quick,
                                             progress=progress)
        plot = plot_press_map
    try:
        table = make()
    except StudyInterrupted as e:
        return keep_interrupted(e, stem.with_suffix(".csv"), f"stability study of {args.benchmark} stopped")
    csv = write_complete(table, stem.with_suffix(".csv"))
    figs = plot(table, stem)
    print(f"wrote {csv}, {', '.join(str(f) for f in figs)}")
    failed = int((table["status"] == "failed").sum()) if "status" in table else 0
    if failed:
        print(f"error: {failed} of {len(table)} rows failed (their reason is in the error column of {csv})",
              file=sys.stderr)
        return 1
    return 0
