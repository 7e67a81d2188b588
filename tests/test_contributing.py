"""docs/contributing.md and tests/mutations.py stay in step: every mutation is on the page with its tests, and the
text each one replaces is still in its file exactly once (else the mutation tests nothing and says so only when
run).  Cheap: no mutation is run here (``python tests/mutations.py`` runs them)."""
from __future__ import annotations

from pathlib import Path

import pytest

from mutations import MUTATIONS, ROOT

PAGE = (ROOT / "docs" / "contributing.md").read_text(encoding="utf-8")


@pytest.mark.parametrize("m", MUTATIONS, ids=[m.name for m in MUTATIONS])
def test_every_mutation_is_listed_and_still_applies(m):
    row = next((line for line in PAGE.splitlines() if line.startswith(f"| `{m.name}` |")), None)
    assert row is not None, f"docs/contributing.md lists no mutation {m.name}"
    words = [t for t in m.tests if not t.startswith("-")]
    assert f"`{words[0]} -k" in row and all(w in row for w in words[1:]), (row, m.tests)
    assert (ROOT / m.path).read_text(encoding="utf-8").count(m.old) == 1, \
        f"{m.path} no longer holds the text mutation {m.name} replaces: update tests/mutations.py"


def test_the_page_lists_no_mutation_the_code_lacks():
    listed = {line.split("`")[1] for line in PAGE.splitlines() if line.startswith("| `")}
    assert listed == {m.name for m in MUTATIONS}
