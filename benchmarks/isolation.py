"""What isolating an FMU costs (``python -m benchmarks.isolation [--steps N] [--repeat R]``).

Two oscillators of tests/c_fmu (a C FMU, compiled here with gcc against fmpy's FMI 2.0 headers) coupled in a
ring, run with ``jacobi`` at a fixed step in this process and isolated (``isolate="all"``: each FMU in a child
process of its own); and the same for a ring of two of the toolkit's Gain FMUs (pythonfmu, in-process by
default).  Printed per case: the best wall time of each way, the difference per FMU step (each step forwards a
set, a do_step and a get: three round trips) and the start-up of the isolated run (child interpreters and
their imports: the whole call's time outside the stepping loop, isolated minus in process)."""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import tempfile
import warnings
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def build_oscillator(folder: Path) -> Path:
    import fmpy

    src = ROOT / "tests" / "c_fmu"
    headers = Path(os.path.dirname(fmpy.__file__)) / "c-code"
    binary = folder / "oscillator.so"
    subprocess.run([shutil.which("gcc") or "gcc", "-shared", "-fPIC", "-O2", f"-I{headers}",
                    str(src / "oscillator.c"), "-o", str(binary), "-lm"], check=True)
    fmu = folder / "oscillator.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.write(src / "modelDescription.xml", "modelDescription.xml")
        z.write(binary, "binaries/linux64/oscillator.so")
    return fmu


def ring(fmu, var_in: str, var_out: str, factor: float):
    from harness.model import Connection, Instance, System

    return System("ring", [Instance("a", fmu=str(fmu)), Instance("b", fmu=str(fmu))],
                  [Connection(f"a.{var_out}", f"b.{var_in}", factor=factor, unit_conversion=True),
                   Connection(f"b.{var_out}", f"a.{var_in}", factor=factor, unit_conversion=True)])


def best(system, steps: int, repeat: int, isolate):
    from harness import simulate

    import time

    runs = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            df = simulate(system, stop_time=steps * 1e-3, step=1e-3, master="jacobi", isolate=isolate,
                          on_error="raise")
        total = time.perf_counter() - t0
        runs.append((df.attrs["wall_time"], df.attrs["init_time"], df.attrs["fmu_steps"], total - df.attrs["wall_time"]))
    return min(runs)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=5000)
    p.add_argument("--repeat", type=int, default=3)
    args = p.parse_args(argv)
    from harness.model import resolve_fmu

    with tempfile.TemporaryDirectory() as tmp:
        cases = {"C oscillator (FMI library)": ring(build_oscillator(Path(tmp)), "F", "x", -20.0),
                 "toolkit Gain (pythonfmu, in-process)": ring(resolve_fmu("Gain"), "u", "integral", -0.5)}
        for label, system in cases.items():
            plain = best(system, args.steps, args.repeat, None)
            alone = best(system, args.steps, args.repeat, "all")
            n = plain[2]
            per = ((alone[0] - alone[1]) - (plain[0] - plain[1])) / n * 1e6
            start = alone[3] - plain[3]
            print(f"{label}: {n} FMU steps; stepping in process {plain[0]:.3f} s, isolated {alone[0]:.3f} s; "
                  f"isolation costs {per:.1f} us per FMU step and {start:.2f} s to start the run's child "
                  f"processes")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
