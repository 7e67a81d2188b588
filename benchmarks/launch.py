"""One benchmark configuration in a fresh worker process (``benchmarks.worker``), pinned to CPU 0 or not.

Its own module so that the driver (``benchmarks.bench``) and the coupling goals (``benchmarks.coupling``), which
the driver runs, both launch workers without importing each other."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run_config(spec: dict, mode: str, timeout: float, worker: tuple[str, ...] = ("benchmarks.worker",)) -> dict:
    """One configuration in a fresh subprocess (pinned to CPU 0 with taskset in mode 'pinned'): ``python -m``
    ``worker`` (a module and its first arguments) with ``spec`` as JSON, whose last ``RESULT`` line is returned."""
    cmd = [sys.executable, "-m", *worker, json.dumps(spec)]
    if mode == "pinned":
        if shutil.which("taskset") is None:
            return {"error": "taskset not found: cannot pin"}
        cmd = ["taskset", "-c", "0"] + cmd
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, cwd=str(ROOT))
    except subprocess.TimeoutExpired:
        return {"error": f"timed out after {timeout:g} s"}
    for line in reversed(proc.stdout.splitlines()):
        if line.startswith("RESULT "):
            return json.loads(line[len("RESULT "):])
    tail = " ".join((proc.stderr or "").strip().splitlines()[-2:])
    return {"error": f"worker exit code {proc.returncode}: {tail}"[:300]}
