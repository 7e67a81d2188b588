"""One HTML page to hand on: a run's (or a study's) answer in one self-contained file.

``run ... --report FILE.html`` (and ``compare``, ``size``, ``sweep``) writes one file a colleague opens in any
browser, offline: the charts are inline PNG images (base64 ``data:`` URIs), the styles inline, no script and
nothing fetched from the network.  A run's page holds

* the engineering quantities with their units (:mod:`harness.reporting.quantities`), the start-up rule in the heading;
* the charts (over time and over one machine cycle, :mod:`harness.reporting.charts`);
* the drive: every instance with its FMU and fidelity, every parameter of every instance with its value, unit
  and who set it (the run, the drive or the FMU's default), and every parameter whose value differs from its FMU's
  declared default (set by the drive, or by the run), with the default beside it;
* the method: master, extrapolation, step, step control, tolerance, stop time, steps, and whether it is the
  drive's declared method; the drive's declared accuracy (:class:`harness.specs.AccuracySpec`), the
  requirements the method was chosen to meet;
* the versions (toolkit, FMPy, Python, platform) and the run time.

The studies build their pages from the same parts (:class:`Page`; ``compare``, ``size`` and ``sweep`` add
their tables and charts).  Python: :func:`harness.report` (a run's result, or a comparison or sizing).
"""
from __future__ import annotations

import base64
import html
import math
import os
import platform
import sys
import time
from pathlib import Path

_STYLE = """
body{font-family:system-ui,-apple-system,"Segoe UI",sans-serif;margin:1.5em auto;max-width:1200px;color:#222;
padding:0 1em;line-height:1.35}
h1{font-size:1.5em;margin-bottom:.2em}h2{font-size:1.15em;margin-top:1.6em;border-bottom:1px solid #ccc}
.sub{color:#555;margin-top:0}table{border-collapse:collapse;margin:.5em 0;font-size:.85em}
th,td{border:1px solid #ccc;padding:.2em .5em;vertical-align:top}th{background:#f0f0f0;text-align:left}
td.n{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
img{max-width:100%;height:auto;border:1px solid #ddd;margin:.4em 0}
figure{margin:.5em 0}figcaption{font-size:.85em;color:#555}pre{background:#f7f7f7;padding:.5em;
font-size:.85em;white-space:pre-wrap}.note{color:#555;font-size:.85em}.wide{overflow-x:auto}
"""


def esc(x) -> str:
    return html.escape(str(x), quote=True)


def number(v) -> str:
    """A value as a person reads it: 4 significant digits, lists joined, None as '-'."""
    if v is None:
        return "-"
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, (list, tuple)):
        return ", ".join(number(x) for x in v) if v else "none"
    if isinstance(v, (int, float)) or hasattr(v, "item"):
        v = float(v)
        if not math.isfinite(v):
            return "-" if math.isnan(v) else str(v)
        return f"{v:.4g}"
    return str(v)


def table(header: list[str], rows: list[list], numeric: set[int] | None = None, caption: str = "") -> str:
    """An HTML table; cells of the ``numeric`` columns (indices; default: every cell that is a number) are
    formatted by :func:`number` and right-aligned."""
    out = ['<div class="wide"><table>']
    if caption:
        out.append(f"<caption>{esc(caption)}</caption>")
    out.append("<tr>" + "".join(f"<th>{esc(h)}</th>" for h in header) + "</tr>")
    for row in rows:
        cells = []
        for i, c in enumerate(row):
            is_num = (i in numeric) if numeric is not None else (
                isinstance(c, (int, float, list, tuple)) and not isinstance(c, bool) or c is None)
            cells.append(f'<td class="n">{esc(number(c))}</td>' if is_num else f"<td>{esc(c)}</td>")
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</table></div>")
    return "\n".join(out)


def frame_table(frame, index_name: str | None = None) -> str:
    """A pandas DataFrame as an HTML table (index as the first column)."""
    header = [index_name or frame.index.name or ""] + [str(c) for c in frame.columns]
    rows = [[idx, *row] for idx, row in zip(frame.index, frame.itertuples(index=False))]
    return table(header, [[_cell(c) for c in r] for r in rows])


def _cell(c):
    if hasattr(c, "item") and not isinstance(c, (list, tuple)):
        try:
            return c.item()
        except (ValueError, AttributeError):
            return c
    return c


def image(png: str | Path, caption: str = "") -> str:
    """A PNG file inline (base64), with a caption."""
    data = base64.b64encode(Path(png).read_bytes()).decode("ascii")
    alt = caption or Path(png).stem
    return (f'<figure><img alt="{esc(alt)}" src="data:image/png;base64,{data}">'
            + (f"<figcaption>{esc(caption)}</figcaption>" if caption else "") + "</figure>")


