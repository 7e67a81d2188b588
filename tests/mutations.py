"""Deliberate bugs and the tests that must catch them: the suite's own check that its checks can fail.

    python tests/mutations.py                # every mutation: each in a scratch copy, its tests must FAIL
    python tests/mutations.py ssp-factor     # some of them, by name
    python tests/mutations.py --list         # what each one breaks and which tests should catch it
    python tests/mutations.py --baseline     # first run every listed test unmutated (they must pass)

Each mutation replaces one exact piece of text (found exactly once, or the mutation itself is out of date and
says so) in a copy of the checkout (``git ls-files``, with ``../shared`` linked beside it), runs its tests there
(``PYTHONPATH`` on the copy, so child processes import the mutated code too) and restores the file.  A mutation
is CAUGHT when pytest reports failures (exit 1); a pass (exit 0) is a check that cannot fail: fix the tests.
Rerun the mutations of a module you change (docs/contributing.md lists them).  Not a test file: pytest does
not collect it; a full run takes about 10 minutes of CPU.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Mutation:
    name: str
    what: str           # the bug in words
    path: str           # the file, relative to the checkout
    old: str            # the exact text replaced (once)
    new: str
    tests: tuple        # pytest arguments that must fail


MUTATIONS = (
    # -- the thirteen of issue 57 (three of them passed every test before it) ----------------------------------
    Mutation("ssp-factor", "SSP unit conversion divides by the target's factor -> multiplies",
             "harness/ssp/bindings.py", "- dst.offset) / dst.factor", "- dst.offset) * dst.factor",
             ("tests/test_ssp.py", "-k", "scaled_and_offset")),
    Mutation("ssp-offset", "SSP unit conversion drops both units' offsets",
             "harness/ssp/bindings.py", "(src.factor * value.value + src.offset - dst.offset) / dst.factor",
             "(src.factor * value.value) / dst.factor", ("tests/test_ssp.py", "-k", "scaled_and_offset")),
    Mutation("sweep-identity-step", "the sweep's identity no longer records the step: --resume mixes steps",
             "harness/studies/sweep_checks.py", 'for k in ("stop_time", "step", "master", "extrapolation")}',
             'for k in ("stop_time", "master", "extrapolation")}', ("tests/test_sweep.py", "-k", "identity or resume")),
    Mutation("kloss-torque", "the motor's Kloss torque 5 % high (a physics change without new references)",
             "fmus/physics/motor_belt.py", "return 2.0 * self.M_k * s * self.s_k / (s * s + self.s_k * self.s_k)",
             "return 1.05 * 2.0 * self.M_k * s * self.s_k / (s * s + self.s_k * self.s_k)",
             ("tests/test_reference_csv.py", "-k", "motor_belt")),
    Mutation("ssp-dimension", "a value in a unit of another quantity is converted instead of refused",
             "harness/ssp/bindings.py", "if src.exponents != dst.exponents:", "if False:",
             ("tests/test_ssp.py", "-k", "unconvertible")),
    Mutation("parameter-low-bound", "a parameter below its lower bound is accepted",
             "fmus/physics/base.py", "if not low_open and not value >= low:",
             "if not low_open and value < low - 1e300:",
             ("tests/test_fmus_built.py", "-k", "non_physical")),
    Mutation("explicit-factor", "Gauss-Seidel drops a connection's factor where it sets a feed-through FMU's "
             "inputs again at t + h (no test saw it: the new chain test does)",
             "harness/master/explicit.py",
             "coupling drops to first order\n"
             "                it.fmu.set(it.inp, it.factor * self.extrapolation.value(self.history, it.src, t_next)",
             "coupling drops to first order\n"
             "                it.fmu.set(it.inp, self.extrapolation.value(self.history, it.src, t_next)",
             ("tests/test_harness_masters.py", "-k", "wherever_along_a_chain")),
    Mutation("quantity-rms", "the motor's RMS torque computed as the mean absolute torque",
             "harness/reporting/quantities.py", "return math.sqrt(_time_mean(t, x * x, on))",
             "return _time_mean(t, np.abs(x), on)", ("tests/test_quantities.py", "-k", "match_numpy")),
    Mutation("parquet-as-csv", "a .parquet result written as CSV",
             "harness/results.py", "plain.to_parquet(tmp, engine=parquet_engine())", "plain.to_csv(tmp)",
             ("tests/test_newcomer_cli.py", "-k", "real_parquet")),
    Mutation("writable-probe", "an unwritable output folder is not found before the run",
             "harness/results.py", 'probe.write_text("")\n        probe.unlink()', "pass",
             ("tests/test_newcomer_cli.py", "-k", "read_only")),
    Mutation("sweep-log", "a finished sweep point is not written to the partial file (lost on Ctrl-C)",
             "harness/studies/sweep.py", "            log.add(row)", "            pass",
             ("tests/test_interrupt.py", "-k", "sweep and 0")),
    Mutation("reference-fmu-source", "a Reference-FMU source the tests build no longer compiles (was a skip)",
             "tests/reference_fmus/Dahlquist/model.c", "#include \"model.h\"", "#include \"model.h\"\n#error broken",
             ("tests/test_reference_fmus.py", "-k", "alone_matches_fmpy and Dahlquist")),
    Mutation("foreign-fmu-script", "a pythonfmu test script no longer builds (was a skip)",
             "tests/foreign/plain_decay.py", "from pythonfmu import", "import pythonfmu_missing\nfrom pythonfmu import",
             ("tests/test_foreign.py", "-k", "without_outputs")),
    # -- more of our own -------------------------------------------------------------------------------------
    Mutation("extrapolation-midpoint", "extrapolated inputs held at the step's end instead of its midpoint",
             "harness/master/extrapolation.py", "        te = t + 0.5 * h\n", "        te = t + h\n",
             ("tests/test_harness_masters.py", "-k", "global_error_order")),
    Mutation("scene-runs-unshared", "scenes answered together (--all) make every run again",
             "harness/studies/scenes.py", "        if key not in self.made:\n", "        if True:\n",
             ("tests/test_scenes.py", "-k", "share_their_runs")),
    Mutation("scene-runs-columns", "a run shared by scenes records the first scene's columns only",
             "harness/studies/scenes.py",
             "self.output = None if not all(wanted) else list(dict.fromkeys(c for cols in wanted for c in cols))",
             "self.output = wanted[0] or None", ("tests/test_scenes.py", "-k", "share_their_runs")),
)


def copy_checkout(dest: Path) -> Path:
    """The tracked and untracked (not ignored) files of the checkout under dest/repo, ../shared linked beside."""
    files = subprocess.run(["git", "ls-files", "-co", "--exclude-standard", "-z"], cwd=ROOT, check=True,
                           capture_output=True).stdout.decode().split("\0")
    repo = dest / "repo"
    for name in filter(None, files):
        src = ROOT / name
        if src.is_file():
            (repo / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, repo / name)
    shared = ROOT.parent / "shared"
    if shared.exists():
        (dest / "shared").symlink_to(shared)
    return repo


def run_tests(repo: Path, tests: tuple) -> tuple[int, str]:
    env = dict(os.environ, PYTHONPATH=str(repo), PYTHONDONTWRITEBYTECODE="1")
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", *tests], cwd=repo,
                       env=env, capture_output=True, text=True)
    lines = (r.stdout.strip().splitlines() or [""])
    return r.returncode, lines[-1]


def mutate(repo: Path, m: Mutation) -> tuple[str, str]:
    """(verdict, pytest's last line) of one mutation in ``repo``, the file restored after."""
    path = repo / m.path
    text = path.read_text(encoding="utf-8")
    if text.count(m.old) != 1:
        return "OUT OF DATE", f"{m.path}: the text to replace occurs {text.count(m.old)} times, not once"
    path.write_text(text.replace(m.old, m.new), encoding="utf-8")
    try:
        rc, last = run_tests(repo, m.tests)
    finally:
        path.write_text(text, encoding="utf-8")
    return {0: "NOT CAUGHT", 1: "caught"}.get(rc, f"ERROR (pytest exit {rc})"), last


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="mutations to run (default: all)")
    ap.add_argument("--list", action="store_true", help="list the mutations and their tests")
    ap.add_argument("--baseline", action="store_true", help="first run each mutation's tests unmutated")
    ap.add_argument("--keep", type=Path, default=None, help="make the scratch copy here and keep it")
    args = ap.parse_args(argv)
    known = {m.name: m for m in MUTATIONS}
    unknown = [n for n in args.names if n not in known]
    if unknown:
        print(f"mutations: unknown {', '.join(unknown)} (known: {', '.join(known)})", file=sys.stderr)
        return 2
    chosen = [known[n] for n in args.names] or list(MUTATIONS)
    if args.list:
        for m in chosen:
            print(f"{m.name}: {m.what}\n    {m.path}; caught by: pytest {' '.join(m.tests)}")
        return 0
    work = args.keep or Path(tempfile.mkdtemp(prefix="pressdrive_mutations_"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        repo = copy_checkout(work)
        bad = 0
        if args.baseline:
            for m in chosen:
                rc, last = run_tests(repo, m.tests)
                print(f"baseline {m.name}: {'passes' if rc == 0 else f'FAILS UNMUTATED (exit {rc})'}: {last}",
                      flush=True)
                bad += rc != 0
        for m in chosen:
            t0 = time.monotonic()
            verdict, last = mutate(repo, m)
            print(f"{m.name}: {verdict} ({time.monotonic() - t0:.0f} s): {last}", flush=True)
            bad += verdict != "caught"
        print(f"{len(chosen) - bad} of {len(chosen)} caught" if not args.baseline else f"{bad} problem(s)")
        return 1 if bad else 0
    finally:
        if args.keep is None:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
