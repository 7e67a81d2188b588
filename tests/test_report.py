"""The HTML report (harness.reporting.htmlreport; run, compare, size and sweep ``--report``): its content checked against
the run it reports, its self-containment, the refusals before any run, and the page opened in a real headless
browser (Debian's chromium) whose images must have loaded."""
from __future__ import annotations

import base64
import html
import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from harness.reporting import htmlreport as h
from harness.model import model_description, resolve_fmu
from harness.run import RunOptions, load, simulate

ROOT = Path(__file__).resolve().parents[1]
DRIVE = "trimmer_conveyor"
CHANGED = {"drive.J_flywheel": 0.07}          # a run's own value, beside the drive's declared ones
CHROMIUM = shutil.which("chromium") or ("/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None)


@pytest.fixture(scope="module")
def run():
    system = load(DRIVE)
    df = simulate(system, stop_time=0.6, start_values=dict(CHANGED), options=RunOptions(progress=None))
    assert df.attrs["complete"]
    return system, df


@pytest.fixture(scope="module")
def page(run, tmp_path_factory):
    system, df = run
    path = h.write_run_report(system, df, tmp_path_factory.mktemp("report") / "run.html")
    return path, path.read_text(encoding="utf-8")


def _cells(text: str) -> list[list[str]]:
    """Every table row's cells, unescaped."""
    return [[html.unescape(c) for c in re.findall(r"<t[dh][^>]*>(.*?)</t[dh]>", row)]
            for row in re.findall(r"<tr>(.*?)</tr>", text, flags=re.S)]


def test_the_page_holds_every_quantity_with_its_value_and_unit(run, page):
    _system, df = run
    q = df.attrs["quantities"]
    rows = {r[0]: r for r in _cells(page[1]) if len(r) == 5}
    assert q.rows
    for r in q.rows:
        assert r.name in rows, r.name
        assert rows[r.name][1] == h.number(r.value)
        assert rows[r.name][2] == (r.unit or "-")
    numeric = [r for r in q.rows if isinstance(r.value, float)]
    assert numeric and all(rows[r.name][1] != "-" for r in numeric)


def test_the_page_is_self_contained(page):
    path, text = page
    assert "<script" not in text.lower() and "<link" not in text.lower()
    assert not re.search(r"""(src|href)\s*=\s*["'](?!data:)""", text)    # nothing fetched: data URIs only
    images = re.findall(r'src="data:image/png;base64,([^"]+)"', text)
    assert len(images) == 2                                               # over time, over one machine cycle
    for b in images:
        assert base64.b64decode(b).startswith(b"\x89PNG\r\n\x1a\n")


def test_the_drive_lists_instances_and_every_parameter_changed_from_its_default(run, page):
    system, _df = run
    cells = _cells(page[1])
    instances = {r[0]: r for r in cells if len(r) == 3 and r[0] in {i.name for i in system.instances}}
    assert set(instances) == {i.name for i in system.instances}
    changed = {(r[0], r[1]): r for r in cells if len(r) == 6 and r[5] in ("drive", "run")}
    # independently: every declared or run value that differs from the FMU's start, and nothing else
    expected = {}
    for inst in system.instances:
        starts = {v.name: v.start for v in model_description(resolve_fmu(inst.fmu)).modelVariables}
        values = {**inst.parameters, **{k.split(".", 1)[1]: v for k, v in CHANGED.items()
                                        if k.split(".", 1)[0] == inst.name}}
        for name, value in values.items():
            # a start written with fewer digits than the drive's value (w_rated = 1425 rpm) is no change
            if not math.isclose(float(value), float(starts[name]), rel_tol=1e-12):
                expected[(inst.name, name)] = "run" if f"{inst.name}.{name}" in CHANGED else "drive"
    assert {k: r[5] for k, r in changed.items()} == expected
    assert changed[("drive", "J_flywheel")][2] == h.number(CHANGED["drive.J_flywheel"])


def test_a_value_equal_to_its_default_is_not_listed(run):
    system, _df = run
    inst = system.instances[0]
    name, value = next((v.name, v.start) for v in model_description(resolve_fmu(inst.fmu)).modelVariables
                       if v.causality == "parameter" and v.name not in inst.parameters and v.type == "Real")
    listed = h.changed_parameters(system, {f"{inst.name}.{name}": float(value)})
    assert (inst.name, name) not in {(r[0], r[1]) for r in listed}
    listed = h.changed_parameters(system, {f"{inst.name}.{name}": float(value) * 2 + 1})
    assert (inst.name, name) in {(r[0], r[1]) for r in listed}


def test_the_method_accuracy_and_versions(run, page):
    import fmpy

    system, df = run
    text = html.unescape(page[1])
    cells = {r[0]: r for r in _cells(page[1]) if len(r) == 3}
    assert cells["master"][1] == df.attrs["master"]
    assert cells["communication step [s]"][1] == h.number(df.attrs["step"])
    assert "the drive's declared method" in text
    for req in system.accuracy.requirements:
        assert req.name in text
    assert fmpy.__version__ in text and sys.version.split()[0] in text
    assert f"{df.attrs['wall_time']:.3g} s" in text


def test_report_paths_refused_before_any_run(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    for bad, why in ((tmp_path / "x.txt", "ending in .html"), (blocker / "x.html", "is a file, not a folder")):
        p = subprocess.run([sys.executable, "-m", "harness", "run", DRIVE, "--report", str(bad)], cwd=ROOT,
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 1
        assert p.stderr.strip().count("\n") == 0 and why in p.stderr, p.stderr
        assert "points to t" not in p.stdout                             # nothing was run


def test_compare_and_size_pages(run, tmp_path):
    from harness.studies.compare import Comparison
    from harness.studies.size import Sizing, parse_target

    system, df = run
    other = simulate(system, stop_time=0.6, start_values={"drive.J_flywheel": 0.2}, options=RunOptions(progress=None))
    df.attrs["variant"], other.attrs["variant"] = "base", "drive.J_flywheel = 0.2"
    comparison = Comparison(system, {"light": df, "heavy": other})
    text = comparison.report(tmp_path / "c.html").read_text()
    frame = comparison.frame()
    head = next(r for r in _cells(text) if r and r[0] == "quantity" and "heavy change %" in r)
    assert head[1:] == [str(c) for c in frame.columns]
    row = next(r for r in _cells(text) if r and r[0] == "motor_torque_rms")
    assert row[-1] == h.number(frame.loc["motor_torque_rms", "heavy change %"])
    assert len(re.findall(r'src="data:image/png;base64,', text)) == 1        # the overlaid cycle chart

    q = df.attrs["quantities"]["motor_torque_rms"]
    target = parse_target(f"motor_torque_rms <= {q * 1.01}")
    sizing = Sizing("drive.J_flywheel", target, (0.01, 0.4), runs={0.01: q * 1.2, 0.07: q, 0.4: q * 0.9},
                    answer=0.07, verified=q, message="made up for the page", system=system, verifying=df)
    text = sizing.report(tmp_path / "s.html").read_text()
    rows = [r for r in _cells(text) if len(r) == 4 and r[2] in ("yes", "no")]
    assert [(r[0], r[2]) for r in rows] == [("0.01", "no"), ("0.07", "yes"), ("0.4", "yes")]
    assert rows[1][3] == "verifying run"
    assert len(re.findall(r'src="data:image/png;base64,', text)) == 3       # runs, over time, over one cycle


def test_sweep_page_from_the_command_line(tmp_path):
    spec = tmp_path / "grid.yaml"
    spec.write_text("stop_time: 0.2\nstep: 2.0e-4\ngrid:\n  drive.J_flywheel: [0.05, 0.1]\n"
                    "outputs:\n  torque_peak: 'peak(r[\"drive.shaft_torque\"])'\n"
                    "plot:\n  x: drive.J_flywheel\n  y: [torque_peak]\n  units: {torque_peak: N.m}\n")
    out, page = tmp_path / "sweep.csv", tmp_path / "sweep.html"
    p = subprocess.run([sys.executable, "-m", "harness", "sweep", DRIVE, "--grid", str(spec), "--workers", "0",
                        "--out", str(out), "--report", str(page)], cwd=ROOT, capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 0, p.stderr
    import pandas as pd

    df = pd.read_csv(out)
    text = page.read_text()
    points = [r for r in _cells(text) if len(r) == len(df.columns) + 1 and r[0] in ("0", "1")]
    assert [r[df.columns.get_loc("torque_peak") + 1] for r in points] == [h.number(v) for v in df["torque_peak"]]
    assert len(re.findall(r'src="data:image/png;base64,', text)) == 1


# -- in a real browser ------------------------------------------------------------------------------------------
_PROBE = ('<script>window.addEventListener("load",function(){var o=[];document.querySelectorAll("img").forEach('
          'function(i){o.push(i.complete?i.naturalWidth+"x"+i.naturalHeight:"pending")});'
          'var p=document.createElement("pre");p.id="probe";p.textContent="IMG:"+o.join(",")+";TABLES:"+'
          'document.querySelectorAll("table").length+";ROWS:"+document.querySelectorAll("tr").length;'
          'document.body.appendChild(p);});</script>')


def _chromium(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=10000",
                           *args], capture_output=True, text=True, timeout=120)


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (Debian package chromium; .ci/run installs "
                                             "it): the report is not opened in a browser")
def test_the_page_shows_its_charts_and_tables_in_headless_chromium(page, tmp_path):
    path, text = page
    probe = tmp_path / "probe.html"              # the report itself carries no script; its copy gets the probe
    probe.write_text(text.replace("</body>", _PROBE + "</body>"), encoding="utf-8")
    dom = _chromium("--dump-dom", probe.as_uri()).stdout
    found = re.search(r'<pre id="probe">IMG:([^;]*);TABLES:(\d+);ROWS:(\d+)</pre>', dom)
    assert found, dom[-500:]
    assert "pending" not in found.group(1), found.group(1)
    sizes = [tuple(map(int, s.split("x"))) for s in found.group(1).split(",") if s]
    assert len(sizes) == 2 and all(w > 500 and hh > 300 for w, hh in sizes), sizes   # decoded, not broken
    assert int(found.group(2)) == text.count("<table>") >= 4
    assert int(found.group(3)) == text.count("<tr>")
    shot = tmp_path / "shot.png"
    _chromium(f"--screenshot={shot}", "--window-size=1280,2000", path.as_uri())
    assert shot.is_file() and shot.stat().st_size > 20_000


def test_harness_report_writes_a_runs_page_and_refuses_what_is_not_a_result(run, tmp_path):
    import pandas as pd

    import harness

    system, df = run
    path = harness.report(df, tmp_path / "r.html", system=system)
    text = path.read_text()
    assert "Engineering quantities" in text and len(re.findall(r'src="data:image/png;base64,', text)) == 2
    with pytest.raises(TypeError, match="not a run's result"):
        harness.report(pd.DataFrame({"x": [1.0]}), tmp_path / "t.html")
    from harness.errors import SystemError_

    with pytest.raises(SystemError_, match="ending in .html"):
        harness.report(df, tmp_path / "r.txt", system=system)


def test_the_page_lists_every_parameter_with_unit_and_no_expression(run, page):
    """Every parameter of every instance, defaults too, as the FMU declares it (its unit, its start unless the
    drive or the run sets it); the page shows no Python expression (the accuracy's zones by their labels)."""
    system, df = run
    _, text = page
    rows = {(c[0], c[1]): c for c in _cells(text) if len(c) == 6}
    for inst in system.instances:
        for v in model_description(resolve_fmu(inst.fmu)).modelVariables:
            if v.causality != "parameter":
                continue
            key = f"{inst.name}.{v.name}"
            by = "run" if key in CHANGED else "drive" if v.name in inst.parameters else "FMU default"
            value = CHANGED.get(key, inst.parameters.get(v.name, v.start))
            cell = rows[(inst.name, v.name)]
            assert cell[4] == by and cell[3] == (v.unit or getattr(v.declaredType, "unit", None) or "-")
            if by != "FMU default" or v.type == "Real":
                assert cell[2] == h.number(float(value) if v.type == "Real" else value), (key, cell)
    for expression in ('r["', "window(", "peak(", "between("):
        assert expression not in html.unescape(text)
