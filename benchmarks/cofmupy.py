"""CoFmuPy (pip package ``cofmupy``) as a peer of the benchmark, run from its OWN virtual environment.

CoFmuPy 1.0 pins pythonfmu 0.6.3 and fmpy 0.3.20; installed beside the toolkit it would downgrade the pythonfmu
0.7 that builds our FMUs.  So it lives in a separate venv and this module has three parts:

* :func:`ensure_venv` (toolkit side): creates or reuses the venv (``$PRESSDRIVE_COFMUPY_VENV``, default
  ``<tempdir>/pressdrive_cofmupy_venv``), installs CoFmuPy and numpy with pip; returns its python, or a
  one-line reason why not (the benchmark then reports the row as skipped);
* :func:`cofmupy_config` / :func:`write_config` (toolkit side): CoFmuPy's JSON configuration of an exported
  SSP (``fmus`` with their ``initialization`` values, ``connections`` output -> input, ``cosim_method``
  "jacobi").  A system CoFmuPy cannot express raises :class:`Unsupported` (reported as skipped, never timed
  as a different system);
* :func:`run_cofmupy` (INSIDE the venv, imports neither harness nor fmus): initialises CoFmuPy's
  ``DefaultMaster`` and steps it ``n`` times, timing only those two, and returns the worker's
  ``{"seconds", "steps", "fmus", "final"}``.

:func:`run_config` ties them together for ``benchmarks.bench`` (one case, one mode).

What CoFmuPy 1.0 computes (read from ``cofmupy/master/default_master.py`` and ``wrappers.py``): the FMUs of a
strongly connected group step on the inputs held since the previous communication point, their outputs are
read right after ``doStep`` and passed on at the next step (Jacobi, zero-order hold) -- the harness's
``jacobi-sampled``.  The differences, and how the configuration deals with them:

* groups are stepped in topological order and a later group takes the NEW outputs of an earlier one
  (Gauss-Seidel between groups): a system that is not one strongly connected group is unsupported;
* a connection copies the value (no factor, no offset): a linear transformation is unsupported;
* before the first step CoFmuPy does not pass the outputs at t = 0 on to the inputs (they start at the
  configuration's ``initialization`` values, default 0) and it sets every input, connected or not, at every
  step: the configuration gives every input its value at the consistent initial point (the outputs at t = 0
  of the harness's initialisation, the point libcosim and Ecos reach themselves; an unconnected input keeps
  its start value);
* ``initialization`` values are set with ``fmi2SetReal`` only (an Integer parameter fails in pythonfmu):
  non-Real parameters travel beside the configuration and the runner sets them with fmpy's typed setter on
  CoFmuPy's own FMU handle, before CoFmuPy's initialisation;
* time advances as ``t += h`` (the harness: ``t_k = k * h``): the time doubles differ in the last bits.

Command line::

    python -m benchmarks.cofmupy venv                          # create/reuse the venv; prints its python
    python -m benchmarks.cofmupy config '{"folder": ...}'      # toolkit side: prints CONFIG <json>
    <venv python> benchmarks/cofmupy.py run '{"config": ...}'  # venv side: prints RESULT <json>
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
VENV_ENV = "PRESSDRIVE_COFMUPY_VENV"
REQUIREMENTS = ("cofmupy==1.0.0", "numpy")   # numpy: imported by our FMUs inside their resources
MARKER = "pressdrive_cofmupy_ready"           # written into the venv once the install has succeeded
NON_REAL = ("Integer", "Enumeration", "Boolean")


class Unsupported(Exception):
    """The system cannot be expressed in CoFmuPy 1.0 (the message says why, on one line)."""


# -- the virtual environment (toolkit side) -------------------------------------------------------------------
_VENV: dict[Path, tuple[str | None, str]] = {}   # this process's answers of ensure_venv, per venv


def venv_dir() -> Path:
    """Where the CoFmuPy venv lives: ``$PRESSDRIVE_COFMUPY_VENV`` or ``<tempdir>/pressdrive_cofmupy_venv``."""
    return Path(os.environ.get(VENV_ENV) or Path(tempfile.gettempdir()) / "pressdrive_cofmupy_venv")


def venv_python(venv: Path) -> Path:
    """The python executable of ``venv``."""
    return venv / ("Scripts/python.exe" if os.name == "nt" else "bin/python")


def ensure_venv(timeout: float = 1800.0) -> tuple[str | None, str]:
    """``(python, "")`` of a venv with CoFmuPy installed (created on first use, reused after), or
    ``(None, reason)``: one line saying why it could not be created.  The answer is kept for this process."""
    venv = venv_dir()
    if venv not in _VENV:
        try:
            with _locked(venv):
                _install(venv, timeout)
            _VENV[venv] = (str(venv_python(venv)), "")
        except (OSError, subprocess.SubprocessError, RuntimeError) as e:
            _VENV[venv] = (None, f"CoFmuPy virtual environment {venv} could not be created: {_one_line(e)}")
    return _VENV[venv]


def _one_line(e: BaseException) -> str:
    text = " ".join(str(e).split()) or type(e).__name__
    return text[:240]


class _locked:
    """An exclusive lock beside the venv (two benchmark runs or test workers must not install at once)."""

    def __init__(self, venv: Path):
        self.path = venv.parent / f"{venv.name}.lock"

    def __enter__(self):
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.fh = open(self.path, "w")
        try:
            import fcntl

            fcntl.flock(self.fh, fcntl.LOCK_EX)
        except ImportError:  # not POSIX: no lock
            pass
        return self

    def __exit__(self, *exc):
        self.fh.close()


def _install(venv: Path, timeout: float) -> None:
    """Create the venv and pip-install CoFmuPy into it, unless the marker says it is done."""
    python = venv_python(venv)
    if (venv / MARKER).is_file() and python.is_file():
        return
    if not python.is_file():
        _call([sys.executable, "-m", "venv", str(venv)], "python -m venv", timeout)
    _call([str(python), "-m", "pip", "install", "--disable-pip-version-check", *REQUIREMENTS], "pip install",
          timeout)
    probe = "import cofmupy, numpy; from cofmupy.master import DefaultMaster; print(cofmupy.__version__)"
    version = _call([str(python), "-c", probe], "import cofmupy", timeout).strip().splitlines()[-1]
    (venv / MARKER).write_text(f"cofmupy {version}\n")


def _call(cmd: list[str], what: str, timeout: float) -> str:
    """Run ``cmd``; its stdout, or RuntimeError with ``what`` and pip's first ERROR line (else the last line)."""
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if proc.returncode != 0:
        lines = [ln.strip() for ln in (proc.stderr or proc.stdout).splitlines() if ln.strip()]
        errors = [ln for ln in lines if ln.startswith("ERROR")] or lines[-1:] or [f"exit code {proc.returncode}"]
        raise RuntimeError(f"{what} failed: {errors[0]}")
    return proc.stdout


