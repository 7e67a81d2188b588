"""Which content kind runs in which tool: the measured table of docs/howto/foreign.md.

    python -m benchmarks.content_matrix [--kinds fmi1-cs,ssp-units] [--tools ours,fmpy] [--timeout 120]

Each content kind (an FMI interface, or an SSP feature) is built from the test content in tests/ (Reference-FMUs
with cmake, pythonfmu / pythonfmu3 builds, the vendored FMI 1.0 identity FMU), then run in each tool (the
harness, FMPy, OMSimulator, libcosim, Ecos) in a SUBPROCESS of its own with a timeout, because some tools abort
or segfault on content they do not take (see benchmarks/peers.py).  A cell is judged from what happened:

* ``runs, agrees with ours to X``: X is the largest difference of any common output at a common time point,
  relative to that output's largest magnitude in our run; agreement means X <= AGREE;
* ``runs, differs (X)``: larger X, or other time points;
* ``cannot load: <the tool's error>`` (it failed before stepping), ``refused: <error>`` (it failed while
  running), ``crashes (exit N)`` (the process died), ``timed out``.

The table goes to stdout and results/content_matrix.md, the cells to results/content_matrix.csv.  Nothing is
assumed per tool: every cell comes from a run.
"""
from __future__ import annotations

import argparse
import csv
import json
import shutil
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
TESTS = ROOT / "tests"
TOOLS = ("ours", "fmpy", "omsimulator", "libcosim", "ecos")
TOOL_NAMES = {"ours": "ours", "fmpy": "FMPy", "omsimulator": "OMSimulator", "libcosim": "libcosim", "ecos": "Ecos"}
AGREE = 1e-4          # relative; ME kinds are integrated by each tool's own solver, so not bit for bit
TINY = 1e-12          # floor of an output's magnitude when it is zero throughout


@dataclass
class Content:
    """One kind's test content: an FMU (``fmu`` True) or an SSP (archive or folder) and what to record.

    ``outputs``: for an FMU, variable names; for an SSP, 'a/b/instance.variable' (nested systems as a path, the
    harness's naming).  ``starts``: start values of the FMU alone.  ``parameter_set``: the .ssv's name (Ecos
    applies a parameter set only when named)."""
    kind: str
    label: str
    path: str
    fmu: bool
    outputs: list
    stop: float
    step: float
    start: float = 0.0
    me: bool = False
    starts: dict = field(default_factory=dict)
    root: str = "s"
    parameter_set: str | None = None


# ------------------------------------------------------------------------------------------- building content
def _run(cmd: list, cwd: Path | None = None) -> None:
    r = subprocess.run([str(c) for c in cmd], cwd=cwd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd[:3]))} failed: {r.stderr.strip()[-300:]}")


def reference_fmus(work: Path, version: int) -> dict[str, Path]:
    """tests/reference_fmus built with cmake for FMI ``version`` (once per work folder)."""
    out = work / f"reference{version}"
    if not (out / "fmus" / "VanDerPol.fmu").is_file():
        out.mkdir(parents=True, exist_ok=True)
        _run(["cmake", TESTS / "reference_fmus", f"-DFMI_VERSION={version}", "-DCMAKE_BUILD_TYPE=Release",
              "-DCMAKE_C_FLAGS=-Wno-error=stringop-truncation"], out)
        _run(["cmake", "--build", ".", "-j", "2"], out)
    return {p.stem: p for p in (out / "fmus").glob("*.fmu")}


def _pythonfmu(work: Path, module: str, script: Path, model: str) -> Path:
    out = work / module
    fmu = out / f"{model}.fmu"
    if not fmu.is_file():
        out.mkdir(parents=True, exist_ok=True)
        _run([sys.executable, "-m", module, "build", "-f", script, "-d", out])
    return fmu


SSD = ('<?xml version="1.0" encoding="UTF-8"?>\n<ssd:SystemStructureDescription version="1.0" name="{name}"'
       ' xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"'
       ' xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"'
       ' xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"'
       ' xmlns:ssm="http://ssp-standard.org/SSP1/SystemStructureParameterMapping">'
       '<ssd:System name="s">{body}</ssd:System>'
       '<ssd:DefaultExperiment startTime="{start}" stopTime="{stop}"/></ssd:SystemStructureDescription>')
