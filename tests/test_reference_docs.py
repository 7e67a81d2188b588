"""docs/reference/ cannot drift from the code: the command line page is regenerated here
(``python -m docs_tools.cli_reference``) and must equal the committed file; the Python API page names where each
public name is defined and is rendered by mkdocstrings, so the whole site is built with ``mkdocs build --strict``
(a missing object, a broken reference or a page error fails)."""
from __future__ import annotations

import importlib
import re
import subprocess
import sys
from pathlib import Path

import pytest

from docs_tools import cli_reference

ROOT = Path(__file__).resolve().parents[1]
API = ROOT / "docs" / "reference" / "api.md"


def _api_objects() -> dict[str, object]:
    """Every ``::: module.name`` of docs/reference/api.md, imported."""
    out = {}
    for path in re.findall(r"^::: ([\w.]+)$", API.read_text(encoding="utf-8"), flags=re.M):
        module, _, name = path.rpartition(".")
        try:
            out[path] = getattr(importlib.import_module(module), name)
        except (ImportError, AttributeError):
            out[path] = importlib.import_module(path)
    return out


def test_the_committed_cli_reference_is_what_the_code_gives(tmp_path):
    done = subprocess.run([sys.executable, "-m", "docs_tools.cli_reference", str(tmp_path)], cwd=ROOT,
                          capture_output=True, text=True, timeout=120, env={"PYTHONPATH": str(ROOT), "PATH": ""})
    assert done.returncode == 0, done.stderr[-2000:]
    assert (tmp_path / "cli.md").read_text(encoding="utf-8") == (ROOT / "docs/reference/cli.md").read_text(
        encoding="utf-8"), "docs/reference/cli.md differs from the code: run `python -m docs_tools.cli_reference`"


def test_the_site_builds_strict(tmp_path):
    """mkdocs with mkdocstrings, strict: every page and every API entry renders without a warning."""
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    page = (tmp_path / "site" / "reference" / "api.html").read_text(encoding="utf-8")
    for path in _api_objects():
        assert f'id="{path}"' in page, path
    assert ":class:" not in page        # the Sphinx roles of the docstrings are rendered as names


def test_every_public_name_is_in_the_api_reference_with_a_docstring():
    import harness

    objects = _api_objects()
    for name in harness.__all__:
        assert any(obj is getattr(harness, name) for obj in objects.values()), f"harness.{name} not in {API.name}"
    # MASTERS (a dict: its instances' docstring is dict's) is documented by its masters' own docstrings
    undocumented = [path for path, obj in objects.items()
                    if not isinstance(obj, dict) and not (getattr(obj, "__doc__", None) or "").strip()]
    assert undocumented == [], undocumented
    assert all((cls.__doc__ or "").strip() for cls in harness.MASTERS.values())


def test_every_command_is_in_the_cli_reference():
    from harness.__main__ import build_parser

    cli = cli_reference.cli_markdown()
    for name, _ in cli_reference._subparsers(build_parser()):
        assert f"`python -m harness {name}`" in cli


def test_a_changed_help_changes_the_reference(monkeypatch):
    """The CLI page comes from the parser: a changed help line shows there (so a stale page fails above)."""
    import harness.__main__ as main

    real = main.build_parser

    def changed(command=None):
        ap = real(command)
        ap._actions[1].help = "a help line that was changed"
        return ap

    monkeypatch.setattr(main, "build_parser", changed)
    assert "a help line that was changed" in cli_reference.cli_markdown()


def test_a_public_name_without_a_docstring_is_found(monkeypatch):
    import harness.results

    monkeypatch.setattr(harness.results.to_csv, "__doc__", None)
    with pytest.raises(AssertionError, match="to_csv"):
        test_every_public_name_is_in_the_api_reference_with_a_docstring()