def para(text: str, cls: str = "") -> str:
    return f'<p{f" class={chr(34)}{cls}{chr(34)}" if cls else ""}>{esc(text)}</p>'


class Page:
    """An HTML page built from sections (:meth:`section`), written whole (:meth:`write`)."""

    def __init__(self, title: str, subtitle: str = ""):
        self.title, self.subtitle = title, subtitle
        self.parts: list[str] = []

    def section(self, heading: str, *parts: str) -> "Page":
        self.parts.append(f"<section><h2>{esc(heading)}</h2>\n" + "\n".join(p for p in parts if p) + "</section>")
        return self

    def html(self) -> str:
        sub = f'<p class="sub">{esc(self.subtitle)}</p>' if self.subtitle else ""
        return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
                f"<title>{esc(self.title)}</title><style>{_STYLE}</style></head>\n<body>\n"
                f"<h1>{esc(self.title)}</h1>{sub}\n" + "\n".join(self.parts) + "\n</body></html>\n")

    def write(self, path: str | Path) -> Path:
        """Write the page at ``path``, whole or not at all (written beside it, then renamed)."""
        path = Path(path)
        tmp = path.with_name(f".{path.name}.tmp")
        tmp.write_text(self.html(), encoding="utf-8")
        os.replace(tmp, path)
        return path


# -- the parts every page shares ---------------------------------------------------------------------------------
def versions() -> list[tuple[str, str]]:
    """(what, version) of the toolkit, FMPy, Python and the platform."""
    from importlib import metadata

    out = []
    for name, dist in (("pressdrive (this toolkit)", "pressdrive"), ("FMPy", "fmpy")):
        try:
            out.append((name, metadata.version(dist)))
        except metadata.PackageNotFoundError:
            out.append((name, "(not installed)"))
    out.append(("Python", sys.version.split()[0]))
    out.append(("platform", platform.platform()))
    return out


def versions_section(page: Page, run_time: list[tuple[str, float | str]]) -> None:
    """Versions and run times ((what, seconds or text) rows) as one section."""
    rows = [[what, v] for what, v in versions()]
    rows += [[what, f"{v:.3g} s" if isinstance(v, (int, float)) else v] for what, v in run_time]
    rows.append(["written", time.strftime("%Y-%m-%d %H:%M:%S %Z")])
    page.section("Versions and run time", table(["what", "version or time"], rows, numeric=set()))


def quantities_section(page: Page, q, heading: str = "Engineering quantities") -> None:
    """The engineering quantities (a :class:`harness.reporting.quantities.Quantities`): value, unit, over, meaning."""
    if q is None or not q.rows:
        page.section(heading, para("the drive declares no engineering quantities"))
        return
    judged = getattr(q, "verdicts", {}) or {}
    rows = [[r.name, r.value, r.unit or "-", r.over, r.what + (f" [{r.note}]" if r.note else "")]
            + ([f"{judged[r.name].word} ({judged[r.name].op} {judged[r.name].limit:g})" if r.name in judged else ""]
               if judged else []) for r in q.rows]
    page.section(heading, f"<pre>{esc(q.heading())}</pre>",
                 table(["quantity", "value", "unit", "over", "meaning"] + (["limit"] if judged else []), rows,
                       numeric={1}))


def limits_section(page: Page, verdicts, source: str = "") -> None:
    """The verdicts of ``--limits`` (:mod:`harness.reporting.limits`): quantity, value, limit, pass or FAIL."""
    failed = sum(not v.passed for v in verdicts)
    rows = [[v.quantity, v.value, v.unit or "-", f"{v.op} {v.limit:g}", v.word,
             v.where + (f" [{v.note}]" if v.note else "")] for v in verdicts]
    page.section("Limits", para(f"{len(verdicts) - failed} of {len(verdicts)} limits met"
                                + (f", {failed} FAILED" if failed else "") + (f" ({source})" if source else "")),
                 table(["quantity", "value", "unit", "limit", "verdict", "from"], rows, numeric={1}))


def _fmu_variables(system) -> dict:
    from harness.model import model_description, resolve_fmu

    out = {}
    for inst in system.instances:
        md = model_description(resolve_fmu(inst.fmu))
        out[inst.name] = (md.modelName, {v.name: v for v in md.modelVariables})
    return out


def _start(v):
    if v is None or v.start is None:
        return None
    try:
        return float(v.start) if v.type in ("Real", "Float64", "Float32") else int(v.start) if v.type in (
            "Integer", "Int32", "Int64", "Enumeration") else v.start
    except (TypeError, ValueError):
        return v.start


