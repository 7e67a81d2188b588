"""What each component FMU costs per communication step in the press drives (a profile of each do_step).

    python -m benchmarks.fmu_costs [SYSTEM ...] [--steps N]

For every instance of a system (its declared model, default step): a short co-simulation records the inputs
the instance receives; then the instance's slave class (fmus/components, the code inside the FMU) replays
them alone, in this process, and the time of ``do_step`` and of reading all outputs (``get_real``, which
evaluates the outputs) is measured per call.  This is the part of a co-simulation step that no master can
save; the master's share is what the benchmark's per-FMU-step cost adds to it.
"""
from __future__ import annotations

import argparse
import time
import warnings

SYSTEMS = ("feeder_gto52", "bed_drive", "spine_knife", "proof_press", "two_inertia")


def _slave(declaration, name: str, parameters: dict):
    from fmus.slave import fmu_class

    slave = fmu_class(declaration)(instance_name=name, resources=None, visible=0, logger=0)
    by_name = {v.name: v for v in slave.vars.values()}
    for key, value in parameters.items():
        v = by_name[key]
        if type(v).__name__ == "Integer":
            slave.set_integer([v.value_reference], [int(value)])
        else:
            slave.set_real([v.value_reference], [float(value)])
    return slave, by_name


def component_costs(system_name: str, steps: int = 400) -> list[dict]:
    """One row per instance: FMU, fidelity, do_step and get_real [us per call] over ``steps`` replayed steps."""
    from harness import load, simulate
    from harness.model import model_name
    from harness.studies.reference import component_classes

    system = load(system_name)
    exp = system.experiment
    classes = component_classes()
    inputs = {}
    for inst in system.instances:
        cls = classes[model_name(inst.fmu)]
        inputs[inst.name] = (cls, list(cls.model.inputs), list(cls.model.outputs))
    columns = [f"{name}.{u}" for name, (_, ins, _) in inputs.items() for u in ins]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = simulate(system, stop_time=steps * exp.step, step=exp.step, output=columns)
    rows = []
    for inst in system.instances:
        cls, ins, outs = inputs[inst.name]
        slave, var = _slave(cls, inst.name, inst.parameters)
        vin = [var[u].value_reference for u in ins]
        vout = [var[y].value_reference for y in outs]
        u = df[[f"{inst.name}.{x}" for x in ins]].to_numpy().tolist() if ins else [[]] * len(df)
        slave.setup_experiment(0.0, None, None)
        slave.enter_initialization_mode()
        slave.set_real(vin, u[0])
        slave.exit_initialization_mode()
        step_time = get_time = 0.0
        n = len(df) - 1
        for k in range(n):
            slave.set_real(vin, u[k])
            t0 = time.perf_counter()
            slave.do_step(df.index[k], exp.step)
            t1 = time.perf_counter()
            slave.get_real(vout)
            t2 = time.perf_counter()
            step_time += t1 - t0
            get_time += t2 - t1
        rows.append({"system": system_name, "instance": inst.name, "fmu": cls.__name__,
                     "fidelity": inst.parameters.get("fidelity", ""), "step": exp.step,
                     "do_step_us": 1e6 * step_time / n, "get_real_us": 1e6 * get_time / n})
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.fmu_costs", description=__doc__.splitlines()[0])
    ap.add_argument("systems", nargs="*", default=list(SYSTEMS), help="systems (default: every press drive)")
    ap.add_argument("--steps", type=int, default=400, help="replayed steps per instance")
    args = ap.parse_args(argv)
    print(f"{'system':13s} {'instance':10s} {'FMU':18s} {'fidelity':>8s} {'do_step [us]':>13s} {'get_real [us]':>14s}")
    for name in args.systems:
        for r in component_costs(name, args.steps):
            print(f"{r['system']:13s} {r['instance']:10s} {r['fmu']:18s} {str(r['fidelity']):>8s} "
                  f"{r['do_step_us']:13.1f} {r['get_real_us']:14.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
