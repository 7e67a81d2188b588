"""Scenes: a question asked of a press drive, answered with the coarsest model that still answers it.

A scene (declared as data in a ``systems/`` module, ``SYSTEM.scenes``) names a quantity of interest (a
:mod:`harness.reporting.qoi` expression), a tolerance and a time window (``stop_time`` may shorten the run).
:func:`choose` then

1. runs the full model (every component at its highest ``fidelity``, at the scene's step) with a method that
   runs it to the end AND is accurate there (:func:`full_model`): the system's master first, then the
   masters of the accuracy study's ladder (:data:`harness.studies.accuracy.DEFAULT_METHODS`), the first whose
   run completes and whose quantity agrees with its own run at half the step within
   :data:`FULL_MODEL_AGREEMENT` of the scene's tolerance.  That measured check needs nothing of the drive
   but the scene itself (any drive, with or without a declared accuracy), and it judges the very quantity the
   candidates are compared on.  No method passing stops the scene in one line naming each method's outcome.
   The full model, its check and the methods refused are cached (``results/cache/``, keyed by a hash of the
   system, the scene, the equation sources and this rule): a repeat does not run them again;
2. greedy search over components, in the order the system lists them (stated, reproducible): for each
   component with a ``fidelity`` parameter, try its lower levels from the lowest up and keep the lowest whose
   quantity stays within tolerance of the full model, given the choices already made (with the full model's
   master and step, so a difference is the model's, not the method's);
3. for the chosen fidelities and each searched master (the full model's, the system's and ``gauss-seidel``;
   see :func:`choose` for why not the others), doubles the communication step while the quantity stays within
   tolerance and the run completes; the cheapest is the configuration with the fewest FMU steps (fmi2DoStep
   calls summed over the FMUs: ``jacobian`` takes at least two per communication step, ``jacobi`` and
   ``gauss-seidel`` one), ties going to the larger step, then to the first master searched -- a deterministic
   rule, unlike comparing noisy wall times;
4. measures the chosen model's wall time and the full model's side by side in the same process (the speed-up);
   on a cached repeat the full model's wall time is the cached one (``remeasure=True`` times it again).

Every candidate run is recorded (fidelities, step, master, quantity, error, wall time, FMU steps, its role)
for the cost-vs-error chart.  The tolerance is relative to the full model's value unless ``relative=False``.

Several scenes of one system answered together (``scene SYSTEM --all``, :class:`SharedRuns`) share their runs:
a run of the same fidelities, step, master and stop time is made once and each scene's quantity read from it.
The scenes of a drive ask different quantities of the same model, so their full models, its check at half the
step (the dearest runs of a search) and the first lowered levels of the greedy search are the same runs.
"""
from __future__ import annotations

import hashlib
import json
import sys
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import pandas as pd

from harness.reporting import qoi
from harness.reporting.charts import save_figure
from harness.specs import Scene  # noqa: F401 (declared with the systems; re-exported)
from harness.studies.trial import (StudyInterrupted, keep_interrupted, one_line, partial_csv, trial,
                                   write_complete)


@dataclass
class Candidate:
    fidelities: dict[str, int]
    step: float
    value: float | None
    error: float | None
    wall_time: float
    ok: bool
    note: str = ""
    master: str = ""
    fmu_steps: int | None = None  # fmi2DoStep calls summed over the FMUs (None: the run raised)
    role: str = "search"          # "full model", "full-model check" (half its step), "full model refused", "search"


FULL_MODEL_AGREEMENT = 0.1
"""The full model's quantity at the scene's step and at half of it must agree within this share of the scene's
tolerance (the error of the run at the full step is then about this share, or twice it for a first-order
method: small beside the tolerance the candidates are judged by)."""
FULL_MODEL_RULE = "full model: completes and agrees with half its step (1)"   # part of the cache key


@dataclass
class SceneResult:
    scene: Scene
    full: Candidate
    chosen: Candidate
    candidates: list[Candidate] = field(default_factory=list)
    speedup: float = float("nan")
    cached_full: bool = False     # the full model's value and wall time came from the cache

    def table(self) -> pd.DataFrame:
        return candidate_table(self.candidates)

    def full_model_text(self) -> str:
        """How the full model was run, in words: its master and step, the methods refused before it and why,
        and its check at half the step."""
        return full_model_text(self.scene, self.full, self.candidates)


