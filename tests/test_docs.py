"""The README and docs/ cannot go stale: every docs page is reached from the README, every relative link
resolves, no page speaks of the project's history, every command a page shows runs, and the output a page
shows is what the command prints.

Convention: a fenced ```console block holds commands, one per line starting with ``$ ``; the lines after a
command, up to the next one, are its output as the page shows it.  Each command is run here as written (in a
scratch folder holding links to ``systems/`` and ``build_fmus.py``, with the session's FMUs), and must exit 0:
``python -m harness`` commands through the command line's ``main`` in this process, others in a process of
their own.  Shown output is an excerpt: its lines must appear in the printed output (stdout, then stderr) one
after the other, in order; a line ``...`` skips any number of printed lines, and ``...`` inside a line
matches any text.  A number matches to the digits shown (half a unit of its last digit), or within the
tolerance the command states in a comment, ``# output within 2%``; a command that exits non-zero by design
says so, ``# exits 2``.  A command too slow for the suite ends
with ``# slow: why``; it must be a ``python -m harness`` command, and in the default suite is checked against
the command line's own parser (so a renamed option, command or choice fails here); with ``-m slow`` it runs
and its shown output is checked too.  The README's ```python example runs too.  Cost: about 40 s.
"""
from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
PAGES = sorted((ROOT / "docs").rglob("*.md"))
FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```", re.M | re.S)
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def blocks(path: Path, language: str) -> list[str]:
    return [body for lang, body in FENCE.findall(path.read_text(encoding="utf-8")) if lang == language]


def examples(path: Path) -> list[tuple[str, list[str]]]:
    """(command, the output lines the page shows after it) of every ``$ `` line of the page's console blocks."""
    out: list[tuple[str, list[str]]] = []
    for body in blocks(path, "console"):
        for line in body.splitlines():
            if line.startswith("$ "):
                out.append((line[2:].strip(), []))
            elif out and line.strip():
                out[-1][1].append(line.rstrip())
    return out


def commands(path: Path) -> list[str]:
    return [command for command, _ in examples(path)]


NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def _line_pattern(expected: str) -> tuple[re.Pattern, list[str]]:
    """A shown line as a regular expression (numbers captured, ``...`` any text, blanks any blanks) and its
    numbers as shown."""
    parts, numbers = [], []
    for token in re.split(rf"(\.\.\.|{NUMBER}|\s+)", expected.strip()):
        if not token:
            continue
        if token == "...":
            parts.append(".*?")
        elif token.isspace():
            parts.append(r"\s+")
        elif re.fullmatch(NUMBER, token):
            parts.append(f"({NUMBER})")
            numbers.append(token)
        else:
            parts.append(re.escape(token))
    return re.compile(r"\s*" + "".join(parts) + r"\s*"), numbers


def _number_agrees(shown: str, printed: str, rtol: float) -> bool:
    digits = shown.lower().split("e")[0]
    exponent = int(shown.lower().split("e")[1]) if "e" in shown.lower() else 0
    decimals = len(digits.split(".")[1]) if "." in digits else 0
    half_unit = 0.5 * 10.0 ** (exponent - decimals)
    e, a = float(shown), float(printed)
    return abs(a - e) <= max(half_unit * (1 + 1e-9), rtol * abs(e))


def _line_agrees(expected: str, printed: str, rtol: float) -> bool:
    pattern, shown = _line_pattern(expected)
    m = pattern.fullmatch(printed)
    return bool(m) and all(_number_agrees(s, p, rtol) for s, p in zip(shown, m.groups()))


def output_mismatch(expected: list[str], printed: str, rtol: float = 0.0) -> str | None:
    """None when the shown lines (``...`` lines split them into runs) appear in ``printed``, each run on
    consecutive lines, the runs in order; else what was not found."""
    runs: list[list[str]] = [[]]
    for line in expected:
        if line.strip() == "...":
            runs.append([])
        else:
            runs[-1].append(line)
    lines = [line for line in printed.splitlines() if line.strip()]
    at = 0
    for run in filter(None, runs):
        best = 0                                      # the most lines of the run matched from one start
        for start in range(at, len(lines) - len(run) + 1):
            n = next((k for k, (e, p) in enumerate(zip(run, lines[start:start + len(run)]))
                      if not _line_agrees(e, p, rtol)), len(run))
            if n == len(run):
                at = start + len(run)
                break
            best = max(best, n)
        else:
            return f"not printed (after line {at} of the output): {run[best]!r}" + (
                f" (following {run[best - 1]!r})" if best else "")
    return None


def stated_tolerance(command: str) -> float:
    m = re.search(r"#.*output within ([\d.]+)\s*%", command)
    return float(m.group(1)) / 100.0 if m else 0.0


def slugs(path: Path) -> set[str]:
    """GitHub's anchors of the page's headings: lower case, punctuation dropped, spaces to hyphens."""
    out = set()
    for heading in re.findall(r"^#+\s+(.*)$", FENCE.sub("", path.read_text(encoding="utf-8")), re.M):
        out.add(re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-"))
    return out


def page_id(page: Path) -> str:
    return str(page.relative_to(ROOT))


ALL_EXAMPLES = [(page_id(page), c, shown) for page in PAGES + [README] for c, shown in examples(page)]
ALL_COMMANDS = [(page, c) for page, c, _ in ALL_EXAMPLES]
SLOW_EXAMPLES = [e for e in ALL_EXAMPLES if "# slow" in e[1]]


def test_every_docs_page_is_reached_from_the_readme():
    """Through links, page to page (README -> docs/index.md -> a how-to -> ...)."""
    seen, todo = set(), [README.resolve()]
    while todo:
        page = todo.pop()
        if page in seen or page.suffix != ".md" or not page.is_file():
            continue
        seen.add(page)
        for target in LINK.findall(FENCE.sub("", page.read_text(encoding="utf-8"))):
            if not re.match(r"^[a-z]+:", target) and target.split("#")[0]:
                todo.append((page.parent / target.split("#")[0]).resolve())
    assert PAGES, "no docs/*.md pages"
    missing = [page_id(p) for p in PAGES if p.resolve() not in seen]
    assert not missing, f"docs pages no link leads to from README.md: {missing}"


HISTORY = re.compile(r"\b(?:issues?\s+#?\d+|stops?\s+\d+(?![\d.]))|\bgoal lines?\b|\[(?:MET|MISS)\s*\]", re.I)


@pytest.mark.parametrize("page", [README] + PAGES, ids=page_id)
def test_no_page_speaks_of_the_projects_history(page):
    """Issue and stop numbers and goal lines belong in CHANGELOG.md, not in a user's page."""
    found = HISTORY.findall(page.read_text(encoding="utf-8"))
    assert not found, f"{page_id(page)}: {found} (project history goes to CHANGELOG.md)"


def test_shown_output_is_compared():
    """The comparison itself: excerpts, ``...``, numbers to the digits shown or a stated tolerance."""
    printed = "run: 101 points to t = 0.05 s\n  speed  62.94  rpm\n  torque  14.74  N.m\n  end\n"
    assert output_mismatch(["  speed  62.94  rpm", "  torque  14.74  N.m"], printed) is None
    assert output_mismatch(["run: 101 points ...", "...", "  end"], printed) is None
    assert output_mismatch(["  speed  62.9  rpm"], printed) is None               # fewer digits shown
    assert output_mismatch(["  speed  62.93  rpm"], printed) is not None          # a stale number
    assert output_mismatch(["  speed  63  rpm"], printed, rtol=0.01) is None      # within a stated 1 %
    assert output_mismatch(["  speed  60  rpm"], printed, rtol=0.01) is not None
    assert output_mismatch(["  speed  62.94  rpm", "  end"], printed) is not None  # not consecutive
    assert output_mismatch(["  torque  14.74  N.m", "  speed  62.94  rpm"], printed) is not None   # order
    assert output_mismatch(["  speed  62.94  m/s"], printed) is not None          # text
    assert stated_tolerance("python -m harness run x  # output within 2.5%") == 0.025


@pytest.mark.parametrize("page", [README] + PAGES, ids=lambda p: p.name)
def test_every_relative_link_resolves(page):
    text = FENCE.sub("", page.read_text(encoding="utf-8"))
    broken = []
    for target in LINK.findall(text):
        if re.match(r"^[a-z]+:", target):          # http:, https:, mailto:
            continue
        file, _, anchor = target.partition("#")
        where = (page.parent / file).resolve() if file else page
        if not where.exists():
            broken.append(target)
        elif anchor and where.suffix == ".md" and anchor not in slugs(where):
            broken.append(f"{target} (no heading with that anchor)")
    assert not broken, f"{page.name}: broken links {broken}"


def test_the_pages_show_commands():
    """Every topic page with a command shows it runnable (the convention above), and a command that
    cannot be parsed as one is not silently skipped."""
    assert len(ALL_COMMANDS) >= 20
    for page, command in ALL_COMMANDS:
        assert command.startswith(("python ", "pressdrive ")), f"{page}: {command!r} is not a command this test runs"


@pytest.fixture(scope="session")
def scratch(tmp_path_factory):
    """A folder to run the pages' commands in: ``systems/`` and ``build_fmus.py`` linked from the tree, the
    outputs (``results/``) kept out of it.  One per session, not per module: under pytest-xdist a worker may run
    another module's test between two of these, which would tear a module-scoped folder down and lose the
    files a page's earlier command wrote.  (A page's commands run in order on one worker: the default suite is
    distributed by file, ``--dist loadfile``.  The ``# slow`` commands each stand alone: the slow suite runs
    without the others, each test on whichever worker is free.)"""
    d = tmp_path_factory.mktemp("docs_commands")
    for name in ("systems", "build_fmus.py"):
        (d / name).symlink_to(ROOT / name)
    return d


def harness_argv(command: str) -> list[str] | None:
    """The arguments of a ``python -m harness`` command (None for any other command)."""
    argv = shlex.split(command, comments=True)
    return argv[3:] if argv[:3] == ["python", "-m", "harness"] else None


def parse_only(command: str) -> None:
    from harness.__main__ import build_parser

    argv = harness_argv(command)
    assert argv is not None, f"a '# slow' command must be python -m harness: {command!r}"
    try:
        build_parser().parse_args(argv)
    except SystemExit as e:
        raise AssertionError(f"{command!r}: the command line refuses it (exit {e.code})") from None


def run_and_check(page, command, shown, scratch, fmu_dir, monkeypatch, capsys):
    """Run ``command`` as the page shows it and compare its output with the shown lines."""
    check(page, command, shown, *run_command(command, scratch, fmu_dir, monkeypatch, capsys))


def run_command(command, scratch, fmu_dir, monkeypatch, capsys) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of ``command`` run as a page shows it, in ``scratch``."""
    monkeypatch.chdir(scratch)
    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    argv = harness_argv(command)
    if argv is not None:
        import warnings

        from harness.__main__ import main
        from reference_cache import sharing

        sharing(monkeypatch)         # a monolithic reference another test computes too: once (tests/reference_cache.py)

        monkeypatch.setattr(warnings, "showwarning", warnings.showwarning)   # main() sets its own
        capsys.readouterr()
        try:
            status = main(argv)
        except SystemExit as e:                       # --help, --version
            status = e.code
        out, err = capsys.readouterr()
    else:
        argv = shlex.split(command, comments=True)
        argv[0] = sys.executable if argv[0] == "python" else argv[0]
        done = subprocess.run(argv, capture_output=True, text=True, timeout=3600,
                              env=dict(os.environ, PYTHONPATH=str(ROOT)))
        status, out, err = done.returncode, done.stdout, done.stderr
    return status, out, err


def check(page, command, shown, status, out, err) -> None:
    """The exit status the page states (0 unless ``# exits N``) and the output it shows."""
    stated = re.search(r"#.*\bexits (\d+)", command)           # a documented refusal, e.g. size's 2
    expected = (int(stated.group(1)),) if stated else (0, None)
    assert status in expected, f"{page}: {command!r} exited {status}:\n{err[-2000:]}"
    if shown:
        wrong = output_mismatch(shown, out + "\n" + err, stated_tolerance(command))
        assert wrong is None, (f"{page}: {command!r} prints other than the page shows: {wrong}\n"
                               f"--- printed:\n{(out + err)[-3000:]}")


@pytest.mark.parametrize("page, command, shown", ALL_EXAMPLES, ids=[f"{p}:{c[:60]}" for p, c, _ in ALL_EXAMPLES])
def test_every_command_on_a_page_runs(page, command, shown, scratch, fmu_dir, monkeypatch, capsys):
    """``python -m harness`` commands run in this process through the command line's own ``main`` (a
    process each would cost 2-3 s of imports); anything else in a process of its own."""
    if "# slow" in command:
        parse_only(command)
        return
    covered = RUN_BY_TESTS.get(tuple(harness_argv(command) or ()))
    if covered is not None:         # a test runs it as written and checks further (RUN_BY_TESTS)
        parse_only(command)
        assert covered[1]() and not shown, (page, command, covered[0])
        return
    run_and_check(page, command, shown, scratch, fmu_dir, monkeypatch, capsys)


def _same_command(examples) -> list[list[tuple]]:
    """The examples grouped by the command they run (its words, the comment left out), in page order."""
    groups: dict = {}
    for page, command, shown in examples:
        groups.setdefault(tuple(shlex.split(command, comments=True)), []).append((page, command, shown))
    return list(groups.values())


SLOW_GROUPS = _same_command(SLOW_EXAMPLES)


def shipped_study_sweep(command: str) -> Path | None:
    """The shipped sweep study (systems/studies/*.yaml) a ``python -m harness sweep`` command runs whole, or None."""
    argv = harness_argv(command) or []
    if argv[:1] != ["sweep"] or "--grid" not in argv:
        return None
    spec = ROOT / argv[argv.index("--grid") + 1]
    return spec if spec.parent == ROOT / "systems" / "studies" else None


def _scene_of(system: str, scene: str) -> bool:
    from harness import load
    from harness.run import system_names

    return system in system_names() and scene in [s.name for s in load(system).scenes]


# page commands that show no output and that a test of the same suite runs as written (its output folder aside) and
# checks further: the page's command runs there, once.  The condition names the test's case, so a renamed case
# fails here.
RUN_BY_TESTS = {
    ("synth", "groove", "--seed-figures", "docs/images"): (
        "tests/test_groove_seed001.py::test_seed_figures_command_writes_figs_2_4_7_and_the_statements",
        lambda: '_args("--seed-figures", str(tmp_path))\n' in (ROOT / "tests" / "test_groove_seed001.py").read_text()),
    ("study", "stability", "two_inertia"): ("tests/test_study_cli.py::test_stability_map_of_the_two_inertia_benchmark_"
                                            "measured", lambda: '["study", "stability", "two_inertia", "--out"'
                                            in (ROOT / "tests" / "test_study_cli.py").read_text()),
    ("study", "stability", "bed_drive"): ("tests/test_stability.py::test_full_press_map_cli",
                                          lambda: '["study", "stability", "bed_drive"' in (ROOT / "tests" / "test_stability.py").read_text()),
    ("study", "precision", "bed_drive"): ("tests/test_precision.py::test_default_study_of_every_system[bed_drive]",
                                          lambda: "bed_drive" in __import__("harness.studies.precision", fromlist=["x"]).PRECISION),
    # asked there with the drive's other scenes (--all): the answer it gets alone
    # (tests/test_scenes.py::test_all_scenes_share_their_runs_and_answer_as_each_alone)
    ("scene", "bed_drive", "bed_stroke"): ("tests/test_scenes.py::test_every_scene_of_a_system_and_two_choose_different_models"
                                           "[bed_drive]", lambda: _scene_of("bed_drive", "bed_stroke")),
}


@pytest.mark.slow
@pytest.mark.parametrize("group", SLOW_GROUPS, ids=[f"{g[0][0]}:{g[0][1][:60]}" for g in SLOW_GROUPS])
def test_every_slow_command_on_a_page_runs(group, scratch, fmu_dir, monkeypatch, capsys):
    """The ``# slow`` commands, run and their shown output checked (``-m slow``).  A command shown on several
    pages (the tutorial's compare and size are the how-to's) runs once, and each page's shown output and stated
    exit status are checked against that run.  A sweep of a whole shipped study (the pages show no output of
    one: the command regenerates a figure's data, 96 runs and more) is the command tests/test_sweep_studies_cli.py
    runs on the same spec with its grid cut to two points, charts included: the part the page adds, the
    command as written, is checked by the command line's parser here.  So is a command :data:`RUN_BY_TESTS`
    names: a slow test runs it as written and checks its results further."""
    page, command, _ = group[0]
    covered = RUN_BY_TESTS.get(tuple(harness_argv(command) or ()))
    if covered is not None:
        parse_only(command)
        assert covered[1]() and all(not shown for _, _, shown in group), (page, command, covered[0])
        return
    study = shipped_study_sweep(command)
    if study is not None and all(not shown for _, _, shown in group):   # a page that shows its output runs it below
        import test_sweep_studies_cli

        parse_only(command)
        assert study in test_sweep_studies_cli.STUDIES, (page, command)
        return
    status, out, err = run_command(command, scratch, fmu_dir, monkeypatch, capsys)
    for page, command, shown in group:
        check(page, command, shown, status, out, err)


def test_a_command_shown_on_two_pages_is_run_once_for_both():
    """The grouping above: the tutorial's compare and size commands are the how-to's, comments aside."""
    groups = {g[0][1].split("#")[0].strip(): [page for page, _, _ in g] for g in SLOW_GROUPS}
    compare = next(c for c in groups if c.startswith("python -m harness compare bed_drive"))
    assert sorted(groups[compare]) == ["docs/howto/compare-and-size.md", "docs/tutorial.md"]
    assert sum(len(g) for g in SLOW_GROUPS) == len(SLOW_EXAMPLES) > len(SLOW_GROUPS)


def test_the_readme_python_example_runs(fmu_dir, monkeypatch, capsys):
    """It runs as printed, without a warning (a renamed argument, a noisy run)."""
    import warnings

    (example,) = blocks(README, "python")
    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        exec(compile(example, "README.md", "exec"), {})            # noqa: S102 (the README's own example)
    out = capsys.readouterr().out.split()
    assert float(out[0]) > 0.2 and out[1] == "m" and out[2] == "True"
