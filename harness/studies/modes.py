"""The torsional natural frequencies and mode shapes of a drive: ``python -m harness modes DRIVE`` and
``harness.modes(system)``.

The drive is linearised about its operating point: the monolithic reference (:mod:`harness.studies.reference`)
assembles the whole drive as one ODE x' = f(x) from the same physics functions its FMUs use; its Jacobian
A = df/dx is taken by central differences (step 1e-6 of each state's magnitude, at least 1e-6) at the drive's
initial state, which for the shipped drives is their running speed (``--points N``: also at N states spread
over one machine cycle of a monolithic run, where a linkage's reduced inertia moves the modes with the crank
angle).  Each complex pair of eigenvalues lambda of A is a mode: its natural frequency f_n = |lambda| / (2 pi)
[Hz] (undamped), damping ratio zeta = -Re(lambda) / |lambda| and damped frequency Im(lambda) / (2 pi).  A motor
at fidelity 0 (an ideal speed source) and a held brake are fixed ends; rigid links move with the parts they
join; real eigenvalues (the motor's slip, a free rotation) are no modes.

Mode shape: the eigenvector's speed states (unit rad/s or m/s, named ``instance.state``), each relative to the
largest of its unit in the mode (1: the part that swings most; a belt's or gear's ratio scales its sides), with
its sense (+: in phase with that part, -: against it); the states listed move by at least 5 %.

Campbell view: a mode is excited where an order k of the main shaft's speed (k per revolution of the machine
cycle) meets it, at n_k = n f_n / (k f_1) [rpm] (f_1 the machine cycles per second at the operating speed n);
the orders k = 1..12 whose n_k lies within +-20 % of n are listed as exciting it (a cycle's load has its
content in the low orders), and every mode's distance from the nearest whole order at the operating speed
(seed 003's rule: f_n / N_B away from a whole number, the "order" column); ``--plot DIR`` draws the diagram
(DIR/<drive>_campbell.png).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

RPM = 2 * math.pi / 60
NEAR = 0.2          # the speed band around the operating speed in which an order's resonance counts as exciting
MOVES = 0.05        # a part moves in a mode when its relative amplitude is at least this
ORDERS = 12         # the orders of the main shaft's speed taken as exciting: 1 to this


@dataclass(frozen=True)
class Mode:
    frequency: float                  # Hz, undamped natural frequency |lambda| / 2 pi
    damping: float                    # damping ratio -Re(lambda) / |lambda|
    damped: float                     # Hz, Im(lambda) / 2 pi
    shape: dict = field(default_factory=dict)   # instance -> signed relative amplitude of its speed states
    order: float = math.nan           # f_n / (main-shaft cycles per second): the order it sits at
    exciting: tuple = ()              # (order k, resonance speed [rpm]) within +-NEAR of the operating speed
    spread: tuple = ()                # (min, max) Hz over the cycle's points (--points), else ()


@dataclass
class Modes:
    """The modes of ``system`` at the operating speed ``speed`` [rpm of the main shaft, per machine cycle]."""
    system: str
    speed: float
    modes: list
    states: int
    points: int = 1

    def table(self) -> str:
        head = (f"{self.system}: {len(self.modes)} torsional modes, linearised at {self.speed:.4g} rpm of the main "
                f"shaft ({self.states} states; " + (f"{self.points} points over a machine cycle)" if self.points > 1
                                                     else "the drive's initial state)"))
        lines = [head, f"  {'f_n [Hz]':>9}  {'zeta':>6}  {'order':>7}  {'off':>5}  {'exciting (k: rpm)':<20}  what "
                       f"moves (speed amplitude, sense)"]
        for m in self.modes:
            excite = ", ".join(f"{k}: {n:.4g}" for k, n in m.exciting) or "none"
            parts = ", ".join(f"{name} {a:+.2f}" for name, a in m.shape.items())
            spread = f"; {m.spread[0]:.4g}-{m.spread[1]:.4g} Hz over the cycle" if m.spread else ""
            off = abs(m.order - round(m.order)) if math.isfinite(m.order) else math.nan
            lines.append(f"  {m.frequency:>9.4g}  {m.damping:>6.3f}  {m.order:>7.4g}  {off:>5.2f}  {excite:<20}  "
                         f"{parts}{spread}")
        lines.append(f"  order: f_n over the main shaft's cycles per second at {self.speed:.4g} rpm; off: its distance "
                     f"from the nearest whole order; exciting: the orders 1-{ORDERS} that meet the mode within "
                     f"+-{100 * NEAR:g} % of that speed, at the speed given")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"system": self.system, "speed_rpm": self.speed, "states": self.states, "points": self.points,
                "modes": [{"frequency_hz": m.frequency, "damping_ratio": m.damping, "damped_hz": m.damped,
                           "order": m.order, "shape": m.shape, "exciting_orders": [list(e) for e in m.exciting],
                           "spread_hz": list(m.spread)} for m in self.modes]}

    def plot(self, folder: str | Path, stem: str | None = None, orders: int = 12) -> list[Path]:
        """The Campbell diagram: each mode's frequency against the main shaft's speed, the orders k = 1..``orders``
        as lines f = k n / 60, the operating speed marked; DIR/<stem>.png (and .svg)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from harness.reporting.chartdraw import save_figure

        n = np.linspace(0.0, 1.5 * self.speed, 200)
        fig, ax = plt.subplots(figsize=(8, 5))
        top = max([m.frequency for m in self.modes] + [orders * self.speed / 60]) * 1.1
        for k in range(1, orders + 1):
            ax.plot(n, k * n / 60, color="0.75", lw=0.8)
            ax.annotate(f"{k}", (n[-1], k * n[-1] / 60), fontsize=7, color="0.5")
        for m in self.modes:
            ax.axhline(m.frequency, color="C0", lw=1.2)
            ax.annotate(f"{m.frequency:.4g} Hz", (n[0], m.frequency), fontsize=8, va="bottom", color="C0")
            for k, nk in m.exciting:
                ax.plot(nk, m.frequency, "o", color="C3", ms=5)
        ax.axvline(self.speed, color="k", ls="--", lw=0.9, label=f"operating speed {self.speed:.4g} rpm")
        ax.axvspan((1 - NEAR) * self.speed, (1 + NEAR) * self.speed, color="C1", alpha=0.1,
                   label=f"+-{100 * NEAR:g} %: exciting orders (red)")
        ax.set_xlim(0, n[-1])
        low = min([m.frequency for m in self.modes] or [1.0])
        if top / low > 20:          # modes decades apart: a log scale shows each against the orders
            ax.set_yscale("log")
            ax.set_ylim(low / 2, top)
        else:
            ax.set_ylim(0, top)
        ax.set_xlabel("main-shaft speed [rpm]")
        ax.set_ylabel("frequency [Hz]")
        ax.set_title(f"{self.system}: Campbell diagram (modes against the main shaft's orders 1-{orders})")
        ax.legend(loc="upper left", fontsize=8)
        fig.tight_layout()
        return [p for p in save_figure(fig, Path(folder) / (stem or f"{self.system}_campbell")) if p.suffix == ".png"]