SSV = ('<?xml version="1.0" encoding="UTF-8"?>\n<ssv:ParameterSet version="1.0" name="p"'
       ' xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"'
       ' xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"><ssv:Parameters>{}</ssv:Parameters>'
       '{}</ssv:ParameterSet>')
SSM = ('<?xml version="1.0" encoding="UTF-8"?>\n<ssm:ParameterMapping version="1.0"'
       ' xmlns:ssm="http://ssp-standard.org/SSP1/SystemStructureParameterMapping"'
       ' xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon">{}</ssm:ParameterMapping>')


def _connectors(connectors: dict) -> str:
    """Declared connectors (name -> kind, or "kind:Type" for a type other than Real): SSP tools other than the
    harness read a component's variables through these, not through its modelDescription.xml."""
    if not connectors:
        return ""

    def one(name, spec):
        kind, _, typ = spec.partition(":")
        return f'<ssd:Connector name="{name}" kind="{kind}"><ssc:{typ or "Real"}/></ssd:Connector>'

    return "<ssd:Connectors>" + "".join(one(n, k) for n, k in connectors.items()) + "</ssd:Connectors>"


def _component(name: str, fmu: str, bindings: str = "", connectors: dict | None = None) -> str:
    return (f'<ssd:Component name="{name}" type="application/x-fmu-sharedlibrary" source="resources/{fmu}.fmu">'
            f'{_connectors(connectors or {})}{bindings}</ssd:Component>')


def _binding(ssv: str, ssm: str = "") -> str:
    mapping = f'<ssd:ParameterMapping source="resources/{ssm}"/>' if ssm else ""
    return (f'<ssd:ParameterBindings><ssd:ParameterBinding source="resources/{ssv}">{mapping}'
            '</ssd:ParameterBinding></ssd:ParameterBindings>')


def _ssp(work: Path, name: str, body: str, fmus: dict, files: dict, stop: float, start: float = 0.0,
         archive: bool = True) -> Path:
    """An SSP folder work/name (SystemStructure.ssd, resources/), and unless ``archive`` is False its zip."""
    folder = work / name
    shutil.rmtree(folder, ignore_errors=True)
    (folder / "resources").mkdir(parents=True)
    for stem, fmu in fmus.items():
        shutil.copy(fmu, folder / "resources" / f"{stem}.fmu")
    for file, text in files.items():
        (folder / "resources" / file).write_text(text)
    (folder / "SystemStructure.ssd").write_text(SSD.format(name=name, body=body, start=start, stop=stop))
    if not archive:
        return folder
    ssp = work / f"{name}.ssp"
    with zipfile.ZipFile(ssp, "w") as z:
        for p in sorted(folder.rglob("*")):
            if p.is_file():
                z.write(p, p.relative_to(folder).as_posix())
    return ssp


def _elements(inner: str, connections: str = "", connectors: dict | None = None) -> str:
    """A system's body; no empty ssd:Connections (the SSP 1.0 schema wants at least one, FMPy checks)."""
    wired = f"<ssd:Connections>{connections}</ssd:Connections>" if connections else ""
    return f"{_connectors(connectors or {})}<ssd:Elements>{inner}</ssd:Elements>{wired}"


def _connection(a: str, ac: str, b: str, bc: str) -> str:
    start = f' startElement="{a}"' if a else ""
    end = f' endElement="{b}"' if b else ""
    return f'<ssd:Connection{start} startConnector="{ac}"{end} endConnector="{bc}"/>'


VDP = {"x0": "output", "x1": "output"}
BALL = {"h": "output", "v": "output"}


