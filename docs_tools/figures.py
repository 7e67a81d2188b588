"""``python -m docs_tools.figures [NAME ...] [--out DIR] [--list]``: regenerate the figures of the docs.

:data:`FIGURES` says, for every file in docs/images/ (the charts, their .svg twins and the .csv data beside
them), the repository command that makes it: a ``python -m harness ...`` run, study, scene or sweep, a
``python -m benchmarks...`` run.  Each command writes into a fresh temporary folder (``{out}`` in the
command); the files the docs use are then copied from there to docs/images/ (or ``--out DIR``), under the name
the pages link (the take-up study writes ``takeup.png``; the seed page shows it as ``seeds_000_takeup.png``).
Other files the command writes (a run's own result CSV, a benchmark's table) are left in the temporary folder.

NAME is a figure's name (``--list`` shows them with their commands and files) or the name of a file in
docs/images/; none: every figure (about 20 minutes on an idle 2-core machine, the full benchmark included).
tests/test_docs_figures.py checks the registry against the pages and against docs/images/, and regenerates the
cheapest figures (slow suite).
"""
from __future__ import annotations

import argparse
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"


@dataclass(frozen=True)
class Figure:
    """One command and the docs/images files it makes.  ``command``: run from the repository's root, ``{out}``
    standing for its output folder; ``files``: (name in docs/images, name the command writes in ``{out}``);
    ``cost``: its rough wall time on an idle 2-core machine, as the pages measured it."""
    name: str
    command: str
    files: tuple[tuple[str, str], ...]
    cost: str

    def shown(self, out: str = "docs/images") -> str:
        """The command as a user types it, writing into ``out``."""
        return self.command.format(out=out)


def _same(*names: str) -> tuple[tuple[str, str], ...]:
    return tuple((n, n) for n in names)


FIGURES: tuple[Figure, ...] = (
    Figure("bed_drive_run", "python -m harness run bed_drive --out {out}/bed_drive.csv --plot {out}",
           _same("bed_drive.png", "bed_drive_cycle.png"), "20 s"),
    Figure("bed_drive_estop",
           "python -m harness run bed_drive --scenario estop --quiet-quantities --out {out}/estop.csv --plot {out}",
           (("bed_drive_estop_stop.png", "estop_stop.png"),), "20 s"),
    Figure("spine_knife_modes", "python -m harness modes spine_knife --plot {out}",
           _same("spine_knife_campbell.png"), "5 s"),
    Figure("precision_bed_drive", "python -m harness study precision bed_drive --out {out}",
           _same("precision_bed_drive.png", "precision_bed_drive.svg", "precision_bed_drive.csv"), "20 s"),
    Figure("stability_bed_drive", "python -m harness study stability bed_drive --out {out}",
           _same("stability_bed_drive_fourbar_rocker_inertia.png", "stability_bed_drive_fourbar_rocker_inertia.svg",
                 "stability_bed_drive_fourbar_rocker_inertia.csv"), "35 s"),
    Figure("stability_two_inertia", "python -m harness study stability two_inertia --out {out}",
           _same("stability_two_inertia_inertia.png", "stability_two_inertia_inertia.svg",
                 "stability_two_inertia_inertia.csv"), "2-3 min"),
    Figure("scene_bed_drive", "python -m harness scene bed_drive --out {out}",
           _same("scene_bed_drive_print_speed_ripple.png", "scene_bed_drive_print_speed_ripple.svg"), "1-2 min"),
    Figure("feeder_clearance", "python -m harness sweep feeder_gto52 --grid systems/studies/feeder_clearance.yaml "
                               "--out {out}/feeder_clearance.csv --plot {out}",
           _same("feeder_clearance.png", "feeder_clearance.svg", "feeder_clearance.csv"), "2 min"),
    Figure("knife_resonance", "python -m harness sweep spine_knife --grid systems/studies/knife_resonance.yaml "
                              "--out {out}/knife_resonance.csv --plot {out}",
           _same("knife_resonance.png", "knife_resonance.svg", "knife_resonance.csv"), "1 min"),
    Figure("conveyor_grid", "python -m harness sweep trimmer_conveyor --grid systems/studies/conveyor_grid.yaml "
                            "--out {out}/conveyor_grid.csv --plot {out}",
           _same("conveyor_grid.png", "conveyor_grid.svg", "conveyor_grid.csv"), "3 min"),
    # The full take-up map; it reads docs/images/feeder_clearance.csv (the feeder_clearance sweep above).  The
    # unprefixed takeup.* files are the same study's output under its own names (an earlier copy in the tree).
    Figure("takeup_map", "python -m harness study takeup --out {out}",
           (("seeds_000_takeup.png", "takeup.png"), ("seeds_000_takeup.svg", "takeup.svg"),
            ("seeds_000_takeup_summary.csv", "takeup_summary.csv"),
            ("takeup.png", "takeup.png"), ("takeup.svg", "takeup.svg"), ("takeup.csv", "takeup.csv"),
            ("takeup_summary.csv", "takeup_summary.csv")), "3.5 min"),
    Figure("takeup_figures", "python -m harness study takeup --figures --out {out}",
           (("seeds_000_takeup_velocity.png", "takeup_velocity.png"),
            ("seeds_000_takeup_liftoff.png", "takeup_liftoff.png"),
            ("seeds_000_takeup_liftoff.csv", "takeup_liftoff.csv")), "5 s"),
    Figure("seed001_figures", "python -m harness synth groove --seed-figures {out}",
           _same("seed001_fig2.png", "seed001_fig2.svg", "seed001_fig4.png", "seed001_fig4.svg",
                 "seed001_fig7.png", "seed001_fig7.svg"), "40 s"),
    Figure("benchmark", "python -m benchmarks --chart {out}/benchmark.png",
           _same("benchmark.png", "benchmark.svg"), "5 min and more"),
    Figure("work_precision", "python -m benchmarks.coupling --out {out}",
           _same("work_precision_bed_drive.png", "work_precision_bed_drive.svg", "work_precision_bed_drive.csv",
                 "work_precision_feeder_gto52.png", "work_precision_feeder_gto52.svg",
                 "work_precision_feeder_gto52.csv"), "10 min and more"),
)