def jacobian(f, x: np.ndarray, rel: float = 1e-6) -> np.ndarray:
    """df/dx by central differences, the step ``rel`` of each state's magnitude (at least ``rel``)."""
    n = x.size
    a = np.empty((n, n))
    for j in range(n):
        h = rel * max(1.0, abs(float(x[j])))
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        a[:, j] = (f(xp) - f(xm)) / (2 * h)
    return a


def _speed_states(mono) -> list[tuple[int, str, str]]:
    """(state index, ``instance.state``, unit) of every speed state (rad/s or m/s) of the assembled drive."""
    out = []
    for name, model, sl in zip(mono.names, mono.models, mono.slices):
        for k, st in enumerate(type(model).states):
            if st.unit in ("rad/s", "m/s"):
                out.append((sl.start + k, f"{name}.{st.name}", st.unit))
    return out


def _pairs(a: np.ndarray, cutoff: float = 1e-3):
    """(eigenvalue with Im > 0, eigenvector) of ``a``, by natural frequency."""
    values, vectors = np.linalg.eig(a)
    keep = [k for k in range(values.size) if values[k].imag > cutoff * max(1.0, abs(values[k]))]
    keep.sort(key=lambda k: abs(values[k]))
    return [(values[k], vectors[:, k]) for k in keep]


def _shape(vector: np.ndarray, speeds) -> dict:
    by_unit: dict[str, dict[str, complex]] = {}
    for i, inst, unit in speeds:
        best = by_unit.setdefault(unit, {})
        if inst not in best or abs(vector[i]) > abs(best[inst]):
            best[inst] = vector[i]
    shape = {}
    for unit, parts in by_unit.items():
        ref = max(parts.values(), key=abs)
        if abs(ref) == 0:
            continue
        for inst, v in parts.items():
            r = v / ref
            if abs(r) >= MOVES:
                shape[inst] = float(math.copysign(abs(r), r.real))
    return dict(sorted(shape.items(), key=lambda kv: -abs(kv[1])))


