"""Where a co-simulation step's CPU time goes, part by part, in the harness and in Ecos on the same SSP.

    python -m benchmarks.step_parts [--cases spine_knife,bed_drive] [--quick] [--repeats 3] [--profile]

Both tools run a case of :mod:`benchmarks.cases` (the same exported SSP, the same step, Jacobi with sampled
outputs, initialisation and stepping timed as :mod:`benchmarks.bench` times them), each configuration in a
fresh process pinned to one CPU (``taskset -c 0``), taken in turn, the least CPU time of ``--repeats`` runs in
that process (``time.process_time``: the process's CPU seconds, its threads included; on a shared, loaded
machine wall times measure the other processes too).  Per FMU step [us]:

* ``total``: the run as the benchmark times it;
* ``calls free``: the same run with every FMU's Python made free right after initialisation, THE SAME WAY in
  both tools: each slave object's ``do_step`` returns True at once, ``set_real`` does nothing and
  ``get_real`` returns the values it read at the end of initialisation.  What is left is the tool itself:
  in the harness its master, observers and in-process call layer, in Ecos its C++ master, the FMUs' C
  wrapper (pythonfmu's, which calls the same slave object in the same interpreter) and the call into Python;
* ``FMUs' Python`` = total - calls free: the slave objects' own work, the same calls in both tools;
* the harness only, the master's bookkeeping taken out one part at a time from the calls-free run (each the
  difference it makes): the divergence watch (``divergence=None``), the recording (one column recorded
  instead of the checked ones: its per-row cost stays), the held inputs and the exchange (the two
  computations per step that move values between FMUs), and what is left: the loop and the calls.

``--fmi`` adds the harness calling every FMU through fmpy, ctypes and pythonfmu's C wrapper (as Ecos calls
them) instead of in-process: the difference is what that call path costs per FMU step.

The harness reaches Ecos's cost per FMU step when its calls-free part is at or below Ecos's: the FMUs'
Python is the same work in both.  ``--profile`` adds ``cProfile`` of the harness's calls-free run (CPU time,
the functions with the most own time), which says which part of the master remains.
"""
from __future__ import annotations

import argparse
import json
import math
import time
import warnings
from pathlib import Path

from benchmarks.cases import CASES

CASE_ORDER = ("ring", "plain_ring", "two_inertia", "feeder_gto52", "bed_drive", "spine_knife", "proof_press")
VARIANTS = ("harness", "harness-free", "harness-free-nowatch", "harness-free-onecol", "ecos", "ecos-free")
# with --fmi: the harness with every FMU called through its C library by fmpy/ctypes instead of in-process
FMI_VARIANT = "harness-fmi"


def _free_slave(slave) -> None:
    """Make one pythonfmu slave object's stepping and value calls free (module docstring), on the instance
    itself, so that any caller (the harness's in-process path, a C wrapper) sees the stand-ins."""
    real_get, cache = slave.get_real, {}

    def get_real(refs):
        key = tuple(refs)
        values = cache.get(key)
        if values is None:
            values = cache[key] = list(real_get(refs))
        return list(values)

    slave.get_real = get_real
    slave.set_real = lambda refs, values: None
    slave.do_step = lambda t, h: True


def _slaves_in_interpreter(before: set[int]) -> list:
    """Every pythonfmu slave object alive in this interpreter that was not in ``before`` (ids)."""
    import gc

    out = []
    for obj in gc.get_objects():
        if id(obj) in before:
            continue
        cls = type(obj)
        if any(c.__name__ == "Fmi2Slave" for c in cls.__mro__[1:]) and callable(getattr(obj, "do_step", None)):
            out.append(obj)
    return out


