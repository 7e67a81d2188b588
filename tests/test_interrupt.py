"""Ctrl-C (SIGINT) keeps the computed work: a run writes its finished part to OUT.partial.csv, a sweep keeps
every finished point in OUT.partial.csv and ``--resume`` skips them.  Each test starts the CLI in a subprocess,
waits for progress, sends SIGINT and reads what is on disk."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from childproc import wait_for_cpu

ROOT = Path(__file__).resolve().parents[1]


def _sigint_as_a_terminal_sends_it():
    """In the child: SIGINT back to its default, which Python turns into KeyboardInterrupt.  A test run started in
    the background of a non-interactive shell (``pytest &``) inherits SIGINT ignored, and a Python started with it
    ignored keeps ignoring it: these tests then saw the run finish instead of stop (measured)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start(args, cwd):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    return subprocess.Popen([sys.executable, "-m", "harness", *args], cwd=cwd, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=_sigint_as_a_terminal_sends_it)


def _lines(path: Path) -> int:
    return sum(1 for _ in open(path)) if path.exists() else 0


def test_sigint_during_a_run_writes_the_finished_part_marked(tmp_path):
    out = tmp_path / "bed.csv"
    # 60 s of the bed drive takes far longer than we wait
    p = _start(["run", "bed_drive", "--stop-time", "60", "--out", str(out)], ROOT)
    wait_for_cpu(p, 6.0)          # the loading takes about 3 s of CPU: stepping by then
    p.send_signal(signal.SIGINT)
    stdout, stderr = p.communicate(timeout=60)
    assert p.returncode == 130, (stdout, stderr)
    assert not out.exists()                      # the whole-result name is never used for a partial result
    partial = tmp_path / "bed.partial.csv"
    df = pd.read_csv(partial, index_col="time")
    assert len(df) > 10 and 0 < df.index[-1] < 60
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "interrupted (Ctrl-C)" in lines[0] and str(partial) in lines[0], stderr
    assert "Traceback" not in stderr


SPEC = """\
system: two_inertia
stop_time: 0.5
step: 1.0e-4
master: gauss-seidel
grid:
  b.c: [50.0, 60.0, 70.0, 80.0, 90.0, 100.0, 110.0, 120.0, 130.0, 140.0, 150.0, 160.0, 170.0, 180.0]
outputs:
  w_end: 'final(r["a.flange.w"])'
"""


@pytest.mark.parametrize("workers", ["0", "2"])
def test_sigint_during_a_sweep_keeps_every_finished_point_and_resume_skips_them(tmp_path, workers):
    """Serial (--workers 0) and on a local dask cluster of two worker processes: after Ctrl-C every finished
    point is on disk, no worker process is left running and no semaphore is reported leaked."""
    import psutil

    spec = tmp_path / "s.yaml"
    spec.write_text(SPEC)
    out = tmp_path / "s.csv"
    partial = tmp_path / "s.partial.csv"
    p = _start(["sweep", "two_inertia", "--grid", str(spec), "--workers", workers, "--out", str(out)], ROOT)
    deadline = time.time() + 180
    while _lines(partial) < 3 and time.time() < deadline and p.poll() is None:  # header + 2 points
        time.sleep(0.2)
    assert p.poll() is None, p.communicate()
    children = psutil.Process(p.pid).children(recursive=True)
    assert workers == "0" or len(children) >= 2, children  # the dask worker processes
    p.send_signal(signal.SIGINT)
    stdout, stderr = p.communicate(timeout=90)
    assert p.returncode == 130, (stdout, stderr)
    gone, alive = psutil.wait_procs(children, timeout=30)
    assert not alive, [c.cmdline() for c in alive]
    assert "leaked" not in stderr, stderr
    assert not out.exists()
    kept = pd.read_csv(partial)
    assert 2 <= len(kept) < 14 and (kept["error"].isna() | (kept["error"] == "")).all()
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and f"{len(kept)} of 14 points finished and kept in {partial}" in lines[0], stderr
    # resume: only the missing points run; the final file has every point once, in the spec's order
    r = subprocess.run([sys.executable, "-m", "harness", "sweep", "two_inertia", "--grid", str(spec), "--workers",
                        "0", "--out", str(out), "--resume"], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert f"({len(kept)} taken from s.partial.csv)" in r.stdout
    df = pd.read_csv(out)
    assert list(df["b.c"]) == [50.0 + 10 * k for k in range(14)]
    assert not partial.exists()
    merged = df.set_index("b.c").loc[kept["b.c"], "w_end"].to_numpy()
    assert (merged == kept["w_end"].to_numpy()).all()   # the kept points were not run again


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="watches the child's start-up in /proc")
@pytest.mark.parametrize("sig, status, words", [(signal.SIGTERM, 143, "terminated (SIGTERM)"),
                                                (signal.SIGINT, 130, "interrupted (Ctrl-C)")])
def test_a_signal_while_the_command_starts_gets_the_usual_message(tmp_path, sig, status, words):
    """The signal arrives while the command still imports its modules (numpy's library just mapped, pandas and
    the toolkit not yet): it used to end with an ImportError of a partially initialised module (the SIGTERM
    handler imported harness.run) or a traceback, instead of the usual one line and status."""
    p = _start(["run", "two_inertia", "--stop-time", "0.01", "--out", str(tmp_path / "x.csv")], tmp_path)
    maps = Path(f"/proc/{p.pid}/maps")
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and p.poll() is None:
        try:
            if "numpy" in maps.read_text():
                break
        except OSError:
            pass
        time.sleep(0.002)
    p.send_signal(sig)
    out, err = p.communicate(timeout=120)
    assert p.returncode == status, (p.returncode, err)
    assert err.strip() == words, err
    assert not (tmp_path / "x.csv").exists()