def modes(system, parameters: dict | None = None, points: int = 0, span: float = NEAR,
          orders: int = ORDERS) -> Modes:
    """The drive's torsional modes (module docstring): ``system`` a System or a name in systems/,
    ``parameters`` (``Instance.parameter`` -> value) over its own, ``points``: also linearise at that many
    states over one machine cycle (the frequencies' spread); ``orders``: the highest order of the main shaft's
    speed taken as exciting (a cycle's load has its content in the low orders)."""
    from harness.run import load
    from harness.studies.reference import Monolithic

    system = load(system)
    mono = Monolithic(system, parameters)
    x0 = mono.initial_state()
    a = jacobian(lambda x: mono.rhs(0.0, x), x0)
    speeds = _speed_states(mono)
    cycle_hz, speed = _operating_speed(system, mono, x0)
    found = []
    for lam, vec in _pairs(a):
        f_n = abs(lam) / (2 * math.pi)
        order = f_n / cycle_hz if cycle_hz > 0 else math.nan
        # order k meets the mode at n_k = speed * order / k: within the band when order / k is in [1 - span, 1 + span]
        ks = range(max(1, math.ceil(order / (1 + span))), min(orders, math.floor(order / (1 - span))) + 1) \
            if cycle_hz > 0 else ()
        exciting = tuple((k, speed * order / k) for k in ks)
        found.append(Mode(f_n, -lam.real / abs(lam), lam.imag / (2 * math.pi), _shape(vec, speeds), order,
                          exciting))
    if points > 1:
        found = _spread(system, mono, found, points, cycle_hz)
    return Modes(system.name, speed, found, x0.size, max(1, points))


def _operating_speed(system, mono, x0) -> tuple[float, float]:
    """(machine cycles per second, main-shaft speed [rpm]) at the state x0, from the drive's declared main shaft."""
    spec = getattr(system, "quantities", None)
    if spec is None:
        return 0.0, 0.0
    inst, _, var = spec.shaft_speed.partition(".")
    _u, y = mono.signals(0.0, x0)
    i = mono.names.index(inst)
    w = float(y[i][mono.models[i].outputs.index(var)])
    return abs(w) / spec.cycle_angle, abs(w) / RPM * (2 * math.pi / spec.cycle_angle)


def _spread(system, mono, found: list, points: int, cycle_hz: float) -> list:
    """Each mode's frequency range over ``points`` states of one machine cycle (a monolithic run from the initial
    state, loose tolerances), matched by rank."""
    from dataclasses import replace

    from scipy.integrate import solve_ivp

    if not cycle_hz > 0:
        return found
    period = 1.0 / cycle_hz
    x0 = mono.initial_state()
    times = np.linspace(0.0, period, points, endpoint=False)
    sol = solve_ivp(lambda t, x: mono.rhs(t, x), (0.0, times[-1] or period), x0, method="Radau", rtol=1e-5,
                    atol=1e-7, t_eval=times, dense_output=False)
    freqs = []
    for k in range(sol.y.shape[1]):
        a = jacobian(lambda x, t=sol.t[k]: mono.rhs(t, x), sol.y[:, k])
        freqs.append([abs(lam) / (2 * math.pi) for lam, _ in _pairs(a)])
    out = []
    for r, m in enumerate(found):
        at = [f[r] for f in freqs if len(f) > r]
        out.append(replace(m, spread=(min(at), max(at))) if at else m)
    return out


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "modes", help="the drive's torsional natural frequencies, mode shapes and exciting orders",
        description="Linearise the drive (its monolithic reference, the FMUs' own equations) about its operating "
                    "point and print each torsional mode: natural frequency [Hz], damping ratio, the order of the "
                    "main shaft's speed it sits at, the orders that excite it within +-20 % of the operating "
                    "speed (a Campbell view), and the parts that move.")
    p.add_argument("system", help="system name in systems/ (e.g. spine_knife) or a .py file defining SYSTEM")
    p.add_argument("--set", action="append", default=[], metavar="Instance.param=VALUE",
                   help="a parameter value over the drive's (repeatable; default: the drive's values)")
    p.add_argument("--points", type=int, default=0, metavar="N",
                   help="also linearise at N states over one machine cycle and give each mode's spread "
                        "(default: 0, the initial state alone)")
    p.add_argument("--plot", type=Path, default=None, metavar="DIR",
                   help="draw the Campbell diagram: DIR/<drive>_campbell.png (default: none)")
    p.add_argument("--out", type=Path, default=None, metavar="FILE.json",
                   help="write the modes as JSON (default: printed only)")
    p.set_defaults(func=_cli)


def _cli(args) -> int:
    import json

    from harness.results import check_writable
    from harness.run.parameters import parse_sets

    if args.out is not None:
        check_writable(args.out, "--out")
    if args.plot is not None:
        check_writable(args.plot, "--plot", folder=True)
    if args.points < 0:
        from harness.errors import SystemDescriptionError

        raise SystemDescriptionError(f"--points {args.points}: give 0 or more")
    result = modes(args.system, parse_sets(args.set), points=args.points)
    print(result.table())
    if args.out is not None:
        args.out.write_text(json.dumps(result.to_dict(), indent=1) + "\n")
        print(f"wrote {args.out}")
    if args.plot is not None:
        print("chart " + ", ".join(map(str, result.plot(args.plot))))
    return 0


__all__ = ["Mode", "Modes", "modes", "jacobian"]