def _harness_run(folder: Path, case, columns: list[str], variant: str) -> tuple[float, int]:
    """(CPU seconds of initialisation and stepping, FMU steps) of one harness run of ``variant``."""
    import dataclasses

    from harness import RunOptions, load, simulate
    from harness.fmi.inprocess import InProcessFMU

    system = load(str(Path(folder) / "SystemStructure.ssd"))
    options = RunOptions(in_process=False) if variant == FMI_VARIANT else RunOptions()
    if not case.detector or variant.endswith("nowatch"):
        options = dataclasses.replace(options, divergence=None)
    output = columns[:1] if variant.endswith("onecol") else columns
    exit_init = InProcessFMU.exit_initialization
    patched = []
    if "free" in variant:
        def exit_then_free(self):
            exit_init(self)
            _free_slave(self._slave)
            # the in-process layer keeps the bound methods it took at instantiation: hand it the stand-ins
            self._get_real, self._set_real, self._step = (self._slave.get_real, self._slave.set_real,
                                                          self._slave.do_step)
            patched.append(self.name)
        InProcessFMU.exit_initialization = exit_then_free
    try:
        n = case.steps
        df = simulate(system, stop_time=n * case.step, step=case.step, master="jacobi-sampled", extrapolation=0,
                      output=output, options=options)
    finally:
        InProcessFMU.exit_initialization = exit_init
    if not df.attrs["complete"]:
        raise RuntimeError(f"harness {variant}: {df.attrs['error']}")
    if "free" in variant and len(patched) != len(system.instances):
        raise RuntimeError(f"harness {variant}: {len(system.instances) - len(patched)} FMUs not on the in-process path")
    return df.attrs["cpu_time"], int(df.attrs["fmu_steps"])


def _ecos_run(folder: Path, case, variant: str, parameter_set: str | None) -> tuple[float, int]:
    import ecospy

    ecospy.EcosLib.set_log_level("warn")
    before = None
    if variant == "ecos-free":
        import gc

        before = {id(o) for o in gc.get_objects()}
    sim = ecospy.EcosSimulation(ssp_path=str(folder), step_size=case.step)
    n = case.steps
    with sim:
        cpu = time.process_time()
        if not sim.init(0.0, parameter_set):
            raise RuntimeError(f"ecos: init failed: {ecospy.EcosLib.get_last_error()}")
        cpu = time.process_time() - cpu
        if before is not None:  # not timed: finding the slave objects (the harness's stand-ins cost no search)
            slaves = _slaves_in_interpreter(before)
            if not slaves:
                raise RuntimeError("ecos-free: no pythonfmu slave object found in this interpreter")
            for s in slaves:
                _free_slave(s)
            fmus = len(slaves)
        stepping = time.process_time()
        sim.step(n)
        cpu += time.process_time() - stepping
        sim.terminate()
    if before is None:
        from benchmarks.runners import _instances

        fmus = len(_instances(folder))
    return cpu, n * fmus


def measure(spec: dict) -> dict:
    """One variant of one case, ``spec["repeats"]`` times in this process: the least CPU time [s], the FMU
    steps, and us per FMU step.  ``spec["profile"]``: also cProfile's top own-time functions of one more run."""
    warnings.simplefilter("ignore")
    case = CASES[spec["case"]]
    if spec.get("quick"):
        case = type(case)(case.name, case.step, case.quick_steps * 10, case.quick_steps, case.detector)
    folder, variant = Path(spec["folder"]), spec["variant"]
    cpu = []
    for _ in range(spec.get("repeats", 3)):
        if variant.startswith("harness"):
            seconds, fmu_steps = _harness_run(folder, case, spec["columns"], variant)
        else:
            seconds, fmu_steps = _ecos_run(folder, case, variant, spec.get("parameter_set"))
        cpu.append(seconds)
    out = {"cpu_s": min(cpu), "fmu_steps": fmu_steps, "us": 1e6 * min(cpu) / fmu_steps}
    if spec.get("profile"):
        out["profile"] = _profile(folder, case, spec["columns"], variant)
    return out


# the harness's parts in a profile, by (file, function): the first that matches names a function's own time
PARTS = (
    ("divergence watch", ("divergence.py", None)),
    ("recording", ("results.py", None), ("observers.py", "on_step")),
    ("held inputs (extrapolation)", ("loop.py", "_hold"), ("extrapolation.py", None)),
    ("outputs read, history (exchange)", ("loop.py", "_read"), ("loop.py", "_exchange"),
     ("extrapolation.py", "push")),
    ("bonds' power and energy", ("loop.py", "_bond_step")),
    ("finite and range check", ("loop.py", "_check")),
    ("calls into the FMUs (in-process layer, stand-ins)", ("inprocess.py", None), ("step_parts.py", None)),
)


def _part(filename: str, function: str) -> str:
    for label, *rules in PARTS:
        for file, prefix in rules:
            if filename == file and (prefix is None or function.startswith(prefix)):
                return label
    return "the loop and the rest"