def changed_parameters(system, start_values: dict | None = None) -> list[list]:
    """Every parameter whose value differs from its FMU's declared default: [instance, parameter, value, default,
    unit, set by] (``"drive"``: the system's declaration, ``"run"``: the run's start values)."""
    fmus = _fmu_variables(system)
    run = dict(start_values or {})
    rows = []
    for inst in system.instances:
        _model, variables = fmus[inst.name]
        names = list(inst.parameters) + [k.split(".", 1)[1] for k in run if k.split(".", 1)[0] == inst.name
                                          and k.split(".", 1)[1] not in inst.parameters]
        for name in names:
            key = f"{inst.name}.{name}"
            by, value = ("run", run[key]) if key in run else ("drive", inst.parameters[name])
            v = variables.get(name)
            default = _start(v)
            if default is not None and _same(value, default):
                continue
            unit = (getattr(v, "unit", None) or getattr(getattr(v, "declaredType", None), "unit", None) or "") if v else ""
            rows.append([inst.name, name, value, default, unit or "-", by])
    return rows


def all_parameters(system, start_values: dict | None = None) -> list[list]:
    """Every parameter of every instance, defaults too: [instance, parameter, value, unit, set by (``"run"``,
    ``"drive"`` or ``"FMU default"``), what it is (the FMU's description)]."""
    fmus = _fmu_variables(system)
    run = dict(start_values or {})
    rows = []
    for inst in system.instances:
        _model, variables = fmus[inst.name]
        for name, v in variables.items():
            if v.causality != "parameter":
                continue
            key = f"{inst.name}.{name}"
            if key in run:
                by, value = "run", run[key]
            elif name in inst.parameters:
                by, value = "drive", inst.parameters[name]
            else:
                by, value = "FMU default", _start(v)
            unit = getattr(v, "unit", None) or getattr(getattr(v, "declaredType", None), "unit", None) or "-"
            rows.append([inst.name, name, value, unit, by, v.description or ""])
    return rows


def _same(a, b) -> bool:
    try:
        return math.isclose(float(a), float(b), rel_tol=1e-12, abs_tol=0.0)
    except (TypeError, ValueError):
        return str(a) == str(b)


def drive_section(page: Page, system, start_values: dict | None = None, heading: str = "The drive") -> None:
    """Instances (FMU, fidelity) and every parameter changed from its FMU's default."""
    fmus = _fmu_variables(system)
    inst_rows = []
    for inst in system.instances:
        model, variables = fmus[inst.name]
        fid = inst.parameters.get("fidelity", _start(variables.get("fidelity")) if "fidelity" in variables else "-")
        key = f"{inst.name}.fidelity"
        if start_values and key in start_values:
            fid = f"{start_values[key]} (run; drive: {fid})"
        inst_rows.append([inst.name, model, fid])
    changed = changed_parameters(system, start_values)
    every = all_parameters(system, start_values)
    bonds = ", ".join(b.label for b in system.bonds)
    page.section(heading, para(system.description.splitlines()[0] if system.description else system.name),
                 table(["instance", "FMU", "fidelity"], inst_rows, numeric=set()),
                 para(f"power bonds (motion out -> motion in): {bonds}", "note") if bonds else "",
                 f"<h3>Parameters changed from the FMUs' defaults ({len(changed)})</h3>",
                 table(["instance", "parameter", "value", "FMU default", "unit", "set by"], changed, numeric={2, 3})
                 if changed else para("none: every parameter at its FMU's default"),
                 f"<h3>Every parameter of every instance ({len(every)})</h3>",
                 table(["instance", "parameter", "value", "unit", "set by", "what it is"], every, numeric={2}))


