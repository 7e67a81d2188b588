"""Subprocess entry of the benchmark: ``python -m benchmarks.worker '<json>'`` runs ONE configuration and
prints ``RESULT <json>`` as its last line (``error`` instead of the timings when it failed)."""
from __future__ import annotations

import json
import sys
import warnings


def main(argv: list[str] | None = None) -> int:
    spec = json.loads((argv if argv is not None else sys.argv[1:])[0])
    warnings.simplefilter("ignore")
    from benchmarks import runners

    try:
        if spec["tool"] == "step-parts":
            from benchmarks import step_parts

            out = step_parts.measure(spec)
        elif spec["tool"] == "sweep-overhead":
            out = runners.run_sweep_overhead(spec["case"], spec["quick"])
        elif spec["tool"] == "realtime":
            out = runners.run_realtime(spec["case"], spec["run"], spec["quick"], stand_in=spec.get("stand_in"))
        else:
            out = runners.run(spec["tool"], spec["folder"], spec["step"], spec["n"], spec["columns"],
                              spec.get("parameter_set"), spec.get("detector", True))
    except Exception as e:  # reported in the table, the benchmark goes on
        out = {"error": f"{type(e).__name__}: {' '.join(str(e).split())}"[:300]}
    sys.stdout.flush()
    print("RESULT " + json.dumps(out), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