def _profile(folder, case, columns, variant, top: int = 10) -> dict:
    """cProfile (CPU clock) of one more run: the share of the profiled time by part (:data:`PARTS`) and the
    ``top`` functions by own time.  Profiling inflates every call about alike: the shares are approximate."""
    import cProfile
    import pstats

    from harness.master import Master

    profiler = cProfile.Profile(time.process_time)
    run = Master.run

    def profiled_run(self, *args, **kwargs):  # the run loop only: not the loading nor the initialisation
        profiler.enable()
        try:
            return run(self, *args, **kwargs)
        finally:
            profiler.disable()

    Master.run = profiled_run
    try:
        _harness_run(folder, case, columns, variant)
    finally:
        Master.run = run
    stats = pstats.Stats(profiler).stats
    total = sum(v[2] for v in stats.values()) or 1.0
    by_part: dict[str, float] = {}
    for (file, _, function), v in stats.items():
        if file == "~" and v[4]:  # a built-in (max, list.append...): its own time goes to its callers' parts
            for (cfile, _, cfunction), c in v[4].items():
                label = _part(Path(cfile).name, cfunction)
                by_part[label] = by_part.get(label, 0.0) + c[2] / total
            continue
        label = _part(Path(file).name, function)
        by_part[label] = by_part.get(label, 0.0) + v[2] / total
    functions = sorted(((f"{Path(k[0]).name}:{k[2]}", v[2] / total) for k, v in stats.items()), key=lambda r: -r[1])
    return {"parts": sorted(by_part.items(), key=lambda r: -r[1]), "functions": functions[:top]}


def _launch(spec: dict, timeout: float) -> dict:
    from benchmarks.launch import run_config

    return run_config(dict(spec, tool="step-parts"), "pinned", timeout)


def run_case(name: str, work: Path, quick: bool, repeats: int, profile: bool, timeout: float, rounds: int = 2,
             fmi: bool = False, log=print) -> dict:
    """Every variant of case ``name``, in turn, each in its own pinned process, ``rounds`` times over:
    {variant: the result of the round with the least CPU time}."""
    from benchmarks.cases import check_columns, ssp_folder

    case = CASES[name]
    system = case.system()
    folder = ssp_folder(system, work)
    pset = "default" if any(i.parameters for i in system.instances) else None
    base = {"case": name, "folder": str(folder), "columns": check_columns(system), "parameter_set": pset,
            "repeats": repeats, "quick": quick}
    out: dict[str, dict] = {}
    for k in range(rounds):
        for variant in VARIANTS + ((FMI_VARIANT,) if fmi else ()):
            spec = dict(base, variant=variant, profile=profile and k == 0 and variant == "harness-free")
            r = _launch(spec, timeout)
            log(f"  {name:13s} round {k + 1} {variant:22s} " +
                (f"{r['us']:8.2f} us per FMU step" if "us" in r else r.get("error", "?")))
            best = out.get(variant)
            if best is None or "us" not in best or ("us" in r and r["us"] < best["us"]):
                out[variant] = dict(r, profile=r.get("profile") or (best or {}).get("profile"))
    return out


def parts(results: dict) -> dict:
    """The per-FMU-step parts [us] from one case's variants (NaN where a variant failed)."""
    us = {k: v.get("us", math.nan) for k, v in results.items()}
    h, h0, e, e0 = us["harness"], us["harness-free"], us["ecos"], us["ecos-free"]
    return {
        "harness": h, "ecos": e, "ratio": h / e,
        "harness_fmus": h - h0, "ecos_fmus": e - e0,
        "harness_own": h0, "ecos_own": e0,
        "watch": h0 - us["harness-free-nowatch"], "recording": h0 - us["harness-free-onecol"],
        # the harness's cost per FMU step if its own part were Ecos's, the FMUs' Python as measured in it
        "floor_ratio": (h - h0 + e0) / e,
        # what calling the same FMUs through fmpy, ctypes and pythonfmu's C wrapper adds (NaN: not measured)
        "fmi_path": us.get(FMI_VARIANT, math.nan) - h,
    }


