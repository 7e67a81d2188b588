"""A sweep's points stepped as batches of variants (:mod:`harness.run.batch`), the default wherever the batch
applies: :func:`run_points` runs one batch (in this process or on a dask worker) and returns the same rows
:func:`harness.studies.sweep.run_point` returns one by one; :func:`run` spreads the points over batches (serially,
or one batch per dask task).

Each point's row holds its own run's numbers: the batch steps every variant with its scalar run's operations and
reruns on its own any variant that fails in it, so the quantities of interest, the errors and their messages are
those of ``sweep --no-batch``.  Only the quantities of interest are kept, reduced as the run goes where their
expression allows (:mod:`harness.reporting.qoi_stream`): a thousand points need no thousand time series.
``wall_time`` is a point's share of its batch's wall time (the batch's time over its points).
"""
from __future__ import annotations

import math
import time

from harness.studies.trial import one_line

CHUNK = 512   # most points in one batch (a dask task), so that a long sweep reports and resumes as it goes


def refusal(system_name, spec) -> str | None:
    """Why the sweep's points cannot run as batches (one line; the points then run one at a time), None when they
    can."""
    from harness import load
    from harness.run.batch import refusal as batch_refusal
    from harness.studies.sweep_cluster import system_on_worker

    try:
        system = load(system_on_worker(system_name))
    except Exception as e:   # noqa: BLE001 (the scalar path reports a system that does not load, point by point)
        return one_line(e)
    return batch_refusal(system, dict(spec.run))


def run_points(system_name, spec, points: list[dict]) -> list[dict]:
    """The rows of ``points`` (one batch, :func:`harness.run.batch.simulate_batch`); never raises: an error is
    part of its row, as in :func:`harness.studies.sweep.run_point`.  ``system_name``: a system name or file, or a
    :class:`~harness.studies.sweep_cluster.SystemFile`."""
    from harness import load
    from harness.run.batch import BatchOptions, Keep, simulate_batch
    from harness.studies.sweep_cluster import system_on_worker

    t0 = time.perf_counter()
    rows, variants, index = [], [], []
    for p in points:
        row = dict(p)
        row.update({name: math.nan for name in spec.outputs})
        try:
            params = spec.parameters(p)
            row.update({f"set:{k}": v for k, v in params.items() if k not in p})
            variants.append(params)
            index.append(len(rows))
        except Exception as e:  # noqa: BLE001 (recorded, never aborts the sweep)
            row["error"] = one_line(e)
        rows.append(row)
    try:
        run = simulate_batch(load(system_on_worker(system_name)), variants, dict(spec.run),
                             Keep(columns=(), reduce=tuple(spec.outputs.items())), BatchOptions())
    except Exception as e:  # noqa: BLE001 (the whole batch refused: every point says why)
        for i in index:
            rows[i]["error"] = one_line(e)
        run = None
    if run is not None:
        for i, r in zip(index, run.results):
            rows[i].update(r.values)
            rows[i]["error"] = r.value_error or r.error
    share = (time.perf_counter() - t0) / max(1, len(points))
    for row in rows:
        row.setdefault("error", "")
        row["wall_time"] = share
    return rows


def chunks(todo: list, workers: int) -> list[list]:
    """The points in batches: as many as the workers (two per worker where there are several workers and enough
    points, so one slow batch does not hold the others; one batch in this process), each at most :data:`CHUNK` points and, where there are enough, at
    least :data:`harness.run.batch.MIN_VARIANTS` (fewer cost more as a batch than one by one)."""
    from harness.run.batch import MIN_VARIANTS

    if not todo:
        return []
    parts = max(1, workers) * (2 if workers > 1 and len(todo) >= 4 * workers else 1)
    parts = max(1, min(parts, len(todo) // MIN_VARIANTS))     # each batch large enough to pay for itself
    size = min(CHUNK, max(1, math.ceil(len(todo) / parts)))
    return [todo[i:i + size] for i in range(0, len(todo), size)]


def run(system_name, spec, todo: list, client, workers: int, finished, progress) -> None:
    """Every point of ``todo`` in batches: serially here (``client`` None) or one batch per task on ``client``'s
    workers; ``finished(row)`` gets each row as its batch ends; ``progress(items, total)`` wraps the batches."""
    parts = chunks(todo, workers if client is not None else 1)
    if client is None:
        for part in progress(parts, len(parts)):
            for row in run_points(system_name, spec, part):
                finished(row)
        return
    from dask.distributed import as_completed

    from harness.studies.sweep_cluster import payload, shipped

    system = shipped(system_name)
    if not isinstance(system, str):
        system = client.submit(payload, system, key=f"system-file-{system.digest[:32]}")
    futures = [client.submit(run_points, system, spec, part, pure=False) for part in parts]
    try:
        for fut in progress(as_completed(futures), len(futures)):
            for row in fut.result():
                finished(row)
    finally:
        client.cancel(futures)


__all__ = ["run_points", "run", "refusal", "chunks", "CHUNK"]
