"""FMI content other people bring (issue 33): what was wrong, and what is new.

* FMI 1.0 String values (tests/fmi1_string/identity.c, an FMI 1.0 co-simulation FMU written for this test,
  compiled with the system C compiler): a String passes through a chain of two connections unchanged (it
  used to arrive as "b'hello'", then as "b\"b'hello'\"").
* A component the SSD declares implementation="ModelExchange" is not run as co-simulation.
"""
from __future__ import annotations

import shutil
import subprocess
import warnings
import zipfile
from pathlib import Path

import pytest

from harness import simulate
from harness.model import Connection, Experiment, Instance, System

HERE = Path(__file__).resolve().parent


def _cc() -> str:
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler (cc/gcc): cannot build the FMI 1.0 test FMU")
    return cc


@pytest.fixture(scope="session")
def identity1(tmp_path_factory) -> Path:
    """tests/fmi1_string as an FMI 1.0 co-simulation FMU (Identity1.fmu)."""
    src = HERE / "fmi1_string"
    out = tmp_path_factory.mktemp("fmi1_string")
    lib = out / "Identity1.so"
    r = subprocess.run([_cc(), "-shared", "-fPIC", "-O1", "-fvisibility=hidden", "-o", str(lib),
                        str(src / "identity.c")], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"compiling tests/fmi1_string/identity.c failed: {r.stderr.strip()[-300:]}")
    fmu = out / "Identity1.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.write(src / "modelDescription.xml", "modelDescription.xml")
        z.write(lib, "binaries/linux64/Identity1.so")
    return fmu


def quiet(system, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(system, **kw)


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_fmi1_string_passes_a_chain_of_two_connections_unchanged(identity1, master):
    system = System("strings", [Instance("a", str(identity1), {"u": "hello"}), Instance("b", str(identity1)),
                                Instance("c", str(identity1))],
                    [Connection("a.y", "b.u"), Connection("b.y", "c.u")],
                    experiment=Experiment(stop_time=0.03, step=0.01))
    df = quiet(system, master=master, on_error="raise")
    assert df.attrs["complete"]
    assert list(df["a.y"]) == ["hello"] * 4
    assert list(df["c.y"])[-1] == "hello"
    assert set(df["b.y"]) <= {"", "hello"} and set(df["c.y"]) <= {"", "hello"}