# -- the configuration (toolkit side) -------------------------------------------------------------------------
def cofmupy_config(ssd: str | Path, step: float) -> dict:
    """``{"config": <CoFmuPy JSON configuration>, "typed_parameters": {instance: {name: value}}}`` of the
    system in ``ssd`` (a SystemStructure.ssd); raises :class:`Unsupported` if CoFmuPy cannot run it as the
    same system with the same algorithm.  ``step`` is only used for the harness's initialisation."""
    from harness import load
    from harness.model import model_description, resolve_fmu

    ssd = Path(ssd)
    if not ssd.is_file():
        raise FileNotFoundError(f"{ssd}: no such SystemStructure.ssd")
    system = load(str(ssd))
    paths = {inst.name: Path(resolve_fmu(inst.fmu)).resolve() for inst in system.instances}
    mds = {name: model_description(p) for name, p in paths.items()}
    variables = {name: {v.name: v for v in md.modelVariables} for name, md in mds.items()}
    connections = system.all_connections(mds)
    _check_fmus(mds, paths)
    _check_connections(connections, variables)
    _check_one_group([inst.name for inst in system.instances], connections)
    start = _initial_sources(system, connections, step)
    fmus, typed = [], {}
    for inst in system.instances:
        init, typed[inst.name] = _initialization(inst, variables[inst.name], connections, start)
        fmus.append({"id": inst.name, "name": inst.name, "path": str(paths[inst.name]), "initialization": init})
    config = {"edge_sep": " -> ", "cosim_method": "jacobi", "iterative": False, "fmus": fmus,
              "connections": _connections(connections, variables), "data_storages": []}
    return {"config": config, "typed_parameters": {k: v for k, v in typed.items() if v}}


