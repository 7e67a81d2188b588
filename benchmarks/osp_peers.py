"""OSP systems (OspSystemStructure.xml) and libcosim's scenario files in libcosim, for comparison with the harness.

``run_osp_libcosim(path, stop_time, outputs, scenario=None)`` runs the file as libcosim loads it
(``cosim_osp_config_execution_create``) to ``stop_time`` and returns the toolkit's result type: a DataFrame
indexed by the times libcosim reports, one column per ``Instance.variable``, with one row per base step of the
execution (ECCO: per step it took).  An instance stepping at its own rate is recorded by libcosim only at the
end of its own steps; its value in between is its last sample (as the harness holds it), and ``attrs["own"]``
gives, per column, the rows where libcosim recorded it.

libcosim 0.11 (libcosimpy 0.0.6) refuses a file without an ``<Algorithm>`` element although the schema gives
it the default ``fixedStep`` ("Invalid algorithm choice"): such a file is run from a copy with the element added
(its FMU sources made absolute, its OspModelDescriptions copied beside it).
"""
from __future__ import annotations

import shutil
import tempfile
from ctypes import POINTER, c_double, c_int64, c_size_t, c_uint32
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pandas as pd

from harness.errors import SystemDescriptionError
from benchmarks.peers import _libcosim, _libcosim_error, libcosim_targets

NS_STRUCTURE = "http://opensimulationplatform.com/MSMI/OSPSystemStructure"


def _with_algorithm(path: Path, folder: Path) -> Path:
    """``path`` itself when it names its algorithm, else a copy in ``folder`` with ``<Algorithm>fixedStep``."""
    tree = ET.parse(path)
    root = tree.getroot()
    ns = root.tag[1:].split("}")[0] if root.tag.startswith("{") else ""
    q = (lambda t: f"{{{ns}}}{t}") if ns else (lambda t: t)
    if root.find(q("Algorithm")) is not None:
        return path
    ET.register_namespace("", ns)
    order = ["StartTime", "EndTime", "BaseStepSize"]
    at = max([i + 1 for i, c in enumerate(root) if c.tag in {q(t) for t in order}], default=0)
    el = ET.Element(q("Algorithm"))
    el.text = "fixedStep"
    root.insert(at, el)
    for sim in root.iter(q("Simulator")):
        src = sim.get("source")
        if src and "://" not in src and not Path(src).is_absolute():
            sim.set("source", str((path.parent / src).resolve()))
    for omd in path.parent.glob("*_OspModelDescription.xml"):
        shutil.copyfile(omd, folder / omd.name)
    out = folder / path.name
    tree.write(out, encoding="utf-8", xml_declaration=True)
    return out


def _samples(observer, index: int, reference: int, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(step numbers, times [ns], values) of one Real variable from step 0, as many as libcosim holds."""
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy._internal import libcosimc, wrap_function

    get = wrap_function(lib=libcosimc(), funcname="cosim_observer_slave_get_real_samples",
                        argtypes=[POINTER(CosimObserver), c_int64, c_uint32, c_int64, c_size_t,
                                  c_double * count, c_int64 * count, c_int64 * count], restype=c_int64)
    values, steps, times = (c_double * count)(), (c_int64 * count)(), (c_int64 * count)()
    got = get(observer.ptr(), index, reference, 0, count, values, steps, times)
    if got < 0:
        raise _libcosim_error("read samples", f"slave {index} reference {reference}:")
    return (np.frombuffer(steps, dtype=np.int64)[:got].copy(), np.frombuffer(times, dtype=np.int64)[:got].copy(),
            np.array(values[:got], dtype=float))


def _smallest_step(path: Path) -> float:
    """The smallest step libcosim may take in the file: its BaseStepSize (0.1 s when absent), or ECCO's least."""
    smallest = 0.1
    for el in ET.parse(path).getroot().iter():
        name = el.tag.rsplit("}", 1)[-1]
        if name in ("BaseStepSize", "MinimumStepSize"):
            smallest = min(smallest, float(el.text))
    return smallest


def run_osp_libcosim(path, stop_time: float, outputs: list, scenario=None) -> pd.DataFrame:
    """An OspSystemStructure.xml (or a folder holding one) in libcosim to ``stop_time`` [s] (module docstring);
    ``scenario``: a libcosim scenario file loaded at the start (its scenario manager)."""
    execution_cls, _, observer_cls, enums = _libcosim()
    from libcosimpy.CosimManipulator import CosimManipulator

    p = Path(path).resolve()
    if p.is_dir():
        p = p / "OspSystemStructure.xml"
    if not p.is_file():
        raise SystemDescriptionError(f"no OspSystemStructure file {p}")
    with tempfile.TemporaryDirectory(prefix="osp-libcosim-") as tmp:
        config = _with_algorithm(p, Path(tmp))
        max_steps = int(stop_time / _smallest_step(config) * (1 + 1e-9)) + 2
        try:
            execution = execution_cls.from_osp_config_file(str(config))
        except AssertionError as e:
            raise _libcosim_error("load OspSystemStructure", f"{p}:") from e
        targets = libcosim_targets(execution, enums, outputs)
        observer = observer_cls.create_time_series(buffer_size=max_steps + 1)
        if not execution.add_observer(observer):
            raise _libcosim_error("add observer")
        for index, reference in targets:
            if not observer.start_time_series(index, reference, enums.CosimVariableType.REAL):
                raise _libcosim_error("start time series", f"slave {index} reference {reference}:")
        if scenario is not None:
            manager = CosimManipulator.create_scenario_manager()
            if not execution.add_manipulator(manager) or not execution.load_scenario(manager, str(Path(scenario))):
                raise _libcosim_error("load scenario", f"{scenario}:")
        if not execution.simulate_until(int(round(stop_time * 1e9))):
            raise _libcosim_error("simulate", f"until {stop_time!r} s:")
        series = [_samples(observer, index, reference, max_steps + 1) for index, reference in targets]
    # the execution's steps: those of the instance recorded at every step (ECCO steps them all)
    steps, times = max(((s, t) for s, t, _ in series), key=lambda st: len(st[0]))
    data = np.empty((len(steps), len(outputs)))
    own = {}
    for k, (s, t, v) in enumerate(series):
        rows = np.searchsorted(steps, s)
        if not np.array_equal(steps[rows], s):
            raise SystemDescriptionError(f"{outputs[k]}: libcosim recorded it at steps the execution did not take")
        pos = np.searchsorted(s, steps, side="right") - 1   # its last sample at or before each step
        data[:, k] = v[pos]
        own[outputs[k]] = rows
    df = pd.DataFrame(data, columns=list(outputs), index=pd.Index(times / 1e9, name="time"))
    df.attrs.update(peer="libcosim", steps=len(steps) - 1, own=own)
    return df


def run_harness(path, scenario=None, **options) -> pd.DataFrame:
    """The harness on the same file, warnings silenced (for :func:`benchmarks.peers.run_isolated`: a fresh process
    loads each FMU's library afresh, as libcosim does; an FMU that keeps state in its globals, as OSP's dp-ship
    ThMPC and DPController do, would otherwise continue from an earlier run in the same process)."""
    import warnings

    from harness.run import simulate, simulate_scenario

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(path, **options) if scenario is None else simulate_scenario(path, scenario, **options)


__all__ = ["run_osp_libcosim", "run_harness"]