def candidate_table(candidates: list[Candidate]) -> pd.DataFrame:
    """One row per candidate run: step, value, error, wall time, ok, note, master and ``fidelity:<instance>``."""
    rows = [dict(asdict(c), **{f"fidelity:{k}": v for k, v in c.fidelities.items()}) for c in candidates]
    return pd.DataFrame(rows).drop(columns=["fidelities"], errors="ignore")


def find_scene(system, name: str | None = None) -> Scene:
    """The scene ``name`` of ``system``, or its default scene when ``name`` is None."""
    from harness.errors import SystemDescriptionError

    scenes = {s.name: s for s in getattr(system, "scenes", [])}
    key = name if name is not None else getattr(system, "default_scene", None)
    if key is None:
        raise SystemDescriptionError(f"system {system.name} has no default scene: name one of "
                                     f"{', '.join(sorted(scenes)) or '(none)'}")
    if key not in scenes:
        raise SystemDescriptionError(f"system {system.name} has no scene {key!r}; known: "
                                     f"{', '.join(sorted(scenes)) or 'none'}")
    return scenes[key]


def fidelity_levels(system) -> dict[str, tuple[int, ...]]:
    """Instance -> admissible fidelity levels (ascending), for instances whose component has one: the levels
    its parameters admit (CamRocker's level 3 exists for the slotted rocker only, not for seed 004's disc cam)."""
    from fmus.physics.base import ParameterError
    from harness.model import model_name
    from harness.studies.reference import component_classes

    classes = component_classes()
    out = {}
    for inst in system.instances:
        cls = classes.get(model_name(inst.fmu))
        if cls is None:
            continue
        f = cls.model.Params.__dataclass_fields__.get("fidelity")
        if f is None or not f.metadata.get("choices"):
            continue
        admitted = []
        for level in sorted(f.metadata["choices"]):
            try:
                cls.model.Params(**{**inst.parameters, "fidelity": level}).validate()
            except ParameterError:
                continue
            admitted.append(level)
        out[inst.name] = tuple(admitted)
    return out


def _key(system, scene: Scene) -> str:
    """Hash of the system, the scene and the equation sources (a changed model invalidates the cache)."""
    model = (system.name, system.instances, system.connections, system.bonds, system.experiment)
    h = hashlib.sha1(repr((model, asdict(scene), FULL_MODEL_RULE)).encode())
    root = Path(__file__).resolve().parents[2] / "fmus"
    for src in sorted([*root.glob("physics/*.py"), *root.glob("components/pd_*.py"), root / "slave.py"]):
        h.update(src.read_bytes())
    return h.hexdigest()[:16]


class SharedRuns:
    """The runs of the scenes ``scenes`` of ``system``, each distinct run made once (the module docstring): a
    run records the columns every one of those scenes' quantities reads (all of them where one reads the whole
    result), so any of the scenes evaluates its quantity on it."""

    def __init__(self, system, scenes: list[Scene]):
        wanted = [qoi.columns(s.quantity) for s in scenes]
        self.output = None if not all(wanted) else list(dict.fromkeys(c for cols in wanted for c in cols))
        self.system = system
        self.made: dict[tuple, object] = {}
        self.timed: dict[tuple, float] = {}    # a configuration's wall time measured side by side (choose, 4.)

    def trial(self, key: tuple, **options):
        if key not in self.made:
            self.made[key] = trial(self.system, output=self.output, **options)
        return self.made[key]


def _run(system, scene: Scene, fidelities: dict[str, int], step: float, full_value: float | None,
         master: str | None = None, runs: SharedRuns | None = None) -> Candidate:
    """One candidate: the scene's quantity of ``system`` at ``fidelities``, ``step`` and ``master``, judged
    against ``full_value`` (None: it is the full model).  ``runs``: shared with other scenes (made once)."""
    options = _options(system, scene, fidelities, step, master)
    master = options["master"]
    t0 = time.perf_counter()
    # quiet: a candidate that blows up or stops early is expected in the search and says so in its own row
    # (``note``); printed per run, five such lines named no configuration
    if runs is None:
        run = trial(system, output=qoi.columns(scene.quantity) or None, **options)
    else:
        run = runs.trial(_configuration_key(options), **options)
    wall = run.wall_time
    steps = None if run.result is None else run.result.attrs.get("fmu_steps")
    steps = None if steps is None else int(steps)
    if not run.complete:
        return Candidate(dict(fidelities), step, None, None, wall, False, run.error, master, steps)
    try:
        value = qoi.evaluate(scene.quantity, run.result)
    except Exception as e:
        return Candidate(dict(fidelities), step, None, None, time.perf_counter() - t0, False, one_line(e), master,
                         steps)
    if full_value is None:
        return Candidate(dict(fidelities), step, value, 0.0, wall, True, "", master, steps)
    err = abs(value - full_value)
    return Candidate(dict(fidelities), step, value, err, wall, err <= _bound(scene, full_value), "", master, steps)


