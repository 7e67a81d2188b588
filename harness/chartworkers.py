"""Chart workers: processes that import Matplotlib while a run steps, then draw the run's figures side by side.

``run SYSTEM --plot DIR`` draws two figures after the stepping; in the command's own process that adds
Matplotlib's import and both drawings, one after the other, to the wait.  With at least two CPUs available the
command starts one worker per figure before its own imports (:func:`start_early`); each worker imports numpy,
Matplotlib and :mod:`harness.chartdraw` on the other CPU while the command loads the drive and steps it, then
draws the :class:`harness.chartdraw.Figure` it is sent, so the figures are drawn at the same time.

Nothing is lost to a worker: a figure whose worker died, could not be started or did not answer is drawn in
the command's process instead, with a one-line warning naming the worker's exit status and the last line it
wrote; a figure that fails to draw fails the same way in the process (its error is the one reported).  The
protocol is pickles over the worker's stdin/stdout: a ``(Figure, out_dir, svg)`` in, ``("ok", paths)`` or
``("error", text)`` out; a worker ends at the end of its input (its parent closed it or exited).

Only light modules are imported here: the command imports this module before its own imports.
"""
from __future__ import annotations

import os
import pickle
import subprocess
import sys
import tempfile
from pathlib import Path

FIGURES = 2          # the run command's charts: over time and over one machine cycle
_early: "ChartWorkers | None" = None


def available_cpus() -> int:
    """The CPUs this process may run on (its affinity, e.g. under ``taskset``), else the machine's count."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):      # pragma: no cover - platforms without affinity
        return os.cpu_count() or 1


class ChartWorkers:
    """``count`` worker processes, started at once; :meth:`draw` hands each figure to one of them and
    collects the files; :meth:`close` ends them (also as a context manager).  ``drawn``: the figures the
    workers drew (the others were drawn in this process)."""

    def __init__(self, count: int = FIGURES):
        self._workers = [self._start() for _ in range(count)]
        self.drawn = 0

    def grow(self, count: int = FIGURES) -> "ChartWorkers":
        """Start workers until there are ``count``; returns self."""
        self._workers += [self._start() for _ in range(count - len(self._workers))]
        return self

    @staticmethod
    def _start():
        here = str(Path(__file__).resolve().parents[1])
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (here, os.environ.get("PYTHONPATH")) if p))
        log = tempfile.TemporaryFile()
        try:
            proc = subprocess.Popen([sys.executable, "-m", "harness.chartworkers"], stdin=subprocess.PIPE,
                                    stdout=subprocess.PIPE, stderr=log, env=env)
        except OSError as e:
            log.close()
            return (None, None, f"not started: {e}")
        return (proc, log, "")

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def draw(self, figures, out_dir: Path, svg: bool = False) -> list[Path]:
        """Draw ``figures`` (:class:`harness.chartdraw.Figure`) into ``out_dir`` and return the paths in the
        figures' order; each worker draws one at a time, figures beyond the workers' number in this process."""
        from harness.chartdraw import draw

        sent = []
        for k, fig in enumerate(figures):
            worker = self._workers[k] if k < len(self._workers) else None
            sent.append(worker is not None and self._send(worker, (fig, Path(out_dir), svg)))
        paths: list[Path] = []
        for k, fig in enumerate(figures):
            got = self._receive(self._workers[k]) if sent[k] else None
            if got is None:                       # no worker, or it failed: drawn here, the same figure
                paths += draw(fig, out_dir, svg)
            else:
                paths += got
                self.drawn += 1
        return paths

    def _send(self, worker, message) -> bool:
        proc = worker[0]
        if proc is None or proc.poll() is not None:
            self._warn(worker, "before it was sent a figure")
            return False
        try:
            pickle.dump(message, proc.stdin, protocol=pickle.HIGHEST_PROTOCOL)
            proc.stdin.flush()
        except (OSError, pickle.PicklingError) as e:
            self._warn(worker, f"when it was sent a figure ({type(e).__name__}: {e})")
            return False
        return True

    def _receive(self, worker) -> list[Path] | None:
        """The worker's paths, or None after a warning when it failed (the figure is then drawn here: an error
        of the drawing itself is raised there again, as in a run without workers)."""
        try:
            status, value = pickle.load(worker[0].stdout)
        except (EOFError, OSError, pickle.UnpicklingError, ValueError) as e:
            self._warn(worker, f"before it answered ({type(e).__name__})")
            return None
        if status == "ok":
            return value
        return None

    @staticmethod
    def _warn(worker, when: str) -> None:
        proc, log, why = worker
        if proc is not None:
            try:
                proc.wait(timeout=1.0)
            except subprocess.TimeoutExpired:
                pass
            why = f"exit status {proc.returncode}" if proc.returncode is not None else "still running"
        last = ""
        if log is not None:
            log.seek(0)
            lines = [ln for ln in log.read().decode(errors="replace").splitlines() if ln.strip()]
            last = f", last line: {lines[-1].strip()}" if lines else ""
        print(f"warning: a chart worker failed {when} ({why}{last}); the chart is drawn in this process",
              file=sys.stderr)

    def close(self) -> None:
        """End the workers: their input is closed (they leave at its end); one that does not within a second is
        killed."""
        for proc, log, _ in self._workers:
            if proc is not None:
                for stream in (proc.stdin, proc.stdout):
                    try:
                        stream.close()
                    except OSError:
                        pass
                try:
                    proc.wait(timeout=1.0)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()
            if log is not None:
                log.close()
        self._workers = []


def start_early() -> None:
    """Start the first of the run command's chart workers now, before the command's own imports, where workers
    pay (at least two CPUs): it imports on the other CPU while the command imports; the command starts the
    others when its imports are done (:func:`for_run`), so no more processes import at once than there are
    CPUs on a two-CPU machine."""
    global _early
    if _early is None and available_cpus() >= 2:
        _early = ChartWorkers(1)


def for_run() -> ChartWorkers | None:
    """The run command's chart workers, one per figure: those :func:`start_early` started, completed (handed
    over once), else new ones; None with one CPU available (the figures are then drawn in the command's
    process, one after the other, as the workers could only take turns with it)."""
    found = take()
    if found is None and available_cpus() < 2:
        return None
    return (found or ChartWorkers(0)).grow(FIGURES)


def take() -> ChartWorkers | None:
    """The workers :func:`start_early` started, handed over once (None when none were started)."""
    global _early
    found, _early = _early, None
    return found


def _serve() -> None:
    """A worker's life: imports, then figures from stdin, answers on stdout, until its input ends."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)    # Ctrl-C is the command's: it closes the workers
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr                          # nothing printed may get into the answers
    from harness import chartdraw
    from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: F401 (what a drawing uses, imported now)
    from matplotlib.patches import Patch  # noqa: F401

    while True:
        try:
            fig, out_dir, svg = pickle.load(inp)
        except EOFError:     # the command closed the input or ended: leave at once (no interpreter teardown)
            sys.stderr.flush()
            os._exit(0)
        try:
            answer = ("ok", chartdraw.draw(fig, out_dir, svg))
        except Exception as e:  # noqa: BLE001 (the command draws it again and reports the error itself)
            answer = ("error", f"{type(e).__name__}: {e}")
        pickle.dump(answer, out, protocol=pickle.HIGHEST_PROTOCOL)
        out.flush()


if __name__ == "__main__":
    _serve()