def _split_ref(ref: str) -> tuple[str, str]:
    """"Instance.variable" -> (instance, variable); instance names contain no dot."""
    inst, _, var = ref.partition(".")
    return inst, var


def _check_fmus(mds: dict, paths: dict) -> None:
    for name, md in mds.items():
        if md.fmiVersion != "2.0" or md.coSimulation is None:
            raise Unsupported(f"instance {name} ({paths[name]}): CoFmuPy runs FMI 2.0 co-simulation FMUs only")


def _check_connections(connections, variables: dict) -> None:
    """Connections must copy an output to an input: CoFmuPy has no factor/offset on a connection."""
    for c in connections:
        if c.factor != 1.0 or c.offset != 0.0:
            raise Unsupported(f"connection {c.source} -> {c.target} has factor {c.factor:g}, offset {c.offset:g}: "
                              "CoFmuPy 1.0 copies values along a connection (no linear transformation)")
        for ref, want in ((c.source, "output"), (c.target, "input")):
            inst, var = _split_ref(ref)
            v = variables.get(inst, {}).get(var)
            if v is None:
                raise ValueError(f"connection {c.source} -> {c.target}: instance {inst!r} has no variable {var!r}")
            if v.causality != want or v.type != "Real":
                raise Unsupported(f"connection {c.source} -> {c.target}: CoFmuPy connects Real outputs to Real "
                                  f"inputs only ({ref} is a {v.type} {v.causality})")


def _check_one_group(names: list[str], connections) -> None:
    """CoFmuPy steps strongly connected groups in topological order, Gauss-Seidel BETWEEN them: it is the
    jacobi-sampled algorithm only if no connection runs from one group to another."""
    from harness.master import graph

    g = graph.Digraph(names, ((_split_ref(c.source)[0], _split_ref(c.target)[0]) for c in connections))
    group = {n: k for k, comp in enumerate(graph.strongly_connected_components(g)) for n in comp}
    for c in connections:
        a, b = _split_ref(c.source)[0], _split_ref(c.target)[0]
        if group[a] != group[b]:
            raise Unsupported(f"connection {c.source} -> {c.target} links two strongly connected groups, which "
                              "CoFmuPy steps Gauss-Seidel (not Jacobi)")


def _initial_sources(system, connections, step: float) -> dict[str, float]:
    """Value of every connection source at t = 0 after the harness's initialisation (consistent inputs and
    outputs; the starting point of every other tool)."""
    from harness import simulate

    sources = sorted({c.source for c in connections})
    if not sources:
        return {}
    df = simulate(system, stop_time=step, step=step, master="jacobi-sampled", extrapolation=0, output=sources)
    if not df.attrs["complete"] or df.index[0] != 0.0:
        raise RuntimeError(f"system {system.name}: initialisation failed: {df.attrs['error']}")
    return {s: float(df[s].iloc[0]) for s in sources}


def _initialization(inst, variables: dict, connections, start: dict) -> tuple[dict, dict]:
    """(CoFmuPy ``initialization`` of one instance: Real parameters and EVERY input, non-Real parameters)."""
    init, typed = {}, {}
    for name, value in inst.parameters.items():
        v = variables.get(name)
        if v is None:
            raise ValueError(f"instance {inst.name} ({inst.fmu}): parameter {name!r} is not a variable of the FMU")
        if v.type == "Real":
            init[name] = float(value)
        elif v.type in NON_REAL:
            typed[name] = bool(value) if v.type == "Boolean" else int(value)
        else:
            raise Unsupported(f"instance {inst.name}: {v.type} parameter {name} cannot be set in CoFmuPy")
    feeds = {_split_ref(c.target)[1]: c.source for c in connections if _split_ref(c.target)[0] == inst.name}
    for v in variables.values():
        if v.causality != "input":
            continue
        if v.type != "Real":
            raise Unsupported(f"instance {inst.name}: {v.type} input {v.name} (CoFmuPy sets inputs with "
                              "fmi2SetReal)")
        if v.name in feeds:
            init[v.name] = start[feeds[v.name]]
        elif v.name not in init:
            init[v.name] = float(v.start) if v.start is not None else 0.0
    return init, typed