def by_file() -> dict[str, Figure]:
    """Each docs/images file name -> the figure that makes it."""
    return {published: f for f in FIGURES for published, _ in f.files}


def select(names: list[str]) -> list[Figure]:
    """The figures named (a figure's name or one of its files' names), in registry order; none: all."""
    if not names:
        return list(FIGURES)
    figures, files = {f.name: f for f in FIGURES}, by_file()
    bad = [n for n in names if n not in figures and n not in files]
    if bad:
        raise SystemExit(f"unknown figure {bad[0]!r} (allowed: {', '.join(figures)}, or a file name in "
                         f"docs/images/: python -m docs_tools.figures --list)")
    wanted = {(figures.get(n) or files[n]).name for n in names}
    return [f for f in FIGURES if f.name in wanted]


def regenerate(figure: Figure, out: Path = IMAGES) -> list[Path]:
    """Run ``figure``'s command into a temporary folder and copy its files to ``out``; the paths written.
    A command that fails, or does not write a file the registry says it does, raises RuntimeError with one
    line (the command's own error output is shown as it runs)."""
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=f"figure-{figure.name}-") as tmp:
        argv = shlex.split(figure.command.format(out=tmp))
        assert argv[0] == "python", figure.command
        env = dict(os.environ, MPLBACKEND="Agg")
        env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in [env.get("PYTHONPATH")] if p])
        status = subprocess.run([sys.executable] + argv[1:], cwd=ROOT, env=env).returncode
        if status != 0:
            raise RuntimeError(f"figure {figure.name}: {figure.shown()} exited {status}")
        written = []
        for published, produced in figure.files:
            source = Path(tmp) / produced
            if not source.is_file():
                raise RuntimeError(f"figure {figure.name}: {figure.shown()} wrote no {produced}")
            written.append(Path(shutil.copyfile(source, out / published)))
    return written


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m docs_tools.figures", description=__doc__.splitlines()[0],
                                 epilog="Figures: " + ", ".join(f.name for f in FIGURES))
    ap.add_argument("names", nargs="*", metavar="NAME", help="figure or docs/images file name (default: all)")
    ap.add_argument("--out", type=Path, default=IMAGES, help="folder to write into (default: docs/images/)")
    ap.add_argument("--list", action="store_true", help="list the figures, their commands and files; run nothing")
    args = ap.parse_args(argv)
    figures = select(args.names)
    if args.list:
        print("Each command runs in a scratch folder; the files listed under it are then copied to docs/images/.")
        for f in figures:
            print(f"{f.name} ({f.cost}): {f.shown()}")
            for published, produced in f.files:
                print(f"    {published}" + ("" if published == produced else f"  (written as {produced})"))
        return 0
    for f in figures:
        print(f"{f.name}: {f.shown(str(args.out))}  ({f.cost})", flush=True)
        try:
            paths = regenerate(f, args.out)
        except RuntimeError as e:
            print(e, file=sys.stderr)
            return 1
        print(f"wrote {', '.join(str(p) for p in paths)}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
