"""Checkpoints of a whole run: save its state at a communication point, continue from it later, bit for bit.

``simulate(system, ..., checkpoint=("startup.ckpt", 0.5))`` (``run DRIVE --checkpoint-at 0.5 --checkpoint
startup.ckpt``) writes, at the first communication point at or after 0.5 s, everything the rest of the run
depends on, and runs on to its stop time; ``checkpoint="end.ckpt"`` writes it at the stop time (a later run
continues further).  ``simulate(system, ..., from_checkpoint="startup.ckpt")`` (``run DRIVE --from-checkpoint
startup.ckpt``) continues from it: its result holds the saved rows and the new ones, the same bit for bit as
the run that was never interrupted.

A checkpoint is a zip archive of:

``manifest.json``  the format, the toolkit version (the package's version and a hash of its ``harness/`` and
                   ``fmus/`` sources), the system's name and the hash of its structure (instances and their FMU
                   models and steps, connections, bonds), each FMU file's SHA-256, the run's settings (master,
                   extrapolation, step, step control, tolerance, start, recording, inputs, options), the
                   parameter values it ran with, and the time;
``fmus/<k>.bin``   each FMU's state as the FMU serializes it (``fmi2SerializeFMUstate``: the toolkit's FMUs
                   write their states as JSON, :func:`fmus.slave_core.state_to_bytes`);
``run.pickle``     the master's own state (:mod:`harness.master.saved`: signal vector, held inputs, extrapolation
                   history, bond energy, counters, rates), the step control's (ECCO's error memory and next step),
                   the divergence detector's, and the rows recorded so far.

Loading is refused in one line, before anything of ``run.pickle`` is read, for a checkpoint of another system
(other name or structure), of another toolkit version or FMU build, of other run settings, or from a time at
or after the stop time; a run whose FMUs cannot serialize their state refuses ``checkpoint=`` before it starts,
naming them.  ``run.pickle`` is Python's pickle: open only checkpoints you or your tools wrote.

Parameters may differ from the checkpoint's: those that do are set at its time, when the run continues (a
variant of a shared start-up, :func:`harness.studies.sweep` and ``compare``); a parameter its FMU fixes at
initialization is refused by the FMU, naming it.
"""
from __future__ import annotations

import hashlib
import json
import math
import pickle
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness.errors import SystemDescriptionError
from harness.master.clock import NS
from harness.master.observers import Observer
from harness.master.saved import master_state, restore_master_state
from harness.model import model_description

FORMAT = 1
ROOT = Path(__file__).resolve().parents[2]


@dataclass
class Checkpoint:
    """Where to write a checkpoint and from what time on (None: at the stop time)."""
    path: Path
    at: float | None = None

    @classmethod
    def of(cls, value) -> "Checkpoint | None":
        """From what ``simulate(checkpoint=...)`` takes: a path, (path, time) or a Checkpoint."""
        if value is None or isinstance(value, Checkpoint):
            return value
        if isinstance(value, (tuple, list)) and len(value) == 2:
            path, at = value
            if at is not None and (isinstance(at, bool) or not isinstance(at, (int, float)) or not math.isfinite(at)
                                   or at < 0):
                raise SystemDescriptionError(f"checkpoint time = {at!r} is not admissible: a finite time >= 0 s")
            return cls(Path(path), None if at is None else float(at))
        if isinstance(value, (str, Path)):
            return cls(Path(value))
        raise SystemDescriptionError(f"checkpoint = {value!r} is not admissible: a file, or (file, time [s])")


