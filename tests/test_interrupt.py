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

import numpy as np
import pandas as pd
import pytest

from childproc import wait_for_cpu

ROOT = Path(__file__).resolve().parents[1]


def _sigint_as_a_terminal_sends_it():
    """In the child: SIGINT back to its default, which Python turns into KeyboardInterrupt.  A test run started in
    the background of a non-interactive shell (``pytest &``) inherits SIGINT ignored, and a Python started with it
    ignored keeps ignoring it: these tests then saw the run finish instead of stop (measured)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start(args, cwd, **env_extra):
    env = dict(os.environ, PYTHONUNBUFFERED="1", **env_extra)
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


# a sweep that cannot finish before the test lets it (tests/foreign/plain_gate.py): its points k > 0 run through,
# the point k = -1 waits in its first step while the gate file exists.  The test interrupts the sweep once the 3
# free points are on disk, by that event: nothing it does races the sweep's end.  One held point, so one of two
# dask workers stays free for the others; the held point is stopped by the signal long before the 60 s after which
# the isolation of a foreign FMU (harness.fmi.isolated.DEFAULT_TIMEOUT) would fail it as hanging
SPEC = """\
stop_time: 0.05
step: 0.01
grid:
  PlainGate.k: [1.0, 2.0, 3.0, -1.0]
outputs:
  y_end: 'final(r["PlainGate.y"])'
"""


@pytest.mark.parametrize("workers", ["0", "2"])
def test_sigint_during_a_sweep_keeps_every_finished_point_and_resume_skips_them(tmp_path, workers):
    """Serial (--workers 0) and on a local dask cluster of two worker processes: after Ctrl-C every finished
    point is on disk, no worker process is left running and no semaphore is reported leaked."""
    import psutil

    from foreign_builds import plain_fmu

    fmu = plain_fmu("plain_gate.py", "PlainGate")
    spec = tmp_path / "s.yaml"
    spec.write_text(SPEC)
    out = tmp_path / "s.csv"
    partial = tmp_path / "s.partial.csv"
    gate = tmp_path / "gate"
    gate.write_text("closed")
    p = _start(["sweep", str(fmu), "--grid", str(spec), "--workers", workers, "--out", str(out)], ROOT,
               PRESSDRIVE_TEST_GATE=str(gate))
    # an event, not a time: the header and the 3 free points (600 s: only a broken sweep waits so long)
    deadline = time.monotonic() + 600
    while _lines(partial) < 4 and p.poll() is None:
        assert time.monotonic() < deadline, "the 3 free points were not written in 600 s"
        time.sleep(0.05)
    assert p.poll() is None, p.communicate()
    children = psutil.Process(p.pid).children(recursive=True)
    assert workers == "0" or len(children) >= 2, children  # the dask worker processes
    p.send_signal(signal.SIGINT)
    # the gate opens after the signal: a dask worker in the held point finishes it, so the cluster closes as after
    # any Ctrl-C; the sweep never records it (the interrupt is pending in it before any of its code runs again)
    gate.unlink()
    stdout, stderr = p.communicate(timeout=300)
    assert p.returncode == 130, (stdout, stderr)
    gone, alive = psutil.wait_procs(children, timeout=60)
    assert not alive, [c.cmdline() for c in alive]
    assert "leaked" not in stderr, stderr
    assert not out.exists()
    kept = pd.read_csv(partial)
    assert sorted(kept["PlainGate.k"]) == [1.0, 2.0, 3.0] and (kept["error"].isna() | (kept["error"] == "")).all()
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and f"3 of 4 points finished and kept in {partial}" in lines[0], stderr
    # resume: only the missing point runs; the final file has every point once, in the spec's order
    r = subprocess.run([sys.executable, "-m", "harness", "sweep", str(fmu), "--grid", str(spec), "--workers",
                        "0", "--out", str(out), "--resume"], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert "(3 taken from s.partial.csv)" in r.stdout
    df = pd.read_csv(out)
    assert list(df["PlainGate.k"]) == [1.0, 2.0, 3.0, -1.0] and not partial.exists()
    np.testing.assert_allclose(df["y_end"], df["PlainGate.k"] * 0.05, rtol=1e-12)   # y = k t at t = 0.05 s
    merged = df.set_index("PlainGate.k").loc[kept["PlainGate.k"], "y_end"].to_numpy()
    assert (merged == kept["y_end"].to_numpy()).all()   # the kept points were not run again


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


@pytest.mark.parametrize("sig, status, words", [(signal.SIGTERM, 143, "terminated (SIGTERM)"),
                                                (signal.SIGINT, 130, "interrupted (Ctrl-C)")])
def test_an_interrupt_an_import_reports_as_another_error_is_still_the_interrupt(monkeypatch, capsys, sig, status,
                                                                                 words):
    """The test above, made certain: a signal that lands inside numpy's C start-up comes out as an ImportError
    ("IMPORTANT: PLEASE READ THIS ..."; seen under load); the command still reports the signal, not the error."""
    import harness.__main__ as cli

    def numpy_like_import(*args, **kwargs):
        try:
            (cli._on_sigterm if sig == signal.SIGTERM else cli._on_sigint)(sig, None)
        except KeyboardInterrupt:
            raise ImportError("IMPORTANT: PLEASE READ THIS FOR ADVICE ON HOW TO SOLVE THIS ISSUE!") from None

    monkeypatch.setattr(cli, "build_parser", numpy_like_import)
    assert cli.main(["run", "two_inertia"]) == status
    assert capsys.readouterr().err.strip() == words
