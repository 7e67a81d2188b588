"""Waiting for a child process by the work it has done, not by the wall clock: on a loaded machine a fixed sleep
may end before the child has imported its modules, let alone started stepping."""
from __future__ import annotations

import os
import subprocess
import time
from pathlib import Path


def cpu_seconds(pid: int) -> float:
    """The CPU time (user + system) the process has used so far, from /proc."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def wait_for_cpu(p: subprocess.Popen, seconds: float, *, at_least: float = 8.0, timeout: float = 600.0) -> None:
    """Return once the child has used ``seconds`` of CPU time and ``at_least`` seconds of wall time have passed
    (where /proc is absent: the wall time alone); fail if it ends first or ``timeout`` passes."""
    start = time.monotonic()
    while True:
        assert p.poll() is None, ("the child ended before it was busy", p.communicate())
        waited = time.monotonic() - start
        try:
            busy = cpu_seconds(p.pid) >= seconds
        except OSError:
            busy = True
        if waited >= at_least and busy:
            return
        assert waited < timeout, f"the child used less than {seconds} s of CPU in {timeout} s"
        time.sleep(0.1)


# the command line of a child that runs ``python -m harness`` as where neither Parquet engine is installed (the
# test extras install fastparquet): both names are None in sys.modules, so neither finds nor imports
_NO_PARQUET = ("import runpy, sys; sys.modules.update(pyarrow=None, fastparquet=None); sys.argv[0] = 'harness'; "
               "runpy.run_module('harness', run_name='__main__')")


def harness_command(parquet: bool = True) -> list[str]:
    """``[python, -m, harness]``, or with ``parquet=False`` the same as where no Parquet engine is installed."""
    import sys

    return [sys.executable, *(("-m", "harness") if parquet else ("-c", _NO_PARQUET))]
