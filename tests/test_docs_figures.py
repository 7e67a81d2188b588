"""The figures of the docs against their registry (docs_tools/figures.py): every image and data file a page
links is made by a named command, every file in docs/images/ has one, the harness commands parse, and (slow) the
cheapest figures regenerate into a scratch folder as valid PNG and CSV files."""
from __future__ import annotations

import argparse
import re
import runpy
import shlex
import sys
from pathlib import Path

import pytest

from docs_tools import figures

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md"] + sorted((ROOT / "docs").rglob("*.md"))
LINK = re.compile(r"images/([A-Za-z0-9_.-]+\.(?:png|csv|svg))")


class _Parsed(Exception):
    """Raised by a benchmark's parser once it has parsed its command line."""


def linked() -> dict[str, list[str]]:
    """Each docs/images file name a page links or names -> the pages (README.md and docs/**/*.md)."""
    found: dict[str, list[str]] = {}
    for page in PAGES:
        for name in LINK.findall(page.read_text(encoding="utf-8")):
            found.setdefault(name, []).append(str(page.relative_to(ROOT)))
    return found


def test_every_file_a_page_links_has_a_command():
    files = figures.by_file()
    missing = {name: pages for name, pages in linked().items() if name not in files}
    assert not missing, f"files the pages link with no command in docs_tools/figures.py: {missing}"


def test_every_file_in_docs_images_has_a_command_and_every_registered_file_exists():
    files = figures.by_file()
    present = {p.name for p in (ROOT / "docs" / "images").iterdir() if p.is_file()}
    assert sorted(present - set(files)) == [], "files in docs/images/ without a command in docs_tools/figures.py"
    assert sorted(set(files) - present) == [], "registered files missing from docs/images/"


def test_every_figure_makes_a_file_a_page_links_and_owns_its_files_alone():
    pages = linked()
    for f in figures.FIGURES:
        assert any(published in pages for published, _ in f.files), f"{f.name}: no page links any of its files"
    published = [p for f in figures.FIGURES for p, _ in f.files]
    assert len(published) == len(set(published)), "a file is made by two figures"
    names = [f.name for f in figures.FIGURES]
    assert len(names) == len(set(names))


@pytest.mark.parametrize("figure", figures.FIGURES, ids=lambda f: f.name)
def test_each_command_is_a_real_command_writing_into_its_folder(figure, monkeypatch):
    from harness.__main__ import build_parser

    assert "{out}" in figure.command, f"{figure.name}: the command names no output folder"
    argv = shlex.split(figure.shown())
    assert argv[:2] == ["python", "-m"], figure.command
    if argv[2] == "harness":
        try:
            build_parser().parse_args(argv[3:])
        except SystemExit as e:
            raise AssertionError(f"{figure.shown()!r}: the command line refuses it (exit {e.code})") from None
    else:   # the module's own parser, caught as it parses: nothing runs
        assert argv[2].split(".")[0] == "benchmarks", f"{figure.name}: not a harness or benchmarks command"
        parse = argparse.ArgumentParser.parse_args

        def parse_then_stop(parser, args=None, namespace=None):
            parse(parser, args, namespace)
            raise _Parsed

        monkeypatch.setattr(argparse.ArgumentParser, "parse_args", parse_then_stop)
        monkeypatch.setattr(sys, "argv", [argv[2]] + argv[3:])
        try:
            runpy.run_module(argv[2], run_name="__main__", alter_sys=False)
        except _Parsed:
            pass
        except SystemExit as e:
            raise AssertionError(f"{figure.shown()!r}: the command line refuses it (exit {e.code})") from None
        else:
            raise AssertionError(f"{figure.shown()!r}: {argv[2]} parsed no command line")
    for word in argv:
        if word.startswith("systems/"):
            assert (ROOT / word).is_file(), f"{figure.name}: {word} does not exist"


def test_the_command_line_selects_by_figure_or_file_and_refuses_an_unknown_name(capsys):
    assert [f.name for f in figures.select(["seeds_000_takeup_liftoff.csv", "bed_drive_run"])] == \
        ["bed_drive_run", "takeup_figures"]
    assert figures.select([]) == list(figures.FIGURES)
    with pytest.raises(SystemExit, match="unknown figure 'nope.png'"):
        figures.select(["nope.png"])
    assert figures.main(["--list", "bed_drive.png"]) == 0
    out = capsys.readouterr().out
    assert "python -m harness run bed_drive --out docs/images/bed_drive.csv --plot docs/images" in out


def _valid_png(path: Path) -> None:
    import matplotlib.image

    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", path
    height, width = matplotlib.image.imread(path).shape[:2]
    assert height > 100 and width > 100, (path, height, width)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["bed_drive_run", "takeup_figures"])
def test_the_cheapest_figures_regenerate_into_a_folder(name, tmp_path):
    import pandas as pd

    figure = next(f for f in figures.FIGURES if f.name == name)
    assert figures.main([name, "--out", str(tmp_path)]) == 0
    written = sorted(p.name for p in tmp_path.iterdir())
    assert written == sorted(published for published, _ in figure.files)
    for path in tmp_path.iterdir():
        if path.suffix == ".png":
            _valid_png(path)
        elif path.suffix == ".csv":
            table = pd.read_csv(path)
            assert len(table) > 0 and len(table.columns) > 1, path