def _connections(connections, variables: dict) -> list[dict]:
    """CoFmuPy connections: one entry per source with the list of its targets."""
    def end(ref: str) -> dict:
        inst, var = _split_ref(ref)
        return {"id": inst, "variable": var, "unit": variables[inst][var].unit or ""}

    by_source: dict[str, list[str]] = {}
    for c in connections:
        by_source.setdefault(c.source, []).append(c.target)
    return [{"source": end(s), "target": [end(t) for t in targets]} for s, targets in by_source.items()]


def write_config(folder: str | Path, step: float) -> dict:
    """Write the configuration of the SSP folder beside it (``<folder>_cofmupy.json``); returns
    ``{"config": path, "typed_parameters": ..., "fmus": n}`` or ``{"skipped": reason}``."""
    folder = Path(folder)
    try:
        made = cofmupy_config(folder / "SystemStructure.ssd", step)
    except Unsupported as e:
        return {"skipped": str(e)}
    path = folder.parent / f"{folder.name}_cofmupy.json"
    path.write_text(json.dumps(made["config"], indent=1))
    return {"config": str(path), "typed_parameters": made["typed_parameters"], "fmus": len(made["config"]["fmus"])}


# -- the runner (INSIDE the CoFmuPy venv: no harness, no fmus) ------------------------------------------------
def run_cofmupy(spec: dict) -> dict:
    """Initialise CoFmuPy's master from ``spec["config"]`` and take ``spec["n"]`` steps of ``spec["step"]``;
    ``seconds`` covers CoFmuPy's initialisation and the stepping loop (not loading the FMUs)."""
    for key in ("config", "step", "n", "columns"):
        if key not in spec:
            raise ValueError(f"cofmupy run spec: missing {key!r}")
    step, n = float(spec["step"]), int(spec["n"])
    master = _load_master(spec["config"])
    _set_typed(master, spec.get("typed_parameters") or {}, spec["config"])
    t0 = time.perf_counter()
    master.init_simulation(input_dict={})
    for _ in range(n):
        master.do_step(step, record_outputs=False)
    seconds = time.perf_counter() - t0
    if abs(master.current_time - n * step) > 1e-9 * max(1.0, n * step):
        raise RuntimeError(f"cofmupy: ended at t = {master.current_time!r} s, expected {n * step!r} s")
    return {"seconds": seconds, "steps": n, "fmus": len(master.fmu_handlers),
            "final": _final(master, spec["columns"], spec["config"])}


def _load_master(config: str):
    """CoFmuPy's DefaultMaster built as ``Coordinator.start`` builds it (FMUs loaded and instantiated), but not
    yet initialised; one strongly connected group (else it would not be Jacobi)."""
    from cofmupy import Coordinator
    from cofmupy.master import DefaultMaster

    if not Path(config).is_file():
        raise FileNotFoundError(f"{config}: CoFmuPy configuration not found")
    coordinator = Coordinator()
    coordinator.parse_config(config)
    coordinator.start_graph_engine(coordinator.config_parser.graph_config)
    order = coordinator.graph_engine.sequence_order
    if len(order) > 1:
        raise RuntimeError(f"{config}: CoFmuPy splits the system into {len(order)} groups (Gauss-Seidel between)")
    mc = coordinator.config_parser.master_config
    return DefaultMaster(fmu_config_list=mc["fmus"], connections=mc["connections"], sequence_order=order,
                         cosim_method=mc["cosim_method"], iterative=mc["iterative"])


def _set_typed(master, typed: dict, config: str) -> None:
    """Non-Real parameters, with fmpy's typed setters on CoFmuPy's FMU handles (instantiated, not initialised)."""
    for inst, values in typed.items():
        handler = master.fmu_handlers.get(inst)
        if handler is None:
            raise ValueError(f"{config}: typed parameters of unknown instance {inst!r}")
        for name, value in values.items():
            v = handler.var_name2attr.get(name)
            if v is None:
                raise ValueError(f"{config}: instance {inst} has no parameter {name!r}")
            setter = handler.fmu.setBoolean if v.type == "Boolean" else handler.fmu.setInteger
            setter([v.valueReference], [value])