def goal_lines(rows: dict) -> list[tuple[str, bool | None, str]]:
    """(goal, met (None: not measured), evidence with the floor) per case: the harness's CPU time per FMU step
    at or below Ecos's."""
    out = []
    for name, p in rows.items():
        what = f"{name}: harness per FMU step <= Ecos's (CPU, pinned)"
        if not math.isfinite(p["ratio"]):
            out.append((what, None, "not measured"))
            continue
        out.append((what, p["ratio"] <= 1.0,
                    f"harness/Ecos = {p['ratio']:.2f} ({p['harness']:.1f} / {p['ecos']:.1f} us); the FMUs' Python "
                    f"{p['harness_fmus']:.1f} us in the harness, {p['ecos_fmus']:.1f} in Ecos; each tool's own part "
                    f"{p['harness_own']:.1f} / {p['ecos_own']:.1f} us; floor: with its own part at Ecos's, "
                    f"harness/Ecos = {p['floor_ratio']:.2f}"))
    return out


HEADER = ("case", "harness", "Ecos", "harness/Ecos", "FMUs' Python (h | E)", "tool's own (h | E)",
          "of it: div. watch", "recording (checked cols)")


def table(rows: dict) -> list[str]:
    lines = ["| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    for name, p in rows.items():
        lines.append(f"| {name} | {p['harness']:.1f} | {p['ecos']:.1f} | {p['ratio']:.2f} | "
                     f"{p['harness_fmus']:.1f} / {p['ecos_fmus']:.1f} | {p['harness_own']:.1f} / {p['ecos_own']:.1f} | "
                     f"{p['watch']:.1f} | {p['recording']:.1f} |")
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.step_parts", description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default=",".join(CASE_ORDER), help="comma-separated cases (default: all)")
    ap.add_argument("--quick", action="store_true", help="a tenth of the steps (timings rougher)")
    ap.add_argument("--repeats", type=int, default=3, help="runs per process; the least CPU time counts")
    ap.add_argument("--rounds", type=int, default=2, help="every variant in turn, this many times; the least counts")
    ap.add_argument("--profile", action="store_true", help="cProfile the harness's calls-free run")
    ap.add_argument("--fmi", action="store_true",
                    help="also the harness calling every FMU through fmpy and its C library (not in-process)")
    ap.add_argument("--work", default="results/step_parts", help="folder for the exported SSPs")
    ap.add_argument("--json", help="also write the raw results to this file")
    ap.add_argument("--timeout", type=float, default=600.0)
    args = ap.parse_args(argv)
    names = [c.strip() for c in args.cases.split(",") if c.strip()]
    bad = [c for c in names if c not in CASES]
    if bad or not names:
        raise SystemExit(f"--cases {args.cases!r}: unknown {', '.join(bad) or '(empty)'}; choose from "
                         f"{', '.join(CASE_ORDER)}")
    work = Path(args.work).resolve()
    work.mkdir(parents=True, exist_ok=True)
    raw, rows = {}, {}
    for name in names:
        raw[name] = run_case(name, work, args.quick, args.repeats, args.profile, args.timeout, args.rounds,
                             args.fmi)
        rows[name] = parts(raw[name])
        prof = raw[name]["harness-free"].get("profile")
        if prof:
            own = rows[name]["harness_own"]
            print(f"  {name}: the harness's own {own:.1f} us per FMU step (calls-free run) by part, cProfile's "
                  f"shares of CPU time: " + "; ".join(f"{p} {100 * s:.0f} % ({s * own:.1f} us)"
                                                      for p, s in prof["parts"]))
            print(f"  {name}: its functions by own time: " +
                  "; ".join(f"{f} {100 * s:.0f} %" for f, s in prof["functions"]))
    print("\nCPU time per FMU step [us], pinned, least of the repeats (h: harness jacobi-sampled, E: Ecos):")
    print("\n".join(table(rows)))
    for name, p in rows.items():
        if math.isfinite(p["fmi_path"]):
            print(f"  {name}: the same harness run calling its FMUs through fmpy, ctypes and the C wrapper costs "
                  f"{p['fmi_path']:+.1f} us per FMU step more than in-process")
    print()
    for what, met, evidence in goal_lines(rows):
        print(f"[{'n/a ' if met is None else ('MET ' if met else 'MISS')}] {what}: {evidence}")
    if args.json:
        Path(args.json).write_text(json.dumps({"raw": raw, "parts": rows}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
