"""Limits a design must meet: ``run DRIVE --limits FILE.yaml`` and ``compare DRIVE ... --limits FILE.yaml``.

A limits file is a YAML (or JSON) mapping from a quantity's name, as the run prints it, to a condition in the
``--target`` syntax of ``size``: ``"<= VALUE"`` or ``">= VALUE"`` in the quantity's own unit::

    speed_fluctuation: "<= 5"            # %
    motor_torque_rms_to_rated: "<= 1"
    stopping_angle: "<= 60"              # deg, in a run with --scenario estop
    belt_slip_margin: ">= 1.5"

Each limit is judged on the run's quantities: a scenario's transient quantities first (a stop's
``shaft_torque_peak`` is the stop's), then the steady ones.  The verdict is ``pass``, ``FAIL`` (the value
breaks the limit) or ``FAIL`` with ``no value`` (the run gives none, e.g. no steady cycle: a limit that cannot
be shown met is not met); a list-valued quantity (angles, impact forces) is judged element by element.  The
verdicts are printed as a table, written beside the result (``FILE.limits.json``), marked in the quantities'
table, their JSON and the HTML report; the command exits with status 3 after writing everything when any
limit fails (0 when all pass).

Refused in one line before any run: a file that is not a mapping, a condition that is not ``<= number`` or
``>= number``, and (in a plain run, whose quantity names are known beforehand) an unknown quantity, with the
nearest names.
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import asdict, dataclass
from pathlib import Path

from harness.errors import SystemDescriptionError

FAILED = 3     # the exit status of a run or comparison whose quantities break a limit

_CONDITION = re.compile(r"\s*(<=|>=)\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*")


@dataclass(frozen=True)
class Limit:
    """``quantity op value``: op ``<=`` or ``>=``."""
    quantity: str
    op: str
    value: float

    def met(self, q: float) -> bool:
        return q <= self.value if self.op == "<=" else q >= self.value

    def __str__(self) -> str:
        return f"{self.quantity} {self.op} {self.value:g}"


@dataclass(frozen=True)
class Verdict:
    """One limit judged: ``value`` the run's (None: none), ``passed``, ``where`` the table it came from
    (``steady``, the scenario's name, or a variant's label), ``note`` why there is no value."""
    quantity: str
    op: str
    limit: float
    value: float | list | None
    unit: str
    passed: bool
    where: str = ""
    note: str = ""

    @property
    def word(self) -> str:
        return "pass" if self.passed else "FAIL"


def parse_condition(quantity: str, text, origin: str) -> Limit:
    """``"<= 5"`` for ``quantity`` -> a :class:`Limit`; ``origin`` names the file in the error."""
    m = _CONDITION.fullmatch(str(text))
    if isinstance(text, bool) or not m:
        raise SystemDescriptionError(f"{origin}: {quantity}: {text!r} is not a limit: write \"<= VALUE\" or "
                                     f"\">= VALUE\" (the --target syntax of size), the value in the quantity's unit")
    value = float(m.group(2))
    if not math.isfinite(value):
        raise SystemDescriptionError(f"{origin}: {quantity}: the limit {m.group(2)} is not a finite number")
    return Limit(quantity, m.group(1), value)


def read(path: str | Path) -> list[Limit]:
    """The limits of a YAML or JSON file (module docstring), refused in one line naming the file."""
    from harness.specs import load_file

    path = Path(path)
    data = load_file(path, "limits file")
    if not isinstance(data, dict) or not data:
        raise SystemDescriptionError(f"limits file {path}: a mapping 'quantity: \"<= VALUE\"' is needed, not "
                                     f"{type(data).__name__ if data is not None else 'an empty file'}")
    out = []
    for name, condition in data.items():
        if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z_]\w*", name):
            raise SystemDescriptionError(f"limits file {path}: {name!r} is not a quantity name")
        out.append(parse_condition(name, condition, f"limits file {path}"))
    return out


def check_names(limits: list[Limit], names: list[str], origin: str, what: str) -> None:
    """Every limit names one of ``names`` (the quantities ``what`` gives), else one line with the nearest."""
    import difflib

    for lim in limits:
        if lim.quantity not in names:
            close = difflib.get_close_matches(lim.quantity, names, n=3)
            hint = f"nearest: {', '.join(close)}" if close else f"its quantities: {', '.join(names)}"
            raise SystemDescriptionError(f"{origin}: {lim.quantity}: {what} has no such quantity ({hint})")


def judge(limits: list[Limit], tables: list[tuple[str, object]]) -> list[Verdict]:
    """Each limit against the first of ``tables`` (``(where, Quantities)``, in order of precedence) that has its
    quantity; a quantity in none of them fails with a note."""
    out = []
    for lim in limits:
        found = next(((w, q.row(lim.quantity)) for w, q in tables if q is not None and lim.quantity in q), None)
        if found is None:
            out.append(Verdict(lim.quantity, lim.op, lim.value, None, "", False, "",
                               "the run has no such quantity"))
            continue
        where, row = found
        value = row.value
        if value is None:
            out.append(Verdict(lim.quantity, lim.op, lim.value, None, row.unit, False, where,
                               row.note or "no value"))
            continue
        values = list(value) if isinstance(value, (list, tuple)) else [value]
        ok = bool(values) and all(lim.met(float(v)) for v in values)
        out.append(Verdict(lim.quantity, lim.op, lim.value, value, row.unit, ok, where))
    return out


def table(verdicts: list[Verdict], heading: str) -> str:
    """The verdicts as a text table under ``heading``, with the count of failures."""
    from harness.reporting.quantities import _format

    rows = [(v.quantity, _format(v.value) if v.value is not None else "-", v.unit or "-", f"{v.op} {v.limit:g}",
             v.word, v.where + (f" [{v.note}]" if v.note else "")) for v in verdicts]
    head = ("quantity", "value", "unit", "limit", "verdict", "from")
    w = [max(len(r[i]) for r in rows + [head]) for i in range(5)]
    failed = sum(not v.passed for v in verdicts)
    lines = [f"{heading}: {len(verdicts) - failed} of {len(verdicts)} limits met"
             + (f", {failed} FAILED" if failed else "")]
    lines.append("  " + "  ".join(h.ljust(w[i]) if i != 1 else h.rjust(w[i]) for i, h in enumerate(head[:5]))
                 + "  " + head[5])
    lines.append("  " + "-" * (sum(w) + 10 + len(head[5])))
    for r in rows:
        lines.append("  " + "  ".join(x.ljust(w[i]) if i != 1 else x.rjust(w[i]) for i, x in enumerate(r[:5]))
                     + "  " + r[5])
    return "\n".join(lines)


def to_dict(verdicts: list[Verdict], source: str) -> dict:
    return {"limits_file": source, "all_passed": all(v.passed for v in verdicts),
            "failed": [v.quantity for v in verdicts if not v.passed],
            "verdicts": [{**asdict(v), "verdict": v.word} for v in verdicts]}


def write_json(verdicts: list[Verdict], source: str, path: str | Path) -> Path:
    path = Path(path)
    path.write_text(json.dumps(to_dict(verdicts, source), indent=1, allow_nan=False) + "\n")
    return path


def json_path(out: str | Path) -> Path:
    """Where ``--limits`` writes its verdicts beside a result ``x.csv``: ``x.limits.json``."""
    out = Path(out)
    return out.with_name(f"{out.stem}.limits.json")


def mark(table_, verdicts: list[Verdict], where: str) -> None:
    """Attach the verdicts judged on ``table_`` (a Quantities, from ``where``) to it, for its table, JSON and the
    report."""
    if table_ is not None:
        table_.verdicts = {v.quantity: v for v in verdicts if v.where == where}


__all__ = ["Limit", "Verdict", "FAILED", "read", "parse_condition", "check_names", "judge", "table", "to_dict",
           "write_json", "json_path", "mark"]