def _options(system, scene: Scene, fidelities: dict[str, int], step: float, master: str | None) -> dict:
    """The options of a candidate's run (:func:`harness.studies.trial.trial`'s, the recorded columns aside)."""
    exp = system.experiment
    return dict(stop_time=scene.stop_time or exp.stop_time, step=step, master=master or exp.master,
                extrapolation=exp.extrapolation, start_values={f"{k}.fidelity": v for k, v in fidelities.items()})


def _configuration_key(options: dict) -> tuple:
    """What makes two runs of one system the same run (their options, the fidelities sorted)."""
    return tuple((k, tuple(sorted(v.items())) if isinstance(v, dict) else v) for k, v in sorted(options.items()))


def _bound(scene: Scene, full_value: float) -> float:
    """The admissible |error| of the scene's quantity around the full model's value."""
    return scene.tolerance * (abs(full_value) if scene.relative else 1.0)


def _better(a: Candidate, b: Candidate) -> bool:
    """a is cheaper than b: fewer FMU steps (fmi2DoStep calls: the cost that holds on any machine, and the one
    that tells ``jacobian``'s two or more calls per communication step from ``jacobi``'s one), a tie going to the
    larger step.  Deterministic, so the search is reproducible."""
    if a.fmu_steps is not None and b.fmu_steps is not None and a.fmu_steps != b.fmu_steps:
        return a.fmu_steps < b.fmu_steps
    return a.step > b.step * (1.0 + 1e-9)


class FullModelError(RuntimeError):
    """No method runs a scene's full model to the end and accurately at the scene's step: the message (one line)
    names each method tried and why it was refused; ``table`` holds those runs (a DataFrame)."""

    def __init__(self, message: str, table: pd.DataFrame):
        super().__init__(message)
        self.table = table


def _methods(system) -> list[str]:
    """The masters that may run a scene's full model, in the order tried: the system's, then those of the
    accuracy study's ladder (the methods a drive's accuracy is measured with)."""
    from harness.studies.accuracy import DEFAULT_METHODS

    return list(dict.fromkeys([system.experiment.master, *(m for m, _ in DEFAULT_METHODS)]))


def full_model(system, scene: Scene, fidelities: dict[str, int], step: float,
               candidates: list[Candidate], runs: SharedRuns | None = None) -> Candidate:
    """The full model's run at ``step`` with the first method of :func:`_methods` that runs it to the end and
    agrees with its own run at half the step within :data:`FULL_MODEL_AGREEMENT` of the scene's tolerance (the
    module docstring: why this check).  Every run made is appended to ``candidates`` (the refused ones, then the
    full model and its check, with their ``role``); the accepted full model is returned.  None accepted:
    :class:`FullModelError`.  ``runs``: shared with other scenes (:class:`SharedRuns`)."""
    refused = []
    for master in _methods(system):
        candidates.append(replace(_run(system, scene, fidelities, step, None, master, runs), role="full model refused"))
        full = candidates[-1]
        if not full.ok:
            refused.append(f"{master} stopped: {full.note}")
            continue
        candidates.append(replace(_run(system, scene, fidelities, step / 2, full.value, master, runs),
                                  role="full model refused"))
        half = candidates[-1]
        allowed = FULL_MODEL_AGREEMENT * _bound(scene, full.value)
        if half.ok and half.error <= allowed:
            candidates[-2:] = [replace(full, role="full model"), replace(half, role="full-model check")]
            return candidates[-2]
        why = (f"at half the step it stopped: {half.note}" if half.error is None else
               f"differs from its run at half the step by {half.error:.3g} {scene.unit}, more than "
               f"{FULL_MODEL_AGREEMENT:g} of the tolerance ({allowed:.3g} {scene.unit})".replace(" )", ")"))
        note = f"not accurate at {step:g} s: {why}"
        candidates[-2:] = [replace(full, ok=False, note=note), replace(half, ok=False)]
        refused.append(f"{master} {note}")
    raise FullModelError(f"scene {scene.name}: no method runs the full model to the end and accurately at the "
                         f"scene's step {step:g} s: " + "; ".join(refused)
                         + " (a smaller step for the scene, Scene.step in the system's module, may)",
                         candidate_table(candidates))


