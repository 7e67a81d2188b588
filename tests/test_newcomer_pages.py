"""The newcomer pages of docs/howto run as written.  The master and observer pages' ```python block is executed on
the shipped two_inertia system and its own asserts decide (a master written out as Jacobi agrees with the shipped
one bit for bit; an observer sees every accepted point).  The component page is followed in a copy of the fmus
package (its files written there, its commands and its system run there, never in the repository's own fmus/):
the toy damper's run must meet the closed form of two inertias joined by it, and a damper with the wrong sign
must not."""
import os
import re
import shlex
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from harness.master import MASTERS

ROOT = Path(__file__).resolve().parents[1]
HOWTO = ROOT / "docs" / "howto"
PAGES = ["add-a-master.md", "add-an-observer.md"]


def code_of(page: str) -> str:
    blocks = re.findall(r"```python\n(.*?)```", (HOWTO / page).read_text(), flags=re.S)
    assert len(blocks) == 1, f"{page}: expected one python block, found {len(blocks)}"
    return blocks[0]


@pytest.mark.parametrize("page", PAGES)
def test_page_example_runs(page, monkeypatch):
    monkeypatch.setattr("harness.master.MASTERS", dict(MASTERS))  # the page's registration stays in the test
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


# -- the component page: followed in a copy of the fmus package, never in the repository's own ---------------

COMPONENT_PAGE = HOWTO / "add-a-component.md"
FENCE = re.compile(r"^```(\w+)\n(.*?)^```", re.M | re.S)


def component_steps(text: str) -> tuple[dict[str, str], list[str], str]:
    """The page's files (a ```python block whose first line is ``# <path>``), its shell commands (```sh blocks)
    and its run (the ```python block without a path), in the page's order."""
    files, commands, runs = {}, [], []
    for lang, body in FENCE.findall(text):
        first = body.splitlines()[0]
        if lang == "python" and re.fullmatch(r"# [\w/]+\.py", first):
            files[first[2:]] = body
        elif lang == "python":
            runs.append(body)
        elif lang == "sh":
            commands += [line for line in body.splitlines() if line.strip()]
    assert files and commands and len(runs) == 1, f"{COMPONENT_PAGE.name}: files {list(files)}, {len(runs)} runs"
    return files, commands, runs[0]


def follow_component_page(text: str, folder: Path) -> subprocess.CompletedProcess:
    """Copy fmus/ and build_fmus.py into ``folder``, write the page's files there, run its commands and its
    system there (the copy's fmus first on the path, FMUs built into ``folder``); the last process's result."""
    shutil.copytree(ROOT / "fmus", folder / "fmus", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy2(ROOT / "build_fmus.py", folder)
    files, commands, run = component_steps(text)
    for path, body in files.items():
        assert not (folder / path).exists(), f"the page's {path} would overwrite a shipped file"
        (folder / path).write_text(body)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(folder), str(ROOT)]),
           "PRESSDRIVE_FMU_DIR": str(folder / "build" / "fmus")}
    for command in commands:
        argv = shlex.split(command)
        assert argv[0] == "python", command
        done = subprocess.run([sys.executable, *argv[1:]], cwd=folder, env=env, capture_output=True, text=True)
        assert done.returncode == 0, f"{command}: {done.stderr.strip()[-2000:]}"
    (folder / "run_page.py").write_text(run)
    return subprocess.run([sys.executable, "run_page.py"], cwd=folder, env=env, capture_output=True, text=True)


def test_component_page_adds_a_damper(tmp_path):
    """The page followed step by step: the damper's FMU is built in the copy, listed by the catalog and its run
    meets the closed form of two inertias joined by it (the page's own asserts)."""
    done = follow_component_page(COMPONENT_PAGE.read_text(), tmp_path)
    assert done.returncode == 0, done.stderr.strip()[-2000:]
    assert (tmp_path / "build" / "fmus" / "Damper.fmu").is_file()
    assert not (ROOT / "fmus" / "physics" / "damper.py").exists()


def test_component_page_fails_on_a_wrong_damper(tmp_path):
    """The page's check can fail: the damper with its torque's sign flipped (it drives the speeds apart) does."""
    text = COMPONENT_PAGE.read_text()
    wrong = text.replace("tau = -self.p.d * (u[1] - u[3])", "tau = self.p.d * (u[1] - u[3])")
    assert wrong != text
    done = follow_component_page(wrong, tmp_path)
    assert done.returncode != 0 and "AssertionError" in done.stderr, done.stderr.strip()[-2000:]
