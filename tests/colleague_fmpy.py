"""Run FMUs with FMPy's simulate_fmu as a colleague does, and write what came out (tests/test_handoff.py).

    python colleague_fmpy.py jobs.json results.json

jobs.json: a list of {"fmu", "stop", "step", "fmi_type"};
results.json: per FMU (its path in jobs.json), its result as {column: [values]} or {"error": one line}, and under
"_versions" the Python and numpy that ran them.  The builder runs this same file with its own Python, the colleague with
theirs (a virtualenv of another Python version with nothing but fmpy), so the two are compared value for value.
Standard library and fmpy only: the colleague has nothing else.  A script, not a test module.
"""
import json
import os
import sys

from fmpy import simulate_fmu


def main(jobs_file: str, results_file: str) -> None:
    import numpy

    with open(jobs_file, encoding="utf-8") as f:
        jobs = json.load(f)
    out = {"_versions": {"python": sys.version.split()[0], "numpy": numpy.__version__}}
    for job in [None, *jobs]:   # the file written before the first FMU and after each
        if job is not None:
            try:
                r = simulate_fmu(job["fmu"], stop_time=job["stop"], step_size=job["step"],
                                 output_interval=job["step"], fmi_type=job.get("fmi_type"))
                out[job["fmu"]] = {n: r[n].tolist() for n in r.dtype.names}
            except Exception as e:   # one line per FMU; the others still run
                out[job["fmu"]] = {"error": " ".join(f"{type(e).__name__}: {e}".split())}
        with open(results_file, "w", encoding="utf-8") as f:
            json.dump(out, f)
    sys.stdout.flush()
    # pythonfmu's wrappers keep references into this interpreter: leave without tearing it down
    os._exit(0)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
