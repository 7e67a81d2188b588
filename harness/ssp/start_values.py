"""The connected inputs' consistent start values of a system, computed by initializing it with its master
(what the SSP export binds as the inputs' start values, :func:`harness.ssp.export.export_ssp`)."""
from __future__ import annotations

from harness.model import System, model_description, resolve_fmu


def consistent_inputs(system: System) -> dict[str, dict]:
    """Instance -> {input: value} of every connected input at the start of the default experiment, as the
    harness initialises the system (:meth:`harness.masters.Master.initialize`: the outputs in initialization
    mode, each input from its source through the connection's transformation).

    The export binds them as the inputs' start values, because a host need not set inputs before
    initialization: FMPy's ``simulate_ssp`` sets none (only a parameter set), and an FMU that takes a state
    from an input (a motor's rotor angle from its pulley's, a four-bar's rocker from its crank) then starts
    from the input's FMU default, 0, and the exported bed drive in FMPy would start with its bed far off
    (tests/test_host_accuracy.py runs it in FMPy from these start values)."""
    from harness.clock import NS as NS_PER_S
    from harness.fmi import open_instance, release
    from harness.masters import master_class

    paths = {inst.name: resolve_fmu(inst.fmu) for inst in system.instances}
    mds = {name: model_description(p) for name, p in paths.items()}
    exp = system.experiment
    start = float(exp.start_time) if exp is not None else 0.0
    fmus: dict = {}
    m = None
    try:
        for inst in system.instances:
            fmus[inst.name] = open_instance(paths[inst.name], inst.name, logging_on=False)
        m = master_class(exp.master if exp is not None else "jacobi")(fmus, system.all_connections(mds),
                                                                      system.bonds)
        m.initialize(int(round(start * NS_PER_S)), None, None, {i.name: dict(i.parameters) for i in system.instances})
        out: dict[str, dict] = {}
        for c in system.all_connections(mds):
            inst, var = c.target.split(".", 1)
            out.setdefault(inst, {})[var] = fmus[inst].get_value(var)
        return out
    finally:
        release(m, fmus)
