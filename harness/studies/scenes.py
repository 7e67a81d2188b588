"""Scenes: a question asked of a press drive, answered with the coarsest model that still answers it.

A scene (declared as data in a ``systems/`` module, ``SYSTEM.scenes``) names a quantity of interest (a
:mod:`harness.qoi` expression), a tolerance and a time window (``stop_time`` may shorten the run).
:func:`choose` then

1. runs the full model (every component at its highest ``fidelity``, the system's default step and master)
   and caches its quantity of interest and wall time (``results/cache/``, keyed by a hash of the system,
   the scene and the equation sources): a repeat does not run the full model again;
2. greedy search over components, in the order the system lists them (stated, reproducible): for each
   component with a ``fidelity`` parameter, try its lower levels from the lowest up and keep the lowest whose
   quantity stays within tolerance of the full model, given the choices already made;
3. for the chosen fidelities and each searched master (the system's and ``gauss-seidel``; see :func:`choose`
   for why not the others), doubles the communication step while the quantity stays within tolerance and the
   run completes; the cheapest is the configuration with the largest step (same FMU calls per step), ties
   going to the system's master -- a deterministic rule, unlike comparing noisy wall times;
4. measures the chosen model's wall time and the full model's side by side in the same process (the speed-up);
   on a cached repeat the full model's wall time is the cached one (``remeasure=True`` times it again).

Every candidate run is recorded (fidelities, step, master, quantity, error, wall time) for the
cost-vs-error chart.  The tolerance is relative to the full model's value unless ``relative=False``.
"""
from __future__ import annotations

import hashlib
import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import pandas as pd

from harness import qoi
from harness.charts import save_figure
from harness.specs import Scene  # noqa: F401 (declared with the systems; re-exported)
from harness.studies.trial import StudyInterrupted, keep_interrupted, one_line, trial, write_complete


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


def candidate_table(candidates: list[Candidate]) -> pd.DataFrame:
    """One row per candidate run: step, value, error, wall time, ok, note, master and ``fidelity:<instance>``."""
    rows = [dict(asdict(c), **{f"fidelity:{k}": v for k, v in c.fidelities.items()}) for c in candidates]
    return pd.DataFrame(rows).drop(columns=["fidelities"], errors="ignore")


def find_scene(system, name: str | None = None) -> Scene:
    """The scene ``name`` of ``system``, or its default scene when ``name`` is None."""
    from harness.errors import SystemError_

    scenes = {s.name: s for s in getattr(system, "scenes", [])}
    key = name if name is not None else getattr(system, "default_scene", None)
    if key is None:
        raise SystemError_(f"system {system.name} has no default scene: name one of "
                           f"{', '.join(sorted(scenes)) or '(none)'}")
    if key not in scenes:
        raise SystemError_(f"system {system.name} has no scene {key!r}; known: {', '.join(sorted(scenes)) or 'none'}")
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
    h = hashlib.sha1(repr((model, asdict(scene))).encode())
    root = Path(__file__).resolve().parents[2] / "fmus"
    for src in sorted([*root.glob("physics/*.py"), *root.glob("components/pd_*.py"), root / "slave.py"]):
        h.update(src.read_bytes())
    return h.hexdigest()[:16]


def _run(system, scene: Scene, fidelities: dict[str, int], step: float, full_value: float | None,
         master: str | None = None) -> Candidate:
    params = {f"{k}.fidelity": v for k, v in fidelities.items()}
    exp = system.experiment
    master = master or exp.master
    t0 = time.perf_counter()
    # quiet: a candidate that blows up or stops early is expected in the search and says so in its own row
    # (``note``); printed per run, five such lines named no configuration
    run = trial(system, stop_time=scene.stop_time or exp.stop_time, step=step,
                master=master, extrapolation=exp.extrapolation, start_values=params,
                output=qoi.columns(scene.quantity) or None)
    wall = run.wall_time
    if not run.complete:
        return Candidate(dict(fidelities), step, None, None, wall, False, run.error, master)
    try:
        value = qoi.evaluate(scene.quantity, run.result)
    except Exception as e:
        return Candidate(dict(fidelities), step, None, None, time.perf_counter() - t0, False, one_line(e), master)
    if full_value is None:
        return Candidate(dict(fidelities), step, value, 0.0, wall, True, "", master)
    err = abs(value - full_value)
    bound = scene.tolerance * (abs(full_value) if scene.relative else 1.0)
    return Candidate(dict(fidelities), step, value, err, wall, err <= bound, "", master)


def _better(a: Candidate, b: Candidate) -> bool:
    """a is cheaper than b: a larger step (fewer communication steps; the FMU calls per step are the same
    for ``jacobi`` and ``gauss-seidel``).  Deterministic, so the search is reproducible."""
    return a.step > b.step * (1.0 + 1e-9)


