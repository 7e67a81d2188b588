"""Every reader of what a user writes, fuzzed (hypothesis): any input loads or is refused in one line.

Readers: SSP archives (the SSD, its SSV parameter sets and SSM mappings, mutated from a real export), a bare
.ssd, an FMU's modelDescription.xml (mutated, the FMU run alone), sweep spec files (YAML and JSON), scenario files, input-signal CSV files, ``--set`` assignments
(``Instance.param=VALUE``), ``size --target`` quantity targets and ``compare --variant`` strings.  The property
for every generated input: the reader returns, or raises one of the toolkit's own errors (``HarnessError``,
``SweepError``, ``QoIError``) with a one-line, non-empty message; never another exception type, never a hang
(each example has a deadline).  The default suite runs ``FUZZ_EXAMPLES`` cases per reader (20, a few seconds);
``PRESSDRIVE_FUZZ_EXAMPLES=N`` runs N (the slow suite's ``test_fuzz_readers_many`` runs 300 per reader).
"""
from __future__ import annotations

import itertools
import json
import os
import string
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[1]
FUZZ_EXAMPLES = int(os.environ.get("PRESSDRIVE_FUZZ_EXAMPLES", "20"))
SLOW_EXAMPLES = 300
FUZZ = settings(max_examples=FUZZ_EXAMPLES, deadline=5000, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
_COUNT = itertools.count()


def _own_errors():
    from harness.errors import HarnessError
    from harness.reporting.qoi import QoIError
    from harness.studies.sweep_checks import SweepError

    return (HarnessError, SweepError, QoIError)


def loads_or_one_line(reader, *args):
    """``reader(*args)``; an exception must be the toolkit's own with a one-line message."""
    try:
        return reader(*args)
    except _own_errors() as e:
        text = str(e)
        assert text.strip() and "\n" not in text.strip(), f"{type(e).__name__} of more than one line: {text!r}"
        assert "Traceback" not in text
        return None


def _fresh(suffix: str) -> Path:
    """A new file name (the archive cache keys on path and time: every example gets its own)."""
    folder = Path(tempfile.mkdtemp(prefix="fuzz_"))
    return folder / f"f{next(_COUNT)}{suffix}"


# -- values a user may write -----------------------------------------------------------------------------------
scalars = st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20),
                    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12))
values = st.recursive(scalars, lambda kids: st.one_of(st.lists(kids, max_size=4),
                                                      st.dictionaries(st.text(max_size=8), kids, max_size=4)),
                      max_leaves=12)


def mapping_with(keys: list[str]):
    """Mappings whose keys are mostly the reader's own (so the fuzz gets past the first key check)."""
    key = st.one_of(st.sampled_from(keys), st.text(max_size=8))
    return st.dictionaries(key, values, max_size=len(keys) + 1)


# -- --set, --target, --variant --------------------------------------------------------------------------------
assignment = st.one_of(st.text(max_size=30),
                       st.builds(lambda a, b, c, v: f"{a}.{b}{c}{v}", st.text(max_size=6), st.text(max_size=6),
                                 st.sampled_from(["=", "==", " = ", ""]), st.text(max_size=10)))


@FUZZ
@given(st.lists(assignment, max_size=4))
def test_set_assignments(items):
    from harness.run import parse_sets

    loads_or_one_line(parse_sets, items)


@FUZZ
@given(st.one_of(st.text(max_size=30),
                 st.builds(lambda q, op, v: f"{q} {op} {v}", st.text(max_size=8),
                           st.sampled_from(["<=", ">=", "<", "="]), st.text(alphabet="0123456789.eE+-", max_size=8))))
def test_size_targets(text):
    from harness.studies.size import parse_target

    loads_or_one_line(parse_target, text)


@FUZZ
@given(st.one_of(st.text(max_size=40), st.builds(lambda l, r: f"{l}: {r}", st.text(max_size=6),
                                                 st.lists(assignment, max_size=3).map(" ".join))))
def test_compare_variants(text):
    from harness.studies.compare import parse_variant

    loads_or_one_line(parse_variant, text)


# -- sweep specs and scenarios (YAML and JSON files) ------------------------------------------------------------
SWEEP_KEYS = ["grid", "sample", "set", "outputs", "stop_time", "step", "master", "extrapolation", "system", "plot"]
SCENARIO_KEYS = ["name", "question", "kind", "stop_time", "parameters", "changes"]


def _write(data, suffix: str, raw: str | None) -> Path:
    import yaml

    path = _fresh(suffix)
    if raw is not None:
        path.write_text(raw)
    elif suffix == ".json":
        path.write_text(json.dumps(data, allow_nan=True))
    else:
        path.write_text(yaml.safe_dump(data, allow_unicode=True))
    return path


grid_like = st.fixed_dictionaries({"grid": st.dictionaries(st.text(max_size=6), values, max_size=3)},
                                  optional={"outputs": st.dictionaries(st.text(max_size=6), st.text(max_size=20),
                                                                       max_size=2),
                                            "set": st.dictionaries(st.text(max_size=6), st.text(max_size=20),
                                                                   max_size=2),
                                            "stop_time": scalars, "step": scalars,
                                            "sample": mapping_with(["method", "n", "seed", "ranges"]),
                                            "plot": mapping_with(["x", "y", "hue", "facet", "reduce", "xspan",
                                                                  "units"])})


@FUZZ
@given(st.one_of(mapping_with(SWEEP_KEYS), grid_like, values), st.sampled_from([".json", ".yaml"]),
       st.one_of(st.none(), st.text(max_size=60)))
