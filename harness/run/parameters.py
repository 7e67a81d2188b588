"""The arguments of a run (:mod:`harness.run`): ``Instance.param`` values split per instance
(:func:`split_parameters`), ``--set`` items (:func:`parse_sets`), positive times, and :func:`simulate`'s
keyword arguments given under FMPy's or former names (:func:`_renamed`)."""

from __future__ import annotations

import difflib
import math
import warnings

from harness.errors import SystemDescriptionError
from harness.model import System
from harness.signals import full_name


def _positive(name: str, value, unit: str = "s") -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        text = repr(float(value)) if isinstance(value, (int, float)) and not isinstance(value, bool) else repr(value)
        raise SystemDescriptionError(f"{name} = {text} is not admissible: must be a positive finite number"
                                     + (f" [{unit}]" if unit else ""))
    return float(value)


def split_parameters(system: System, parameters: dict | None) -> dict[str, dict]:
    """Instance name -> {parameter: value}: the system's values overridden by ``{"Instance.param": value}`` (in
    a system of one FMU also by the FMU's own names, as FMPy takes them: :func:`harness.signals.full_name`)."""
    out = {inst.name: dict(inst.parameters) for inst in system.instances}
    for ref, value in (parameters or {}).items():
        inst, dot, var = full_name(system, ref).partition(".")
        if not dot or not var:
            raise SystemDescriptionError(f"parameter {ref!r} must be written 'Instance.parameter'")
        if inst not in out:
            close = difflib.get_close_matches(inst, list(out), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise SystemDescriptionError(f"parameter {ref}: unknown instance {inst!r}{hint} "
                                         f"(instances: {', '.join(out)})")
        out[inst][var] = value
    return out


# FMPy's names (fmpy.simulate_fmu) and this function's older ones, each mapped to its one spelling here
_ALIASES = {"step_size": "step", "relative_tolerance": "tolerance"}  # FMPy's, the same meaning (docs/fmpy.md)


_DEPRECATED = {"parameters": "start_values", "outputs": "output"}    # still accepted, with a DeprecationWarning


# FMPy's other arguments: what takes their place here (one line each, raised as a TypeError)
_FMPY_ONLY = {
    "solver": "a model exchange FMU is integrated by CVODE inside the master (harness.fmi.me)",
    "fmi_type": "a co-simulation FMU runs as one; a model exchange-only FMU is integrated by CVODE",
    "validate": "the system is always validated against the FMUs before the run",
    "record_events": "results hold the communication points (or every output_interval)",
    "apply_default_start_values": "an FMU keeps its declared start values unless start_values sets them",
    "timeout": "Ctrl-C or SIGTERM ends a run and keeps what it computed (RunInterrupted.partial)",
    "debug_logging": "use options=RunOptions(logging=...)",
    "logger": "an FMU's log goes into the one-line error of a failed call",
    "fmi_call_logger": "an FMU's log goes into the one-line error of a failed call",
    "step_finished": "the result is returned whole; a stopped run returns what it computed",
    "set_input_derivatives": "input derivatives are set from extrapolation >= 1 for FMUs that can interpolate",
    "visible": "FMUs run in batch mode", "remote_platform": "FMUs run on this platform",
    "model_description": "the modelDescription is read once and cached (harness.fmi.cache)",
    "fmu_instance": "the master instantiates every FMU itself", "fmu_state": "runs start from initialization",
    "initialize": "runs start from initialization", "terminate": "every run ends with fmi2Terminate",
    "early_return_allowed": "FMI 3.0 early return is not used", "use_event_mode": "FMI 3.0 event mode is not used",
    "set_stop_time": "the stop time is always passed to the FMUs",
}


def _renamed(given: dict, canonical: dict) -> dict:
    """The keyword arguments of :func:`simulate` given under FMPy's name or an old one (``given``), under
    their name here; ``canonical`` holds the values given under that name.  The same argument given twice
    (``step`` and ``step_size``), an FMPy argument without a counterpart or an unknown name is a TypeError
    in one line."""
    out = {}
    for name, value in given.items():
        if name in _DEPRECATED:
            warnings.warn(f"simulate(): {name}= is now {_DEPRECATED[name]}= (the name fmpy.simulate_fmu uses)",
                          DeprecationWarning, stacklevel=3)
            here = _DEPRECATED[name]
        elif name in _ALIASES:
            here = _ALIASES[name]
        elif name in _FMPY_ONLY:
            raise TypeError(f"simulate() has no argument {name!r} (fmpy.simulate_fmu's): {_FMPY_ONLY[name]}")
        else:
            raise TypeError(f"simulate() got an unexpected keyword argument {name!r}")
        if value is None:
            continue
        if canonical.get(here) is not None or here in out:
            raise TypeError(f"simulate(): {name}= and {here}= are the same argument ({name} is FMPy's or the "
                            f"former name of {here}): give one")
        out[here] = value
    return out


# -- CLI ----------------------------------------------------------------------------------------------------------
def _value(text: str):
    t = text.strip()
    if t.lower() in ("true", "false"):
        return t.lower() == "true"
    try:
        return int(t)
    except ValueError:
        pass
    try:
        return float(t)
    except ValueError:
        return t


def parse_sets(items: list[str] | None) -> dict:
    out = {}
    for item in items or []:
        name, eq, value = item.partition("=")
        if not eq or not name.strip() or not value.strip():
            raise SystemDescriptionError(f"--set {item!r}: expected Instance.param=VALUE")
        out[name.strip()] = _value(value)
    return out
