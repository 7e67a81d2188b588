"""The README and docs/ cannot go stale: every docs page is linked from the README, every relative link
resolves, and every command a page shows runs.

Convention: a fenced ```console block holds commands, one per line starting with ``$ ``.  Each is run here
as written (in a scratch folder holding links to ``systems/`` and ``build_fmus.py``, with the session's FMUs),
and must exit 0: ``python -m harness`` commands through the command line's ``main`` in this process, others
in a process of their own.  A command too slow for the suite ends with ``# slow: why``; it must be a ``python -m
harness`` command, and is checked against the command line's own parser (so a renamed option, command or
choice fails here) instead of being run.  The README's ```python example runs too.  Cost: about 30 s.
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
PAGES = sorted((ROOT / "docs").glob("*.md"))
FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```", re.M | re.S)
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def blocks(path: Path, language: str) -> list[str]:
    return [body for lang, body in FENCE.findall(path.read_text(encoding="utf-8")) if lang == language]


def commands(path: Path) -> list[str]:
    return [line[2:].strip() for body in blocks(path, "console") for line in body.splitlines()
            if line.startswith("$ ")]


def slugs(path: Path) -> set[str]:
    """GitHub's anchors of the page's headings: lower case, punctuation dropped, spaces to hyphens."""
    out = set()
    for heading in re.findall(r"^#+\s+(.*)$", FENCE.sub("", path.read_text(encoding="utf-8")), re.M):
        out.add(re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-"))
    return out


ALL_COMMANDS = [(page.name, c) for page in PAGES + [README] for c in commands(page)]


def test_every_docs_page_is_linked_from_the_readme():
    linked = {(README.parent / target.split("#")[0]).resolve()
              for target in LINK.findall(README.read_text(encoding="utf-8"))}
    assert PAGES, "no docs/*.md pages"
    missing = [p.name for p in PAGES if p.resolve() not in linked]
    assert not missing, f"docs pages not linked from README.md: {missing}"


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


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    """A folder to run the pages' commands in: ``systems/`` and ``build_fmus.py`` linked from the tree, the
    outputs (``results/``) kept out of it."""
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


@pytest.mark.parametrize("page, command", ALL_COMMANDS, ids=[f"{p}:{c[:60]}" for p, c in ALL_COMMANDS])
def test_every_command_on_a_page_runs(page, command, scratch, fmu_dir, monkeypatch, capsys):
    """``python -m harness`` commands run in this process through the command line's own ``main`` (a
    process each would cost 2-3 s of imports); anything else in a process of its own."""
    if "# slow" in command:
        parse_only(command)
        return
    monkeypatch.chdir(scratch)
    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    argv = harness_argv(command)
    if argv is not None:
        import warnings

        from harness.__main__ import main

        monkeypatch.setattr(warnings, "showwarning", warnings.showwarning)   # main() sets its own
        try:
            status = main(argv)
        except SystemExit as e:                       # --help, --version
            status = e.code
        err = capsys.readouterr().err
    else:
        argv = shlex.split(command, comments=True)
        argv[0] = sys.executable if argv[0] == "python" else argv[0]
        done = subprocess.run(argv, capture_output=True, text=True, timeout=120,
                              env=dict(os.environ, PYTHONPATH=str(ROOT)))
        status, err = done.returncode, done.stderr
    assert status in (0, None), f"{page}: {command!r} exited {status}:\n{err[-2000:]}"


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