def full_model_text(scene: Scene, full: Candidate, candidates: list[Candidate]) -> str:
    """``full model: gauss-seidel at 0.2 ms, agrees with its run at 0.1 ms to 2.76e-07 m (allowed 0.000149 m);
    refused before it: jacobi (t = 0.8296 s: ...)`` -- what the scene's output says about its reference run."""
    check = next((c for c in candidates if c.role == "full-model check"), None)
    text = f"full model: {full.master} at {full.step * 1e3:g} ms"
    if check is not None and check.error is not None:
        text += (f", agrees with its run at {check.step * 1e3:g} ms to {check.error:.3g} {scene.unit} (allowed "
                 f"{FULL_MODEL_AGREEMENT * _bound(scene, full.value):.3g} {scene.unit})").replace(" )", ")")
    refused = list(dict.fromkeys(c.master for c in candidates if c.role == "full model refused"))
    if refused:
        text += "; refused before it: " + ", ".join(
            f"{m} ({next(c.note for c in candidates if c.master == m and c.role == 'full model refused')})"
            for m in refused)
    return text


def choose(system, scene: Scene, cache_dir: Path = Path("results/cache"), max_doublings: int = 10,
           masters: tuple[str, ...] | None = None, remeasure: bool = False,
           runs: SharedRuns | None = None) -> SceneResult:
    """Answer ``scene`` on ``system`` with the coarsest adequate model (module docstring: the search).

    ``masters``: the masters whose largest admissible step is searched (default: the full model's master, the
    system's and ``gauss-seidel``).  ``iterative`` is not searched: it repeats every step until the coupling converges,
    so it costs several FMU steps per communication step and only pays off with algebraic loops, which the
    press drives do not have; ``jacobi-sampled`` costs the same as ``jacobi`` and is less accurate (it
    exists to compare with other tools step by step).  ``max_doublings`` bounds the doubling (1024 times the
    scene's step by default: a doubled run costs half the one before, and the tolerance ends the doubling
    first).  The full model's run is cached in ``cache_dir``; a
    repeat does not run it again and takes its wall time from the cache unless ``remeasure`` is True.
    ``runs``: the runs shared with other scenes of the system (:class:`SharedRuns`; None: this scene's own).
    """
    candidates: list[Candidate] = []
    try:  # Ctrl-C or SIGTERM: the candidates run so far go with the interrupt
        return _choose(system, scene, cache_dir, max_doublings, masters, remeasure, candidates, runs)
    except KeyboardInterrupt as e:
        raise StudyInterrupted(candidate_table(candidates), e) from None


def _choose(system, scene: Scene, cache_dir: Path, max_doublings: int, masters, remeasure: bool,
            candidates: list[Candidate], runs: SharedRuns | None) -> SceneResult:
    levels = fidelity_levels(system)
    full_f = {k: v[-1] for k, v in levels.items()}
    exp = system.experiment
    step0, master0 = scene.step or exp.step, exp.master
    cache = cache_dir / f"{system.name}_{scene.name}_{_key(system, scene)}.json"
    cached = cache.exists()
    if cached:           # the full model first, then the runs that chose its method (as when it was run)
        stored = [Candidate(**c) for c in json.loads(cache.read_text())]
        candidates += [c for c in stored if c.role == "full model"] + [c for c in stored if c.role != "full model"]
    else:
        full_model(system, scene, full_f, step0, candidates, runs)
        candidates.sort(key=lambda c: c.role != "full model")   # the full model first (stable: the rest in order)
        cache.parent.mkdir(parents=True, exist_ok=True)
        cache.write_text(json.dumps([asdict(c) for c in candidates]))
    full = candidates[0]
    master1 = full.master            # the method the full model is run with: the search compares models with it
    if masters is None:
        masters = tuple(dict.fromkeys((master1, master0, "gauss-seidel")))
    current = dict(full_f)
    for inst, lv in levels.items():  # greedy, in the system's instance order
        for level in lv[:-1]:
            trial = dict(current, **{inst: level})
            c = _run(system, scene, trial, step0, full.value, master1, runs)
            candidates.append(c)
            if c.ok:
                current = trial
                break
    chosen = next((c for c in reversed(candidates) if c.ok and c.role == "search" and c.fidelities == current
                   and c.step == step0 and c.master == master1), full)
    for master in masters:           # the largest admissible step of each master, by doubling
        step = step0
        if master != master1:
            c = _run(system, scene, current, step0, full.value, master, runs)
            candidates.append(c)
            if not c.ok:
                continue
            if _better(c, chosen):
                chosen = c
        for _ in range(max_doublings):
            c = _run(system, scene, current, step * 2, full.value, master, runs)
            candidates.append(c)
            if not c.ok:
                break
            step = step * 2
            if _better(c, chosen):
                chosen = c
    if remeasure or not cached:      # cost side by side in this process (warm: after the search)
        full = candidates[0] = replace(full, wall_time=_timed(system, scene, full, runs))
        n_full = 1 + sum(c.role != "search" for c in candidates[1:])
        cache.write_text(json.dumps([asdict(c) for c in candidates[:n_full]]))
        chosen_again = replace(chosen, wall_time=_timed(system, scene, chosen, runs))
    else:
        chosen_again = chosen
    speedup = full.wall_time / chosen_again.wall_time if chosen_again.wall_time > 0 else float("nan")
    return SceneResult(scene, full, chosen_again, candidates, speedup, cached_full=cached and not remeasure)