def method_section(page: Page, system, attrs: dict) -> None:
    """The master, step and the rest of the method the run used, against the drive's declared method, and the
    drive's declared accuracy."""
    a = attrs
    exp = system.experiment
    rows = [["master", a.get("master"), exp.master if exp else "-"],
            ["extrapolation order", a.get("extrapolation"), exp.extrapolation if exp else "-"],
            ["communication step [s]", a.get("step"), exp.step if exp else "-"],
            ["step control", a.get("step_control") or "none", (exp.step_control or "none") if exp else "-"],
            ["tolerance", a.get("tolerance"), exp.tolerance if exp else "-"],
            ["start time [s]", a.get("start_time"), exp.start_time if exp else "-"],
            ["stop time [s]", a.get("stop_time"), exp.stop_time if exp else "-"],
            ["output interval [s]", a.get("output_interval"), "-"]]
    same = exp is not None and all(_same(r[1], r[2]) or (r[1] is None and r[2] is None) for r in rows[:5])
    said = ("the drive's declared method" if same else "differs from the drive's declared method (right column)")
    counts = (f"{a.get('steps', '?')} communication steps, {a.get('fmu_steps', '?')} FMU steps, "
              f"complete: {'yes' if a.get('complete', True) else 'NO: ' + str(a.get('error', ''))}")
    parts = [para(f"The run's method: {said}; {counts}."),
             table(["", "this run", "drive's declaration"], [[r[0], _plain(r[1]), _plain(r[2])] for r in rows],
                   numeric={1, 2})]
    acc = getattr(system, "accuracy", None)
    if acc is not None:
        zones = {z.where: z.label for z in (system.chart.zones if getattr(system, "chart", None) else ())}
        req = [[r.name, r.tolerance, ("relative" if r.relative else r.unit),
                zones.get(r.where, "where its condition holds") if r.where else "everywhere"]
               for r in acc.requirements]
        parts += [f"<h3>The drive's declared accuracy</h3>",
                  para(f"The requirements its declared method meets against the monolithic reference over "
                       f"{acc.stop_time:g} s (checked by `python -m harness study accuracy {system.name}`):"),
                  table(["requirement", "tolerance", "unit", "where"], req, numeric={1})]
    else:
        parts.append(para("the drive declares no accuracy requirements", "note"))
    page.section("Method", *parts)


def _plain(v):
    return "-" if v is None else v


def run_page(system, df, charts: list[Path] | None = None, title: str | None = None) -> Page:
    """The page of one run: quantities, charts, drive, method, versions (module docstring)."""
    a = df.attrs
    t_end = float(df.index[-1]) if len(df) else 0.0
    status = "" if a.get("complete", True) else f" (INCOMPLETE: {a.get('error', '')})"
    page = Page(title or f"{system.name}: run report",
                f"{len(df)} points to t = {t_end:.6g} s, master {a.get('master')}, step {a.get('step', 0):g} s"
                f"{status}")
    if a.get("limits"):
        limits_section(page, a["limits"])
    quantities_section(page, a.get("quantities"))
    if a.get("transient") is not None:
        quantities_section(page, a["transient"], heading=f"Transient quantities ({a.get('scenario')})")
    charts = list(charts or [])
    page.section("Charts", *[image(p, _caption(p, system.name)) for p in charts] if charts else
                 [para("no chart: the run recorded no points")])
    drive_section(page, system, a.get("start_values"))
    method_section(page, system, a)
    versions_section(page, [("stepping (initialisation and steps)", a.get("wall_time", math.nan)),
                            ("of which initialisation", a.get("init_time", math.nan))])
    return page


def _caption(p: Path, name: str) -> str:
    stem = Path(p).stem.replace(".partial", "")
    if stem.endswith("_cycle"):
        return f"{name} over its last complete machine cycle against the crank angle"
    return f"{name} over time"


def render_charts(draw, folder: str | Path | None) -> tuple[list[Path], object]:
    """The PNG charts ``draw(folder)`` writes, in ``folder`` or (None) a temporary folder kept alive by the
    second value returned (drop it after the page is written)."""
    import tempfile

    if folder is not None:
        return [p for p in draw(Path(folder)) if Path(p).suffix == ".png"], None
    tmp = tempfile.TemporaryDirectory(prefix="pressdrive-report-")
    return [p for p in draw(Path(tmp.name)) if Path(p).suffix == ".png"], tmp


def write_run_report(system, df, path: str | Path, charts: list[Path] | None = None) -> Path:
    """Write the page of one run at ``path``; ``charts``: PNGs already drawn (None: drawn here, into a
    temporary folder)."""
    keep = None
    if charts is None and len(df):
        from harness.reporting.charts import plot_result

        charts, keep = render_charts(lambda d: plot_result(system, df, d), None)
    try:
        return run_page(system, df, charts).write(path)
    finally:
        if keep is not None:
            keep.cleanup()


def check_report_path(path: str | Path) -> Path:
    """``--report FILE.html`` before any run: an .html/.htm name in a folder that can be written."""
    from harness.errors import SystemDescriptionError
    from harness.results import check_writable

    path = Path(path)
    if path.suffix.lower() not in (".html", ".htm"):
        raise SystemDescriptionError(f"--report {path}: give a file name ending in .html")
    return check_writable(path, "--report")


__all__ = ["Page", "run_page", "write_run_report", "check_report_path", "table", "frame_table", "image", "para",
           "quantities_section", "limits_section", "drive_section", "all_parameters", "method_section", "versions_section", "render_charts"]