def choose(system, scene: Scene, cache_dir: Path = Path("results/cache"), max_doublings: int = 6,
           masters: tuple[str, ...] | None = None, remeasure: bool = False) -> SceneResult:
    """Answer ``scene`` on ``system`` with the coarsest adequate model (module docstring: the search).

    ``masters``: the masters whose largest admissible step is searched (default: the system's master and
    ``gauss-seidel``).  ``iterative`` is not searched: it repeats every step until the coupling converges,
    so it costs several FMU steps per communication step and only pays off with algebraic loops, which the
    press drives do not have; ``jacobi-sampled`` costs the same as ``jacobi`` and is less accurate (it
    exists to compare with other tools step by step).  The full model's run is cached in ``cache_dir``; a
    repeat does not run it again and takes its wall time from the cache unless ``remeasure`` is True.
    """
    candidates: list[Candidate] = []
    try:  # Ctrl-C or SIGTERM: the candidates run so far go with the interrupt
        return _choose(system, scene, cache_dir, max_doublings, masters, remeasure, candidates)
    except KeyboardInterrupt as e:
        raise StudyInterrupted(candidate_table(candidates), e) from None


def _choose(system, scene: Scene, cache_dir: Path, max_doublings: int, masters, remeasure: bool,
            candidates: list[Candidate]) -> SceneResult:
    levels = fidelity_levels(system)
    full_f = {k: v[-1] for k, v in levels.items()}
    exp = system.experiment
    step0, master0 = scene.step or exp.step, exp.master
    if masters is None:
        masters = tuple(dict.fromkeys((master0, "gauss-seidel")))
    cache = cache_dir / f"{system.name}_{scene.name}_{_key(system, scene)}.json"
    cached = cache.exists()
    if cached:
        full = Candidate(**json.loads(cache.read_text()))
    else:
        full = _run(system, scene, full_f, step0, None, master0)
        if not full.ok:
            raise RuntimeError(f"scene {scene.name}: the full model failed: {full.note}")
        cache.parent.mkdir(parents=True, exist_ok=True)
        cache.write_text(json.dumps(asdict(full)))
    candidates.append(full)
    current = dict(full_f)
    for inst, lv in levels.items():  # greedy, in the system's instance order
        for level in lv[:-1]:
            trial = dict(current, **{inst: level})
            c = _run(system, scene, trial, step0, full.value, master0)
            candidates.append(c)
            if c.ok:
                current = trial
                break
    chosen = next((c for c in reversed(candidates) if c.ok and c.fidelities == current and c.step == step0), full)
    for master in masters:           # the largest admissible step of each master, by doubling
        step = step0
        if master != master0:
            c = _run(system, scene, current, step0, full.value, master)
            candidates.append(c)
            if not c.ok:
                continue
            if _better(c, chosen):
                chosen = c
        for _ in range(max_doublings):
            c = _run(system, scene, current, step * 2, full.value, master)
            candidates.append(c)
            if not c.ok:
                break
            step = step * 2
            if _better(c, chosen):
                chosen = c
    if remeasure or not cached:      # cost side by side in this process (warm: after the search)
        full_again = _run(system, scene, full_f, step0, full.value, master0)
        full = Candidate(**dict(asdict(full), wall_time=full_again.wall_time))
        cache.write_text(json.dumps(asdict(full)))
        chosen_again = _run(system, scene, chosen.fidelities, chosen.step, full.value, chosen.master)
    else:
        chosen_again = chosen
    speedup = full.wall_time / chosen_again.wall_time if chosen_again.wall_time > 0 else float("nan")
    return SceneResult(scene, full, chosen_again, candidates, speedup, cached_full=cached and not remeasure)


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
    rest = [c for c in result.candidates[1:]]   # the first candidate is the full model itself
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
    p.set_defaults(func=_run_cli)


def _run_cli(args) -> int:
    from harness import load

    system = load(args.system)
    scene = find_scene(system, args.scene)
    stem = args.out / f"scene_{system.name}_{scene.name}"
    try:
        res = choose(system, scene, cache_dir=args.out / "cache", remeasure=args.remeasure)
    except StudyInterrupted as e:
        return keep_interrupted(e, stem.with_suffix(".csv"), f"scene {scene.name} stopped during its search")
    csv = write_complete(res.table(), stem.with_suffix(".csv"))
    paths = chart(res, stem)
    print(f"scene {scene.name}: {res.scene.question}")
    print(f"  chosen fidelities: {res.chosen.fidelities}, step {res.chosen.step:g} s, master {res.chosen.master} "
          f"({configuration(res.chosen, res.full)})")
    print(f"  quantity: {res.chosen.value:.6g} {res.scene.unit} (full model {res.full.value:.6g}); "
          f"error {res.chosen.error:.3g}")
    print(f"  wall time: full {res.full.wall_time:.3f} s, chosen {res.chosen.wall_time:.3f} s, "
          f"speed-up {res.speedup:.2f}x " + ("(full model from the cache)" if res.cached_full
                                             else "(measured side by side in this run)"))
    stopped = [c for c in res.candidates if c.error is None]
    if stopped:
        print(f"  {len(stopped)} of {len(res.candidates)} candidates stopped early (their reasons: the note "
              f"column of {csv})")
    print(f"  chart: {paths[0]}")
    return 0
