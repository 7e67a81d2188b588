"""The co-simulation master: wire FMI 2.0 (and FMI 1.0) co-simulation FMUs into a system and run it.

    from harness import load, simulate
    df = simulate(load("two_inertia"), stop_time=1.0, step=1e-3, master="gauss-seidel", extrapolation=1)

The packages, by concern (ARCHITECTURE.md): :mod:`harness.fmi` (checked FMU wrappers of every kind),
:mod:`harness.model` (the system as data), :mod:`harness.master` (the masters: one stepping loop, the methods
by name, their parts), :mod:`harness.run` (``load``, ``simulate`` and the ``run`` command), :mod:`harness.ssp`,
:mod:`harness.reporting` (engineering quantities, charts, the HTML report), :mod:`harness.export` (a drive as one
FMU), :mod:`harness.studies`, :mod:`harness.synthesis`.  Heavy imports happen on first use.
"""
from __future__ import annotations

__all__ = ["load", "simulate", "simulate_scenario", "RunOptions", "bond_energy", "to_csv", "MASTERS", "export_fmu",
           "report", "modes"]


def report(result, path, system=None):
    """Write one self-contained HTML page of ``result`` at ``path`` (:mod:`harness.reporting.htmlreport`) and return its
    path: a run's result (the DataFrame of :func:`simulate`; ``system``: the drive, default: the one the run
    names), or a study's result that writes its own page (:func:`harness.studies.compare.compare`'s comparison,
    :func:`harness.studies.size.size`'s sizing; a sweep's table: :func:`harness.studies.sweep.report`)."""
    import pandas as pd

    from harness.reporting.htmlreport import check_report_path, write_run_report

    check_report_path(path)
    if hasattr(result, "report") and not isinstance(result, pd.DataFrame):
        return result.report(path)
    if not isinstance(result, pd.DataFrame) or "quantities" not in result.attrs:
        raise TypeError(f"harness.report: {type(result).__name__} is not a run's result (harness.simulate), a "
                        f"comparison or a sizing; a sweep's table: harness.studies.sweep.report(df, spec, path)")
    from harness.run import load

    return write_run_report(load(system if system is not None else result.attrs["system"]), result, path)


def export_fmu(system, out, outputs=None, fmi_version: int = 2):
    """Write ``system`` (a name in systems/, a .py or .ssp file, or a System) as one co-simulation FMU of the
    whole drive at ``out`` (:func:`harness.export.drive_fmu.export_fmu`) and return its path."""
    from harness.export.drive_fmu import export_fmu as export
    from harness.run import load

    return export(load(system), out, outputs=outputs, fmi_version=fmi_version)


def modes(system, parameters=None, points: int = 0):
    """The torsional natural frequencies and mode shapes of ``system`` linearised about its operating point
    (:func:`harness.studies.modes.modes`): a :class:`harness.studies.modes.Modes`."""
    from harness.studies.modes import modes as find

    return find(system, parameters, points)


def __getattr__(name):
    if name in ("load", "simulate", "simulate_scenario", "RunOptions"):
        from harness import run

        return getattr(run, name)
    if name in ("bond_energy", "to_csv"):
        from harness import results

        return getattr(results, name)
    if name == "MASTERS":
        from harness.master import MASTERS

        return MASTERS
    raise AttributeError(f"module 'harness' has no attribute {name!r}")
