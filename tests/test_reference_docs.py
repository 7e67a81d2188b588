"""docs/reference/ cannot drift from the code: it is regenerated here (``python -m docs_tools.reference``) and
must equal the committed files; a public name without a docstring fails the generator.  Cost: about 3 s."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from docs_tools import reference

ROOT = Path(__file__).resolve().parents[1]


def test_the_committed_reference_is_what_the_code_gives(tmp_path):
    done = subprocess.run([sys.executable, "-m", "docs_tools.reference", str(tmp_path)], cwd=ROOT,
                          capture_output=True, text=True, timeout=120, env={"PYTHONPATH": str(ROOT), "PATH": ""})
    assert done.returncode == 0, done.stderr[-2000:]
    stale = [name for name in ("cli.md", "api.md")
             if (tmp_path / name).read_text(encoding="utf-8") != (ROOT / "docs/reference" / name).read_text(
                 encoding="utf-8")]
    assert not stale, (f"docs/reference/{stale} differ from the code: run `python -m docs_tools.reference` "
                       "and commit the result")


def test_every_command_and_export_is_in_the_reference():
    from harness.__main__ import build_parser

    import harness

    cli = reference.cli_markdown()
    api = reference.api_markdown()
    for name in reference._subparsers(build_parser()):
        assert f"`python -m harness {name[0]}`" in cli
    for name in harness.__all__:
        assert f"## `{name}`" in api


def test_a_public_name_without_a_docstring_fails(monkeypatch):
    import harness

    monkeypatch.setattr(harness.to_csv, "__doc__", None)
    with pytest.raises(reference.MissingDocstring, match="to_csv"):
        reference.api_markdown()


def test_a_changed_help_changes_the_reference(monkeypatch):
    """The CLI page comes from the parser: a changed help line shows there (so a stale page fails above)."""
    import harness.__main__ as main

    real = main.build_parser

    def changed(command=None):
        ap = real(command)
        ap._actions[1].help = "a help line that was changed"
        return ap

    monkeypatch.setattr(main, "build_parser", changed)
    assert "a help line that was changed" in reference.cli_markdown()