def _timed(system, scene: Scene, c: Candidate, runs: SharedRuns | None) -> float:
    """The wall time of candidate ``c``'s configuration run again, warm, beside the others (choose, 4.); with
    shared runs, a configuration another scene timed already keeps that time (the same run)."""
    key = _configuration_key(_options(system, scene, c.fidelities, c.step, c.master))
    if runs is not None and key in runs.timed:
        return runs.timed[key]
    wall = _run(system, scene, c.fidelities, c.step, None, c.master).wall_time
    if runs is not None:
        runs.timed[key] = wall
    return wall


def configuration(c: Candidate, full: Candidate) -> str:
    """What distinguishes candidate ``c`` from the full model, in words: the lowered fidelity levels, the
    step, the master ("fourbar level 1, cam level 1, step 0.4 ms")."""
    parts = [f"{k} level {v}" for k, v in c.fidelities.items() if full.fidelities.get(k) != v]
    if abs(c.step - full.step) > 1e-12 * full.step:
        parts.append(f"step {c.step * 1e3:g} ms")
    if c.master != full.master:
        parts.append(c.master)
    return ", ".join(parts) or "full model"


def chart(result: SceneResult, out: Path) -> list[Path]:
    """Error of the scene's quantity against each candidate's wall time.  Every candidate is a numbered point
    whose configuration the key beside the axes names; a candidate that stopped early (no quantity) is drawn
    on a band above the others; the full model, the reference, is the vertical line at its cost."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

    full, ch = result.full, result.chosen
    rest = [c for c in result.candidates[1:] if c.role == "search"]   # [0]: the full model; not its method runs
    measured = [c for c in rest if c.error is not None]
    unit = f" [{result.scene.unit}]" if result.scene.unit else ""
    tol = result.scene.tolerance * (abs(full.value) if result.scene.relative else 1.0)
    errors = [c.error for c in measured if c.error > 0.0] + [tol]
    floor = min(errors) / 10.0                  # where an error of exactly 0 is drawn on the log axis
    top = max(errors) * 4.0                     # the band of the runs that stopped early

    fig, ax = plt.subplots(figsize=(10.0, 4.8))
    ax.axvline(full.wall_time, color="tab:blue", ls=":", lw=1.2)
    ax.axhline(tol, color="grey", ls="--", lw=1)
    ax.axhspan(top / 1.6, top * 1.6, color="0.93", zorder=0)
    key = []
    for n, c in enumerate(rest, start=1):
        y = top if c.error is None else max(c.error, floor)
        style = (dict(marker="^", color="tab:red", mfc="none") if c.error is None
                 else dict(marker="o", color="tab:green") if c.ok else dict(marker="x", color="tab:red"))
        ax.plot([c.wall_time], [y], ls="none", ms=7, **style)
        ax.annotate(str(n), (c.wall_time, y), xytext=(5, 4), textcoords="offset points", fontsize=7)
        why = "" if c.error is not None else " (stopped early)"
        key.append(f"{n:2d}  {configuration(c, full)}{why}")
    y_ch = top if ch.error is None else max(ch.error, floor)
    ax.plot([ch.wall_time], [y_ch], ls="none", marker="o", ms=15, mfc="none", mec="k")
    handles = [Line2D([], [], color="tab:blue", ls=":",
                      label=f"full model (the reference): {full.wall_time:.2g} s a run"),
               Line2D([], [], ls="none", marker="o", color="tab:green", label="within tolerance"),
               Line2D([], [], ls="none", marker="x", color="tab:red", label="outside tolerance"),
               Line2D([], [], ls="none", marker="^", color="tab:red", mfc="none",
                      label="stopped early (blow-up): no quantity"),
               Line2D([], [], ls="none", marker="o", ms=11, mfc="none", mec="k",
                      label=f"chosen: {configuration(ch, full)} (speed-up {result.speedup:.2f}x)"),
               Line2D([], [], color="grey", ls="--", label=f"tolerance {tol:.3g} {result.scene.unit}".rstrip())]
    first = ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)
    ax.add_artist(first)
    blank = [Line2D([], [], ls="none")] * len(key)
    ax.legend(blank, key, fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 0.62), frameon=False,
              handlelength=0, handletextpad=0, title="candidates (what differs from the full model)",
              title_fontsize=7, alignment="left")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(floor / 1.5, top * 2.0)
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(FormatStrFormatter("%g"))
        axis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("wall time per run [s]")
    ax.set_ylabel(f"|error| of the quantity{unit}")
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title(f"{result.scene.name}: {result.scene.question}", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, out)


def register(subparsers) -> None:
    p = subparsers.add_parser("scene", help="answer a scene's question with the coarsest adequate model")
    p.add_argument("system", help="system module name in systems/")
    p.add_argument("scene", nargs="?", default=None,
                   help="scene name (see the system's SYSTEM.scenes; default: its default scene)")
    p.add_argument("--out", type=Path, default=Path("results"), help="folder for the chart and table")
    p.add_argument("--remeasure", action="store_true", help="time the full model again even if it is cached")
    p.add_argument("--all", action="store_true",
                   help="answer every scene of the system, in its order, sharing the runs they have in common "
                        "(the same model, step, master and stop time run once)")
    p.set_defaults(func=_run_cli)


def _run_cli(args) -> int:
    from harness import load

    system = load(args.system)
    if args.all and args.scene is not None:
        print(f"error: scene {args.system}: name a scene or give --all, not both ({args.scene!r} and --all)",
              file=sys.stderr)
        return 2
    asked = list(system.scenes) if args.all else [find_scene(system, args.scene)]
    if not asked:
        print(f"error: system {system.name} declares no scenes (SYSTEM.scenes in its module)", file=sys.stderr)
        return 1
    runs = SharedRuns(system, asked)
    status = 0
    for scene in asked:
        status = _answer(system, scene, args, runs) or status
        if status in (130, 143):        # interrupted: the rest is not asked
            break
    return status


def _answer(system, scene: Scene, args, runs: SharedRuns) -> int:
    """One scene answered and printed (its CSV and chart written); the exit status."""
    stem = args.out / f"scene_{system.name}_{scene.name}"
    try:
        res = choose(system, scene, cache_dir=args.out / "cache", remeasure=args.remeasure, runs=runs)
    except StudyInterrupted as e:
        return keep_interrupted(e, stem.with_suffix(".csv"), f"scene {scene.name} stopped during its search")
    except FullModelError as e:     # its runs kept, as an interrupted search keeps its candidates
        out = partial_csv(stem.with_suffix(".csv"))
        out.parent.mkdir(parents=True, exist_ok=True)
        e.table.to_csv(out, index=False)
        print(f"error: {e}; the {len(e.table)} runs made are kept in {out}", file=sys.stderr)
        return 1
    csv = write_complete(res.table(), stem.with_suffix(".csv"))
    paths = chart(res, stem)
    print(f"scene {scene.name}: {res.scene.question}")
    print(f"  {res.full_model_text()}")
    print(f"  chosen fidelities: {res.chosen.fidelities}, step {res.chosen.step:g} s, master {res.chosen.master} "
          f"({configuration(res.chosen, res.full)})")
    print(f"  quantity: {res.chosen.value:.6g} {res.scene.unit} (full model {res.full.value:.6g}); "
          f"error {res.chosen.error:.3g}")
    print(f"  wall time: full {res.full.wall_time:.3f} s, chosen {res.chosen.wall_time:.3f} s, "
          f"speed-up {res.speedup:.2f}x " + ("(full model from the cache)" if res.cached_full
                                             else "(measured side by side in this run)"))
    searched = [c for c in res.candidates if c.role == "search"]
    stopped = [c for c in searched if c.error is None]
    if stopped:
        print(f"  {len(stopped)} of {len(searched)} candidates stopped early (their reasons: the note "
              f"column of {csv})")
    print(f"  chart: {paths[0]}")
    return 0