def test_sweep_spec_files(data, suffix, raw):
    from harness.studies.sweep import read_spec

    loads_or_one_line(read_spec, _write(data, suffix, raw))


change = st.fixed_dictionaries({"time": scalars, "variable": scalars, "value": scalars},
                               optional={"ramp": scalars, "other": scalars})
scenario_like = st.fixed_dictionaries({"name": scalars, "changes": st.one_of(st.lists(change, max_size=3), values)},
                                      optional={"stop_time": scalars, "kind": scalars, "question": scalars,
                                                "parameters": values})


@FUZZ
@given(st.one_of(mapping_with(SCENARIO_KEYS), scenario_like, values), st.sampled_from([".json", ".yaml"]),
       st.one_of(st.none(), st.text(max_size=60)))
def test_scenario_files(data, suffix, raw):
    from harness.scenarios import read

    loads_or_one_line(read, _write(data, suffix, raw))


# -- input CSV ----------------------------------------------------------------------------------------------------
cell = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.integers(-5, 5).map(str),
                 st.sampled_from(["", "x", "true", "nan", "1e999", " "]))


@FUZZ
@given(st.lists(st.one_of(st.sampled_from(["time", "a.u", "b.y", ""]), st.text(max_size=5)), min_size=0,
                max_size=3),
       st.lists(st.lists(cell, max_size=4), max_size=5), st.one_of(st.none(), st.text(max_size=40)))
def test_input_csv(header, rows, raw):
    from harness.signals import read_table

    path = _fresh(".csv")
    path.write_text(raw if raw is not None else
                    "\n".join([",".join(header)] + [",".join(r) for r in rows]) + "\n")
    loads_or_one_line(read_table, path)


# -- SSP archives: a real export, mutated ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def exported_ssp(tmp_path_factory) -> Path:
    """An SSP exported by the toolkit: two Gain FMUs in a ring with parameters (an SSV) and a unit-converting
    connection."""
    from harness.model import Connection, Instance, System
    from harness.ssp import export_ssp

    system = System("fuzz", [Instance("a", "Gain", parameters={"k": 2.0}),
                             Instance("b", "Gain", parameters={"offset": 0.5})],
                    [Connection("a.integral", "b.u", factor=-0.5, unit_conversion=True),
                     Connection("b.y", "a.u")])
    return export_ssp(system, tmp_path_factory.mktemp("ssp") / "fuzz.ssp")


def _members(archive: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(archive) as z:
        return {n: z.read(n) for n in z.namelist()}


XML_BITS = ["", "<", ">", "/>", '"', "=", "&", "&amp;", "x", "-1", "nan", "1e999", "0", "a.b", "a", "b",
            "</ssd:Elements>", "<ssd:Connection/>", 'startElement="zz"', "ssv:", "ssd:", " ", "\x00"]


def mutate(text: str, edits) -> str:
    """Replace ``length`` characters at each relative ``position`` with ``new``."""
    for position, length, new in edits:
        i = int(position * len(text))
        text = text[:i] + new + text[i + length:]
    return text


edits = st.lists(st.tuples(st.floats(0, 1), st.integers(0, 12), st.one_of(st.sampled_from(XML_BITS),
                                                                          st.text(max_size=6))),
                 min_size=1, max_size=4)


@FUZZ
@given(edits, st.data())
def test_ssp_archives(exported_ssp, changes, data):
    from harness.ssp import load_ssp

    members = _members(exported_ssp)
    texts = sorted(n for n in members if n.endswith((".ssd", ".ssv", ".ssm")))
    target = data.draw(st.sampled_from(texts), label="member")
    members[target] = mutate(members[target].decode("utf-8"), changes).encode("utf-8", "surrogatepass")
    path = _fresh(".ssp")
    with zipfile.ZipFile(path, "w") as z:
        for n, b in members.items():
            z.writestr(n, b)
    loads_or_one_line(load_ssp, path)


@FUZZ
@given(st.one_of(st.binary(max_size=200), edits))
def test_ssd_files_and_broken_archives(exported_ssp, content):
    from harness.ssp import load_ssp

    if isinstance(content, bytes):   # anything as .ssp or .ssd
        for suffix in (".ssp", ".ssd"):
            path = _fresh(suffix)
            path.write_bytes(content)
            loads_or_one_line(load_ssp, path)
        return
    ssd = _members(exported_ssp)["SystemStructure.ssd"].decode()   # a bare .ssd beside nothing
    path = _fresh(".ssd")
    path.write_text(mutate(ssd, content))
    loads_or_one_line(load_ssp, path)


@pytest.fixture(scope="module")
def gain_fmu() -> Path:
    from harness.model import resolve_fmu

    return resolve_fmu("Gain")


@FUZZ
@given(edits)
def test_fmu_model_descriptions(gain_fmu, changes):
    """An FMU whose modelDescription.xml is mutated, run alone (``run X.fmu``): loaded, its description checked."""
    from harness.run import load

    members = _members(gain_fmu)
    members["modelDescription.xml"] = mutate(members["modelDescription.xml"].decode(), changes).encode(
        "utf-8", "surrogatepass")
    path = _fresh(".fmu")
    with zipfile.ZipFile(path, "w") as z:
        for n, b in members.items():
            z.writestr(n, b)
    loads_or_one_line(load, path)


@pytest.mark.slow
def test_fuzz_readers_many():
    """The slow suite's campaign: every reader above with SLOW_EXAMPLES cases."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), PRESSDRIVE_FUZZ_EXAMPLES=str(SLOW_EXAMPLES))
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", __file__,
                           "-k", "not many"], cwd=ROOT, env=env, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout[-3000:]