def toolkit_version() -> str:
    """The package's version and a hash of the sources that compute a run (``harness/`` and ``fmus/``)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        v = version("pressdrive")
    except PackageNotFoundError:   # pragma: no cover - a checkout without its metadata
        v = "unknown"
    h = hashlib.sha256()
    for folder in ("harness", "fmus"):
        for p in sorted((ROOT / folder).rglob("*.py")):
            h.update(p.relative_to(ROOT).as_posix().encode())
            h.update(p.read_bytes())
    return f"{v}+{h.hexdigest()[:12]}"


def _sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def structure(system, paths: dict) -> dict:
    """What makes a system the same system: its instances (name, model, own step), connections and bonds."""
    mds = {n: model_description(p) for n, p in paths.items()}
    return {"instances": [[i.name, mds[i.name].modelName, i.step] for i in system.instances],
            "connections": [[c.source, c.target, c.factor, c.offset,
                             None if c.mapping is None else sorted(map(list, c.mapping.items()))]
                            for c in system.all_connections(mds)],
            "bonds": [[b.motion_out, b.motion_in] for b in system.bonds]}


def manifest(system, paths: dict, settings: dict, parameters: dict) -> dict:
    """The manifest of a run (module docstring), but its time."""
    body = structure(system, paths)
    return {"format": FORMAT, "toolkit": toolkit_version(), "system": system.name,
            "structure": hashlib.sha256(json.dumps(body, sort_keys=True).encode()).hexdigest(),
            "fmus": {n: _sha256(p) for n, p in paths.items()}, "settings": settings,
            "parameters": {i: {k: _plain(v) for k, v in d.items()} for i, d in parameters.items()}}


def _plain(v):
    return v.item() if hasattr(v, "item") else v


def refuse_unserializable(fmus: dict, where: str) -> None:
    """One line naming the instances whose FMU cannot save or serialize its state, if any."""
    bad = [f"{n} ({Path(f.path).name})" for n, f in fmus.items()
           if not (getattr(f, "can_get_set_state", False) and getattr(f, "can_serialize", False))]
    if bad:
        raise SystemDescriptionError(f"{where}: instances {', '.join(bad)} cannot serialize their state "
                                     f"(canGetAndSetFMUstate and canSerializeFMUstate): no checkpoint of this run")


# -- writing ---------------------------------------------------------------------------------------------------------
class Writer(Observer):
    """Writes the checkpoint at the first accepted point at or after its time (observer of the run loop)."""

    def __init__(self, request: Checkpoint, head: dict, parts: dict, stop_ns: int):
        self.request, self.head, self.parts = request, head, parts
        at = request.at
        self.at_ns = stop_ns if at is None else int(round(at * NS))
        self.written: float | None = None

    def on_start(self, master, t_ns):
        if t_ns >= self.at_ns:
            self.write(master, t_ns)

    def on_step(self, master, t_prev_ns, t_ns):
        if self.written is None and t_ns >= self.at_ns:
            self.write(master, t_ns)

    def write(self, master, t_ns: int) -> None:
        controller, recorder, watch = self.parts["controller"], self.parts["recorder"], self.parts["watch"]
        states = []
        for it in master.insts:
            s = it.fmu.get_state()
            states.append(it.fmu.serialize_state(s))
            it.fmu.free_state(s)
        run = {"master": master_state(master),
               "controller": {k: v for k, v in vars(controller).items() if isinstance(v, (bool, int, float))},
               "recorder": _recorder_state(recorder), "watch": None if watch is None else
               {"detector": watch.detector, "start_ns": watch.start_ns}}
        head = dict(self.head, t_ns=int(t_ns), instances=[it.name for it in master.insts])
        path = self.request.path
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.writing")
        try:
            with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
                z.writestr("manifest.json", json.dumps(head, indent=1))
                for k, data in enumerate(states):
                    z.writestr(f"fmus/{k}.bin", data)
                z.writestr("run.pickle", pickle.dumps(run, protocol=pickle.HIGHEST_PROTOCOL))
            tmp.replace(path)
        finally:
            tmp.unlink(missing_ok=True)
        self.written = t_ns / NS


def _recorder_state(rec) -> dict:
    n = rec.rows
    return {"rows": n, "time": rec.time[:n].copy(), "data": rec.data[:n].copy(), "bonds": rec.bonds[:n].copy(),
            "columns": list(rec.columns), "typed": [list(values[:n]) for *_, values in rec._typed],
            "typed_at": [(None, None, k, kind, None) for _, _, k, kind, _ in rec._typed]}


# -- reading -----------------------------------------------------------------------------------------------------------
def read_manifest(path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise SystemDescriptionError(f"checkpoint {path}: no such file")
    try:
        with zipfile.ZipFile(path) as z:
            head = json.loads(z.read("manifest.json"))
    except (zipfile.BadZipFile, KeyError, ValueError, OSError) as e:
        raise SystemDescriptionError(f"checkpoint {path}: not a checkpoint of this toolkit ({e})") from None
    if head.get("format") != FORMAT:
        raise SystemDescriptionError(f"checkpoint {path}: format {head.get('format')!r}, this toolkit reads {FORMAT}")
    return head


class Resume:
    """A checkpoint to continue from: its manifest checked against the run's, then its state restored."""

    def __init__(self, path):
        self.path = Path(path)
        self.head = read_manifest(self.path)

    @property
    def t_ns(self) -> int:
        return int(self.head["t_ns"])

    def check(self, now: dict, stop_ns: int) -> None:
        """Refuse in one line what makes the checkpoint another run's (module docstring)."""
        h, where = self.head, f"checkpoint {self.path}"
        if h["system"] != now["system"]:
            raise SystemDescriptionError(f"{where} is of system {h['system']}, not {now['system']}")
        if h["structure"] != now["structure"]:
            raise SystemDescriptionError(f"{where}: system {now['system']} has other instances, connections or "
                                         f"bonds than the one it was written from")
        if h["toolkit"] != now["toolkit"]:
            raise SystemDescriptionError(f"{where} was written by toolkit {h['toolkit']}, this is {now['toolkit']}: "
                                         f"its state is another code's")
        for name, digest in now["fmus"].items():
            if h["fmus"].get(name) != digest:
                raise SystemDescriptionError(f"{where}: the FMU of instance {name} is another build than the one it "
                                             f"was written with (its file's SHA-256 differs)")
        for key, value in now["settings"].items():
            if key == "output" and set(value) <= set(h["settings"].get(key, [])):
                continue   # fewer columns than were recorded: the rows of those
            if h["settings"].get(key) != value:
                saved, name = h["settings"].get(key), key
                if key.endswith("_ns"):   # times in seconds, by the option's name
                    name = {"step_ns": "step", "start_ns": "start_time", "sample_ns": "output_interval"}[key]
                    saved, value = f"{saved / NS:g} s", f"{value / NS:g} s"
                raise SystemDescriptionError(f"{where}: {name} = {saved} in the checkpoint, {value} in this run "
                                             f"(continue with the checkpoint's)")
        if self.t_ns >= stop_ns:
            raise SystemDescriptionError(f"{where} is at t = {self.t_ns / NS:g} s: stop_time must be later "
                                         f"(got {stop_ns / NS:g} s)")

    def restore(self, master, controller, recorder, watch, parameters: dict) -> None:
        """Restore every FMU's state, the master's, the controller's, the detector's and the rows; then set the
        parameters that differ from the checkpoint's (``parameters``: the run's, by instance)."""
        with zipfile.ZipFile(self.path) as z:
            run = pickle.loads(z.read("run.pickle"))
            if self.head["instances"] != [it.name for it in master.insts]:
                raise SystemDescriptionError(f"checkpoint {self.path}: instances {self.head['instances']} differ from "
                                             f"the run's")
            for k, it in enumerate(master.insts):
                it.fmu.set_state(it.fmu.deserialize_state(z.read(f"fmus/{k}.bin")))
        restore_master_state(master, run["master"])
        for k, v in run["controller"].items():
            setattr(controller, k, v)
        _restore_recorder(recorder, run["recorder"])
        if watch is not None and run["watch"] is not None:
            watch.detector, watch.start_ns = run["watch"]["detector"], run["watch"]["start_ns"]
        saved = self.head["parameters"]
        t = self.t_ns / NS
        changed = []
        for it in master.insts:
            it.fmu.time = t
            for name, value in parameters.get(it.name, {}).items():
                before = saved.get(it.name, {}).get(name)
                if before == _plain(value):
                    continue
                v = it.fmu.variables[name]
                if v.causality == "parameter" and v.variability != "tunable":
                    raise SystemDescriptionError(f"checkpoint {self.path}: {it.name}.{name} = {value!r} differs from "
                                                 f"its {before!r} there, and its FMU fixes it at initialization "
                                                 f"(variability {v.variability}): it cannot change at t = {t:g} s; "
                                                 f"run from the start to change it")
                changed.append((it.fmu, name, value))
        for fmu, name, value in changed:
            fmu.set_value(name, value)
        if changed:
            master.refresh(t)

    def first_ns(self, controller) -> int | None:
        return getattr(controller, "next_ns", None)