def build(kind: str, work: Path) -> Content:
    """The content of one kind, built under ``work``."""
    work.mkdir(parents=True, exist_ok=True)
    vdp = ["x0", "x1"]
    if kind == "fmi1-cs":
        return Content(kind, "FMI 1.0 CS (ViProMa identity)", str(TESTS / "fmi1_identity" / "identity.fmu"), True,
                       ["realOut"], 0.1, 0.01, starts={"realIn": 2.5})
    if kind == "fmi2-cs":
        return Content(kind, "FMI 2.0 CS (C Reference-FMU VanDerPol)", str(reference_fmus(work, 2)["VanDerPol"]),
                       True, vdp, 2.0, 0.01)
    if kind == "fmi2-pythonfmu":
        fmu = _pythonfmu(work, "pythonfmu", TESTS / "foreign" / "plain_lag.py", "PlainLag")
        return Content(kind, "FMI 2.0 CS plain pythonfmu (PlainLag)", str(fmu), True, ["y"], 1.0, 0.01,
                       starts={"u": 1.0})
    if kind == "fmi3-cs":
        return Content(kind, "FMI 3.0 CS (C Reference-FMU VanDerPol)", str(reference_fmus(work, 3)["VanDerPol"]),
                       True, vdp, 2.0, 0.01)
    if kind == "fmi3-pythonfmu3":
        fmu = _pythonfmu(work, "pythonfmu3", TESTS / "pythonfmu3" / "pythonslave.py", "PythonSlave")
        return Content(kind, "FMI 3.0 CS pythonfmu3 (PythonSlave)", str(fmu), True, ["realOut"], 1.0, 0.1)
    if kind in ("fmi2-me", "fmi3-me"):
        from harness.fmi.cache import model_exchange_only

        version = 2 if kind == "fmi2-me" else 3
        fmu = model_exchange_only(reference_fmus(work, version)["VanDerPol"])
        return Content(kind, f"FMI {version}.0 ME (Reference-FMU VanDerPol, ME only)", str(fmu), True, vdp, 2.0,
                       0.01, me=True)
    ref = reference_fmus(work, 2)
    if kind == "ssp-units":
        ssv = SSV.format('<ssv:Parameter name="g"><ssv:Real value="-500" unit="cm/s2"/></ssv:Parameter>',
                         '<ssv:Units><ssc:Unit name="cm/s2"><ssc:BaseUnit m="1" s="-2" factor="0.01"/></ssc:Unit>'
                         '</ssv:Units>')
        path = _ssp(work, "units", _elements(_component("ball", "BouncingBall", _binding("g.ssv"), BALL)),
                    {"BouncingBall": ref["BouncingBall"]}, {"g.ssv": ssv}, 1.0)
        return Content(kind, "SSP, .ssv value in another unit (g = -500 cm/s2)", str(path), False,
                       ["ball.h", "ball.v"], 1.0, 0.01, parameter_set="p")
    if kind == "ssp-nested":
        ft = {"Float64_continuous_input": "input", "Float64_continuous_output": "output"}
        sub = ('<ssd:System name="sub">' + _elements(
            _component("ft", "Feedthrough", connectors=ft), _connection("", "in", "ft", "Float64_continuous_input"),
            {"in": "input"}) + '</ssd:System>')
        body = _elements(_component("vdp", "VanDerPol", connectors=VDP) + sub, _connection("vdp", "x0", "sub", "in"))
        path = _ssp(work, "nested", body, {"VanDerPol": ref["VanDerPol"], "Feedthrough": ref["Feedthrough"]}, {},
                    2.0)
        return Content(kind, "SSP, nested system (system connector)", str(path), False,
                       ["vdp.x0", "sub/ft.Float64_continuous_output"], 2.0, 0.01)
    mu = SSV.format('<ssv:Parameter name="{}"><ssv:Real value="{}"/></ssv:Parameter>', "")
    if kind == "ssp-ssm":
        ssm = SSM.format('<ssm:MappingEntry source="damping_percent" target="mu">'
                         '<ssc:LinearTransformation factor="0.01"/></ssm:MappingEntry>')
        path = _ssp(work, "mapping", _elements(_component("vdp", "VanDerPol", _binding("mu.ssv", "mu.ssm"), VDP)),
                    {"VanDerPol": ref["VanDerPol"]}, {"mu.ssv": mu.format("damping_percent", 250.0), "mu.ssm": ssm},
                    2.0)
        return Content(kind, "SSP, parameter mapping (.ssm, mu = 250 % -> 2.5)", str(path), False, ["vdp.x0", "vdp.x1"],
                       2.0, 0.01, parameter_set="p")
    if kind == "ssp-folder":
        path = _ssp(work, "folder", _elements(_component("vdp", "VanDerPol", _binding("mu.ssv"), VDP)),
                    {"VanDerPol": ref["VanDerPol"]}, {"mu.ssv": mu.format("mu", 2.5)}, 2.0, archive=False)
        return Content(kind, "SSP as an unpacked folder", str(path), False, ["vdp.x0", "vdp.x1"], 2.0, 0.01,
                       parameter_set="p")
    if kind == "ssp-start":
        path = _ssp(work, "start", _elements(_component("ball", "BouncingBall", connectors=BALL)),
                    {"BouncingBall": ref["BouncingBall"]}, {}, 1.5, start=0.5)
        return Content(kind, "SSP, DefaultExperiment startTime = 0.5 s", str(path), False, ["ball.h", "ball.v"], 1.5,
                       0.01, start=0.5)
    if kind == "ssp-int-mapping":
        entries = "".join(f'<ssc:MapEntry source="{k}" target="{v}"/>' for k, v in ((1, 10), (2, 20), (3, 30)))
        conn = ('<ssd:Connection startElement="stair" startConnector="counter" endElement="ft" '
                f'endConnector="Int32_input"><ssc:IntegerMappingTransformation>{entries}'
                '</ssc:IntegerMappingTransformation></ssd:Connection>')
        body = _elements(_component("stair", "Stair", connectors={"counter": "output:Integer"})
                         + _component("ft", "Feedthrough", connectors={"Int32_input": "input:Integer",
                                                                       "Int32_output": "output:Integer"}), conn)
        path = _ssp(work, "intmap", body, {"Stair": ref["Stair"], "Feedthrough": ref["Feedthrough"]}, {}, 2.5)
        return Content(kind, "SSP, IntegerMappingTransformation on a connection (Stair 1, 2, 3 -> 10, 20, 30)",
                       str(path), False, ["stair.counter", "ft.Int32_output"], 2.5, 0.01)
    raise SystemExit(f"content_matrix: unknown kind {kind!r} (kinds: {', '.join(KINDS)})")


