"""The benchmark cases: a ring of trivial FMUs and the press drives, each with a fixed step and a size.

A case is the system, the step [s], the number of steps (full and ``--quick``) and the columns whose final
values every tool must agree on: the outputs WITHOUT direct feed-through (their value at a communication point
depends on the state only, so libcosim and Ecos, which sample feed-through outputs at different moments, still
report the same number for them).
"""
from __future__ import annotations

import shutil
import zipfile
from dataclasses import dataclass
from pathlib import Path

from harness.model import Connection, Experiment, Instance, System

RING_SIZE = 6
# the accuracy search's ladder (harness.studies.accuracy.search) for the coupling goals and the timing scopes
METHODS = (("jacobi", 1), ("gauss-seidel", 1), ("jacobian", 1))
STEPS = {"bed_drive": (2e-4, 5e-4, 1e-3, 2e-3), "feeder_gto52": (1e-4, 2e-4, 4e-4, 1e-3)}


def ring(n: int = RING_SIZE) -> System:
    """``n`` Gain FMUs in a ring: ``g[i].integral -> g[i+1].u``, plain connections (factor 1, offset 0: every
    tool can express them); the first integral starts at 1 so the values are not all 0.  ``integral`` does not
    depend directly on ``u``: no algebraic loop, every master can run it."""
    return System(
        name="ring",
        description=f"ring of {n} trivial FMUs (Gain: integral -> next u)",
        instances=[Instance(f"g{i}", "Gain", {"k": 1.0, "q0": 1.0 if i == 0 else 0.0}) for i in range(n)],
        connections=[Connection(f"g{i}.integral", f"g{(i + 1) % n}.u", unit_conversion=True) for i in range(n)],
        experiment=Experiment(stop_time=10.0, step=1e-3, master="jacobi"),
    )


PLAIN_SCRIPT = Path(__file__).resolve().parents[1] / "tests" / "foreign" / "plain_lag.py"


def plain_lag_fmu(out: Path | None = None) -> Path:
    """PlainLag.fmu built from tests/foreign/plain_lag.py with ``pythonfmu build``, as a new user builds it
    (no ModelStructure dependencies, no FMU state); rebuilt when the script is newer."""
    import subprocess
    import sys

    out = Path(out) if out is not None else Path(__file__).resolve().parents[1] / "build" / "plain"
    fmu = out / "PlainLag.fmu"
    if fmu.is_file() and fmu.stat().st_mtime >= PLAIN_SCRIPT.stat().st_mtime:
        return fmu
    out.mkdir(parents=True, exist_ok=True)
    exe = Path(sys.executable).with_name("pythonfmu")
    r = subprocess.run([str(exe), "build", "-f", str(PLAIN_SCRIPT), "-d", str(out)], capture_output=True, text=True)
    if r.returncode != 0 or not fmu.is_file():
        raise RuntimeError(f"pythonfmu build of {PLAIN_SCRIPT} failed: {r.stderr.strip()[-300:]}")
    return fmu


def plain_ring(n: int = RING_SIZE) -> System:
    """``n`` plain pythonfmu lags (``y' = (k u - y)/tau``, explicit Euler in the step) in a ring ``lag[i].y ->
    lag[i+1].u``.  Their outputs declare no dependencies: the masters take them as sampled after the step
    (AssumptionWarning), as libcosim and Ecos do."""
    fmu = str(plain_lag_fmu())
    return System(
        name="plain_ring",
        description=f"ring of {n} plain pythonfmu FMUs (no dependencies, no FMU state)",
        instances=[Instance(f"lag{i}", fmu, {"y0": float(i + 1), "k": -0.5 + 0.1 * i, "tau": 0.5 + 0.2 * i})
                   for i in range(n)],
        connections=[Connection(f"lag{i}.y", f"lag{(i + 1) % n}.u") for i in range(n)],
        experiment=Experiment(stop_time=10.0, step=1e-3, master="jacobi-sampled"),
    )


# cases whose outputs declare no dependencies but are states by construction (known from their source): every
# Real output is checked
ALL_OUTPUTS_CHECKED = {"plain_ring"}


@dataclass(frozen=True)
class Case:
    name: str
    step: float       # s, the same for every tool
    steps: int        # full run
    quick_steps: int  # --quick
    # False: the harness runs the case with its divergence detector off, and its rows say so (a case whose
    # common algorithm is unstable: timed for the comparison, its result not a physical one)
    detector: bool = True

    def system(self) -> System:
        if self.name == "ring":
            return ring()
        if self.name == "plain_ring":
            return plain_ring()
        from harness import load

        return load(self.name)

    def n_steps(self, quick: bool) -> int:
        return self.quick_steps if quick else self.steps


# bed_drive runs at 1e-4 s here: at its default 2e-4 s the sampled Jacobi coupling of libcosim/Ecos (and the
# harness's jacobi-sampled) is unstable (blow-up at t = 0.035 s); the harness's jacobi is stable there.
CASES = {
    "ring": Case("ring", 1e-3, 10_000, 200),
    "plain_ring": Case("plain_ring", 1e-3, 10_000, 200),
    # two_inertia (undamped, free-free) is unstable under Jacobi with zero-order hold at every step (README,
    # Coupling stability; damping does not help): 2 000 steps keep the growth far below the blow-up limit, so
    # every peer finishes, and the harness, whose divergence detector stops it at 0.36 s, runs it without
    "two_inertia": Case("two_inertia", 1e-3, 2_000, 200, detector=False),
    "feeder_gto52": Case("feeder_gto52", 1e-4, 2_000, 20),
    "bed_drive": Case("bed_drive", 1e-4, 2_000, 20),
    "spine_knife": Case("spine_knife", 5e-5, 2_000, 20),
    "proof_press": Case("proof_press", 2e-4, 2_000, 20),
}


def check_columns(system: System) -> list[str]:
    """'Instance.output' of every Real output without direct feed-through."""
    from harness.master import graph
    from harness.model import model_description, resolve_fmu

    cols = []
    for inst in system.instances:
        md = model_description(resolve_fmu(inst.fmu))
        deps = graph.direct_dependencies(md)
        for v in md.modelVariables:
            if v.causality == "output" and v.type == "Real" and (
                    not deps.get(v.name) or system.name in ALL_OUTPUTS_CHECKED):
                cols.append(f"{inst.name}.{v.name}")
    return cols


def ssp_folder(system: System, work: Path) -> Path:
    """Export the system as SSP (``work/<name>.ssp``) and extract it to ``work/<name>_ssp`` (libcosim and Ecos
    load the folder; the same FMU files for every tool)."""
    from harness.ssp import export_ssp

    work = Path(work)
    archive = export_ssp(system, work / f"{system.name}.ssp")
    folder = work / f"{system.name}_ssp"
    shutil.rmtree(folder, ignore_errors=True)
    with zipfile.ZipFile(archive) as z:
        z.extractall(folder)
    return folder