def _final(master, columns: list[str], config: str) -> dict:
    """Values of the check columns ("Instance.variable") read from CoFmuPy's FMU handles."""
    final = {}
    for column in columns:
        inst, var = _split_ref(column)
        if inst not in master.fmu_handlers:
            raise ValueError(f"check column {column!r}: no instance {inst!r} in {config}")
        final[column] = float(master.get_variable((inst, var))[0])
    return final


# -- one benchmark configuration (toolkit side) ---------------------------------------------------------------
_PREPARED: dict[tuple[str, float], dict] = {}


def prepare(folder: str, step: float, timeout: float) -> dict:
    """``write_config`` in a subprocess of the toolkit's python (the harness initialisation runs FMUs; the
    benchmark driver runs none itself); once per SSP folder and step."""
    key = (str(folder), float(step))
    if key not in _PREPARED:
        job = json.dumps({"folder": str(folder), "step": step})
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
        out = _tagged(subprocess.run([sys.executable, "-m", "benchmarks.cofmupy", "config", job], capture_output=True,
                                     text=True, timeout=timeout, env=env, cwd=str(ROOT)), "CONFIG ")
        if "error" in out:
            return out
        _PREPARED[key] = out
    return dict(_PREPARED[key])


def run_config(spec: dict, mode: str, timeout: float) -> dict:
    """One benchmark configuration (``spec`` as benchmarks.bench builds it) in CoFmuPy: the RESULT dict,
    ``{"skipped": reason}`` or ``{"error": message}``."""
    try:
        prepared = prepare(spec["folder"], spec["step"], timeout)
        if "config" not in prepared:
            return prepared
        python, reason = ensure_venv(timeout)
        if python is None:
            return {"skipped": reason}
        job = {"config": prepared["config"], "typed_parameters": prepared["typed_parameters"], "step": spec["step"],
               "n": spec["n"], "columns": spec["columns"]}
        return _run_in_venv(python, job, mode, timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"timed out after {timeout:g} s"}


def _run_in_venv(python: str, job: dict, mode: str, timeout: float) -> dict:
    """The runner as a script of the venv's python (not ``-m``: the toolkit must not be importable there),
    pinned to CPU 0 in mode 'pinned'; CoFmuPy's FMU extractions go to a temporary folder removed after."""
    cmd = [python, str(Path(__file__).resolve()), "run", json.dumps(job)]
    if mode == "pinned":
        import shutil

        if shutil.which("taskset") is None:
            return {"error": "taskset not found: cannot pin"}
        cmd = ["taskset", "-c", "0"] + cmd
    with tempfile.TemporaryDirectory(prefix="pd_cofmupy_") as tmp:
        env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
        env.update(TMPDIR=tmp, TEMP=tmp, TMP=tmp)
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, cwd=tmp)
    return _tagged(proc, "RESULT ")


def _tagged(proc: subprocess.CompletedProcess, tag: str) -> dict:
    """The JSON after the last line starting with ``tag``, or an error with the tail of stderr."""
    for line in reversed(proc.stdout.splitlines()):
        if line.startswith(tag):
            return json.loads(line[len(tag):])
    tail = " ".join((proc.stderr or "").strip().splitlines()[-2:])
    return {"error": f"exit code {proc.returncode}: {tail}"[:300]}


# -- command line ---------------------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    what = argv[0] if argv else ""
    if what == "venv":
        python, reason = ensure_venv()
        print(python or f"skipped: {reason}")
        return 0 if python else 1
    if what not in ("config", "run") or len(argv) != 2:
        print(__doc__.rsplit("Command line::", 1)[-1], file=sys.stderr)
        return 2
    spec = json.loads(argv[1])
    try:
        out = write_config(spec["folder"], spec["step"]) if what == "config" else run_cofmupy(spec)
    except Exception as e:  # reported in the benchmark table, the benchmark goes on
        out = {"error": f"{type(e).__name__}: {_one_line(e)}"[:300]}
    sys.stdout.flush()
    print(("CONFIG " if what == "config" else "RESULT ") + json.dumps(out), flush=True)
    return 0


if __name__ == "__main__":
    if not __package__:
        # run as a script (in the CoFmuPy venv): this folder is sys.path[0]; without it, ``import cofmupy``
        # finds the package and not this file
        sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != HERE]
    sys.exit(main())