KINDS = ("fmi1-cs", "fmi2-cs", "fmi2-pythonfmu", "fmi3-cs", "fmi3-pythonfmu3", "fmi2-me", "fmi3-me", "ssp-units",
         "ssp-nested", "ssp-ssm", "ssp-folder", "ssp-start", "ssp-int-mapping")


# ------------------------------------------------------------------------------------------- one tool, one kind
class Refused(Exception):
    """The tool failed; ``stage`` is 'load' (before the first step) or 'run'."""

    def __init__(self, stage: str, message: str):
        super().__init__(" ".join(str(message).split())[:300])
        self.stage = stage


def _times(c: Content) -> np.ndarray:
    n = round((c.stop - c.start) / c.step)
    return np.round(c.start + np.arange(n + 1) * c.step, 12)   # 6 * 0.1 is 0.6000000000000001: a step too far


def _split(output: str) -> tuple[list[str], str]:
    """'sub/ft.y' -> (['sub', 'ft'], 'y')."""
    path, _, var = output.partition(".")
    return path.split("/"), var


def run_ours(c: Content) -> pd.DataFrame:
    import warnings

    from harness import simulate
    from harness.model import Experiment, Instance, System
    from harness.ssp import load_ssp

    try:
        if c.fmu:
            system = System("m", [Instance("m", c.path, dict(c.starts))],
                            experiment=Experiment(stop_time=c.stop, step=c.step))
        else:
            system = load_ssp(c.path)
    except Exception as e:
        raise Refused("load", e) from e
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            df = simulate(system, stop_time=c.stop, step=c.step, on_error="raise")
        except Exception as e:
            raise Refused("run", e) from e
    return df[[f"m.{o}" for o in c.outputs]].set_axis(c.outputs, axis=1) if c.fmu else df[c.outputs]


def run_fmpy(c: Content) -> pd.DataFrame:
    from fmpy import simulate_fmu

    if c.fmu:
        try:
            r = simulate_fmu(c.path, stop_time=c.stop, step_size=None if c.me else c.step, output_interval=c.step,
                             start_values=dict(c.starts), output=list(c.outputs),
                             fmi_type="ModelExchange" if c.me else "CoSimulation")
        except Exception as e:
            raise Refused("run", e) from e
        return pd.DataFrame({o: r[o] for o in c.outputs}, index=pd.Index(r["time"], name="time"))
    from fmpy.ssp.simulation import simulate_ssp

    try:
        r = simulate_ssp(c.path, start_time=c.start, stop_time=c.stop, step_size=c.step)
    except Exception as e:
        raise Refused("load", e) from e
    columns = {}
    for o in c.outputs:
        path, var = _split(o)
        match = [n for n in r.dtype.names if n.endswith(f"{path[-1]}.{var}")]
        if match:
            columns[o] = r[match[0]]
    return pd.DataFrame(columns, index=pd.Index(r["time"], name="time"))


