"""The newcomer pages of docs/howto run as written: each page's ```python block is executed on the shipped
two_inertia system and its own asserts decide (a master written out as Jacobi agrees with the shipped one bit
for bit; an observer sees every accepted point)."""
import re
import warnings
from pathlib import Path

import pytest

from harness.masters import MASTERS

HOWTO = Path(__file__).resolve().parents[1] / "docs" / "howto"
PAGES = ["add-a-master.md", "add-an-observer.md"]


def code_of(page: str) -> str:
    blocks = re.findall(r"```python\n(.*?)```", (HOWTO / page).read_text(), flags=re.S)
    assert len(blocks) == 1, f"{page}: expected one python block, found {len(blocks)}"
    return blocks[0]


@pytest.mark.parametrize("page", PAGES)
def test_page_example_runs(page, monkeypatch):
    monkeypatch.setattr("harness.masters.MASTERS", dict(MASTERS))  # the page's registration stays in the test
    namespace: dict = {"__name__": f"howto_{page}"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        exec(compile(code_of(page), str(HOWTO / page), "exec"), namespace)


def test_master_page_fails_on_a_wrong_master():
    """The master page's asserts can fail: the same block with the FMU steps not counted does."""
    code = code_of("add-a-master.md").replace("self._step_fmus(self.insts, t, h, no_prior_state=True)",
                                              "[it.fmu.do_step(t, h, no_prior_state=True) for it in self.insts]")
    saved = dict(MASTERS)
    try:
        with warnings.catch_warnings(), pytest.raises(AssertionError):
            warnings.simplefilter("ignore")
            exec(compile(code, "add-a-master (perturbed)", "exec"), {"__name__": "howto_perturbed"})
    finally:
        MASTERS.clear()
        MASTERS.update(saved)