def _restore_recorder(rec, state: dict) -> None:
    """The rows saved, of the run's columns (the same as the checkpoint's run's, or some of them)."""
    where = {c: k for k, c in enumerate(state["columns"])}
    n = state["rows"]
    while len(rec.time) < n:
        rec._grow()
    rec.time[:n], rec.bonds[:n] = state["time"], state["bonds"]
    rec.data[:n] = state["data"][:, [where[c] for c in rec.columns]]
    typed = {state["columns"][k]: values for (_, _, k, _, _), values in zip(state["typed_at"], state["typed"])}
    for _, _, k, _, values in rec._typed:
        values[:] = typed[rec.columns[k]]
    rec.rows = n


class Resumed(Observer):
    """An observer of a resumed run: told of everything but the start (its start was the checkpoint's run's)."""

    def __init__(self, inner):
        self.inner = inner

    def on_event(self, master, t_ns):
        self.inner.on_event(master, t_ns)

    def on_step(self, master, t_prev_ns, t_ns):
        self.inner.on_step(master, t_prev_ns, t_ns)

    def on_end(self, master, t_ns, completed):
        self.inner.on_end(master, t_ns, completed)


def signals_digest(signals) -> str:
    """A short hash of a run's input table (:class:`harness.signals.Signals`: its times and values), for the
    settings."""
    if hasattr(signals, "digest"):   # a libcosim scenario (harness.osp.scenario)
        return signals.digest()
    h = hashlib.sha256(np.asarray(signals.t_ns, dtype=np.int64).tobytes())
    for inst, var, _, values in signals.columns:
        h.update(repr((inst, var, [_plain(v) for v in values])).encode())
    return h.hexdigest()[:16]


__all__ = ["Checkpoint", "Writer", "Resume", "Resumed", "toolkit_version", "manifest", "read_manifest",
           "refuse_unserializable"]