def run_omsimulator(c: Content) -> pd.DataFrame:
    from OMSimulator import SSP, CRef

    try:
        if c.fmu:
            model = SSP()
            model.addResource(c.path, "resources/m.fmu")
            model.addComponent(CRef("default", "m"), "resources/m.fmu")
            root, paths = "default", {o: (["m"], o) for o in c.outputs}
        else:
            model = SSP(c.path)
            root, paths = c.root, {o: _split(o) for o in c.outputs}
        im = model.instantiate()
        for name, value in c.starts.items():
            im.setValue(CRef(root, "m", name), value)
        im.setFixedStepSize(c.step)
        im.setStartTime(c.start)
        im.setStopTime(c.stop)
        result = Path(tempfile.mkdtemp(prefix="content_matrix_oms_")) / "result.csv"
        im.setResultFile(str(result))
        im.initialize()
    except Exception as e:
        raise Refused("load", e) from e
    try:
        im.simulate()
        im.terminate()
        im.delete()
    except Exception as e:
        raise Refused("run", e) from e
    # its own result file (each communication point written twice: judge() keeps the last)
    raw = pd.read_csv(result)
    columns = {o: ".".join([root, *paths[o][0], paths[o][1]]) for o in c.outputs}
    missing = [name for name in columns.values() if name not in raw.columns]
    if missing:
        raise Refused("run", f"no column {missing[0]} in its result ({', '.join(raw.columns[:6])}, ...)")
    return pd.DataFrame({o: raw[name].to_numpy() for o, name in columns.items()},
                        index=pd.Index(raw["time"].to_numpy(), name="time"))


def _libcosim_collect(execution, targets: dict, c: Content) -> pd.DataFrame:
    from benchmarks.peers import _libcosim, _libcosim_error, _libcosim_record, _libcosim_samples

    _, _, observer_cls, enums = _libcosim()
    n = len(_times(c)) - 1
    observer = _libcosim_record(execution, observer_cls, enums, list(targets.values()), n)
    if not execution.step(n) or execution.status().error_code != 0:
        raise Refused("run", _libcosim_error("step"))
    data, times = {}, None
    for o, (index, reference, integer) in targets.items():
        t_ns, data[o] = _libcosim_samples(observer, index, reference, n + 1, integer)
        times = t_ns / 1e9
    return pd.DataFrame(data, index=pd.Index(times, name="time"))


def run_libcosim(c: Content) -> pd.DataFrame:
    from benchmarks.peers import _libcosim, _libcosim_error, step_nanoseconds

    execution_cls, slave_cls, _, enums = _libcosim()
    try:
        if c.fmu:
            execution = execution_cls.from_step_size(step_nanoseconds(c.step))
            index = execution.add_local_slave(slave_cls(fmu_path=c.path, instance_name="m"))
            if index < 0:
                raise _libcosim_error("add slave")
            slaves = {"m": index}
        else:
            execution = execution_cls.from_ssp_file(c.path, step_nanoseconds(c.step))
            slaves = {info.name.decode(): info.index for info in execution.slave_infos()}
        kinds = (enums.CosimVariableType.REAL.value, enums.CosimVariableType.INTEGER.value)
        typed = {i: {v.name.decode(): (v.reference, v.type == kinds[1]) for v in execution.slave_variables(i)
                     if v.type in kinds} for i in slaves.values()}
        reals = {i: {k: ref for k, (ref, integer) in vs.items() if not integer} for i, vs in typed.items()}
        for name, value in c.starts.items():
            if not execution.real_initial_value(slaves["m"], reals[slaves["m"]][name], float(value)):
                raise _libcosim_error("initial value", name)
        targets = {}
        for o in c.outputs:
            path, var = (["m"], o) if c.fmu else _split(o)
            index = slaves.get(path[-1], slaves.get("/".join(path)))
            if index is not None and var in typed[index]:
                targets[o] = (index, *typed[index][var])
        if not targets:
            raise Refused("load", f"none of {', '.join(c.outputs)} among its slaves {', '.join(slaves)}")
    except Refused:
        raise
    except Exception as e:
        raise Refused("load", e) from e
    return _libcosim_collect(execution, targets, c)


def _ecos_value(sim, name: str) -> float:
    """A Real variable's value, else an Integer's (Ecos has one getter per type)."""
    try:
        return sim.get_real(name)
    except Exception:
        return float(sim.get_integer(name))


def run_ecos(c: Content) -> pd.DataFrame:
    import ecospy

    ecospy.EcosLib.set_log_level("warn")
    try:
        if c.fmu:
            structure = ecospy.EcosSimulationStructure()
            structure.add_model("m", str(Path(c.path).resolve()))
            if c.starts and not structure.add_parameter_set("start", {f"m::{k}": v for k, v in c.starts.items()}):
                raise RuntimeError(ecospy.EcosLib.get_last_error())
            sim = ecospy.EcosSimulation(structure=structure, step_size=c.step)
            names, parameter_set = {o: f"m::{o}" for o in c.outputs}, "start" if c.starts else None
        else:
            sim = ecospy.EcosSimulation(ssp_path=str(Path(c.path).resolve()), step_size=c.step)
            names, parameter_set = {}, c.parameter_set
            for o in c.outputs:
                path, var = _split(o)
                names[o] = f"{path[-1]}::{var}"
        if not sim.init(c.start, parameter_set):
            raise RuntimeError(ecospy.EcosLib.get_last_error())
    except Exception as e:
        raise Refused("load", e) from e
    n = len(_times(c)) - 1
    times, values = np.empty(n + 1), np.empty((n + 1, len(c.outputs)))
    try:
        for k in range(n + 1):
            times[k] = sim.step(1) if k else sim.get_time()
            values[k] = [_ecos_value(sim, names[o]) for o in c.outputs]
        sim.terminate()
    except Exception as e:
        raise Refused("run", e) from e
    return pd.DataFrame(values, columns=c.outputs, index=pd.Index(times, name="time"))


RUNNERS = {"ours": run_ours, "fmpy": run_fmpy, "omsimulator": run_omsimulator, "libcosim": run_libcosim,
           "ecos": run_ecos}


def cell_main(tool: str, content_json: str, out_csv: str) -> int:
    """The subprocess: run one tool on one content; the result CSV, or one JSON line {stage, error}."""
    c = Content(**json.loads(Path(content_json).read_text()))
    try:
        df = RUNNERS[tool](c)
    except Refused as e:
        print(json.dumps({"stage": e.stage, "error": str(e)}), flush=True)
        return 3
    except Exception as e:
        print(json.dumps({"stage": "run", "error": " ".join(f"{type(e).__name__}: {e}".split())[:300]}), flush=True)
        return 3
    df.to_csv(out_csv)
    sys.stdout.flush()
    import os

    os._exit(0)   # some tools' libraries crash in their atexit handlers; the result is written


# ------------------------------------------------------------------------------------------- judging
def run_cell(tool: str, c: Content, work: Path, timeout: float) -> tuple[str, pd.DataFrame | None]:
    """(how it ended, its result or None): 'ok', or a finished cell text."""
    spec = work / f"{c.kind}.json"
    spec.write_text(json.dumps(asdict(c)))
    out = work / f"{c.kind}.{tool}.csv"
    out.unlink(missing_ok=True)
    try:
        r = subprocess.run([sys.executable, "-m", "benchmarks.content_matrix", "--cell", tool, str(spec), str(out)],
                           cwd=ROOT, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return f"timed out (> {timeout:g} s)", None
    if r.returncode == 0 and out.is_file():
        return "ok", pd.read_csv(out, index_col=0)
    for line in reversed(r.stdout.strip().splitlines()):
        if line.startswith("{"):
            info = json.loads(line)
            # OMSimulator raises a bare "Status.error" and prints its reason as an "error:" line
            said = [x.split(":", 1)[1].strip() for x in (r.stderr + r.stdout).splitlines() if x.startswith("error:")]
            reason = info["error"] + (f" ({said[0]})" if said else "")
            return ("cannot load: " if info["stage"] == "load" else "refused: ") + reason, None
    tail = " ".join(r.stderr.strip().splitlines()[-1:])[:160]
    return f"crashes (exit {r.returncode}{': ' + tail if tail else ''})", None


def judge(df: pd.DataFrame, ours: pd.DataFrame) -> tuple[str, float | None]:
    """The cell text of a run against ours, and the relative difference (None: nothing comparable)."""
    common = [o for o in ours.columns if o in df.columns]
    if not common:
        return f"runs, none of our outputs recorded ({', '.join(df.columns) or 'no columns'})", None
    t_ours, t_df = ours.index.to_numpy(dtype=float), df.index.to_numpy(dtype=float)
    # each time point once (OMSimulator-style duplicates keep the last value)
    df = df[~pd.Index(np.round(t_df, 9)).duplicated(keep="last")]
    t_df = df.index.to_numpy(dtype=float)
    at = {round(t, 9): i for i, t in enumerate(t_df)}
    rows = [(i, at[round(t, 9)]) for i, t in enumerate(t_ours) if round(t, 9) in at]
    if len(rows) < 2:
        return (f"runs, differs (time points {t_df[0]:g}..{t_df[-1]:g} s, ours {t_ours[0]:g}..{t_ours[-1]:g} s)",
                None)
    a = ours[common].to_numpy(dtype=float)[[i for i, _ in rows]]
    b = df[common].to_numpy(dtype=float)[[j for _, j in rows]]
    note = "" if len(rows) == len(t_ours) else f"; only {len(rows)} of our {len(t_ours)} time points"
    if len(rows) < len(t_ours) and t_df[-1] < t_ours[-1] - 1e-9:
        note += f", its result ends at {t_df[-1]:g} s"
    if not np.isfinite(b).all():
        return f"runs, differs (non-finite values{note})", None
    scale = np.maximum(np.abs(a).max(axis=0), TINY)
    x = float((np.abs(b - a) / scale).max())
    if x <= AGREE:
        return f"runs, agrees with ours to {x:.1e}{note}", x
    # a tool that labels each row with the time at the START of the step it reports (one step late)
    late = float((np.abs(b[:-1] - a[1:]) / scale).max()) if len(a) > 2 else np.inf
    if late <= AGREE:
        note += f"; its row at t holds our t + step: shifted, agrees to {late:.1e}"
    return f"runs, differs ({x:.1e}{note})", x


def matrix(kinds, tools, work: Path, timeout: float) -> list[dict]:
    rows = []
    for kind in kinds:
        try:
            c = build(kind, work)
        except Exception as e:
            rows.append({"kind": kind, "label": kind, **{t: f"content not built: {e}" for t in tools}})
            continue
        row = {"kind": kind, "label": c.label}
        status, ours = run_cell("ours", c, work, timeout)
        row["ours"] = "runs" if status == "ok" else status
        if status == "ok" and len(ours) > 0:
            row["ours"] = f"runs ({len(ours) - 1} steps)"
        for tool in tools:
            if tool == "ours":
                continue
            status, df = run_cell(tool, c, work, timeout)
            if status != "ok":
                row[tool] = status
            elif ours is None:
                row[tool] = "runs (ours failed: nothing to compare)"
            else:
                row[tool] = judge(df, ours)[0]
        rows.append(row)
        print(f"{kind}: " + " | ".join(row.get(t, "") for t in tools), file=sys.stderr, flush=True)
    return rows


def markdown(rows: list[dict], tools) -> str:
    head = "| Content kind | " + " | ".join(TOOL_NAMES[t] for t in tools) + " |"
    lines = [head, "|" + "---|" * (len(tools) + 1)]
    for r in rows:
        cells = [r.get(t, "").replace("|", "/") for t in tools]
        lines.append(f"| {r['label']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.content_matrix", description=__doc__.split("\n")[0])
    p.add_argument("--kinds", default=",".join(KINDS))
    p.add_argument("--tools", default=",".join(TOOLS))
    p.add_argument("--timeout", type=float, default=180.0, help="seconds per cell")
    p.add_argument("--work", default=str(ROOT / "build" / "content_matrix"), help="where content is built")
    p.add_argument("--out", default=str(ROOT / "results" / "content_matrix"), help="output stem (.md, .csv)")
    p.add_argument("--cell", nargs=3, metavar=("TOOL", "CONTENT_JSON", "OUT_CSV"), help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.cell:
        return cell_main(*a.cell)
    kinds, tools = a.kinds.split(","), a.tools.split(",")
    for t in tools:
        if t not in TOOLS:
            p.error(f"--tools: {t!r} is not one of {', '.join(TOOLS)}")
    if "ours" not in tools:
        tools = ["ours", *tools]
    rows = matrix(kinds, tools, Path(a.work), a.timeout)
    table = markdown(rows, tools)
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".md").write_text(table)
    with open(out.with_suffix(".csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["kind", "label", *tools])
        w.writeheader()
        w.writerows(rows)
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
