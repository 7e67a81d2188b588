"""What an SSP connection carries besides a plain value (issues 33 and 34).

* Value mappings (issue 33): SSP 1.0's ssc:IntegerMappingTransformation (Integer and Enumeration values) and
  ssc:BooleanMappingTransformation on an ssd:Connection (SystemStructureCommon.xsd, GTransformationChoice:
  "the transformation to be applied to a value prior to its use in a connection or parameter mapping"; each
  ssc:MapEntry gives the target value of one source value).  No peer applies them: OMSimulator 3.0 drops a
  connection's transformations, libcosim 0.11 and Ecos 0.7.2 read only ssc:LinearTransformation.  So the
  runs are checked against that definition: every target value is the table's entry for its source's value
  at the same communication point (or the one before, for a master that passes discrete values sampled).
  The FMUs are the Modelica Reference-FMUs Stair and Feedthrough (tests/reference_fmus, built with cmake).
"""
from __future__ import annotations

import shutil
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest

from harness import simulate
from harness.errors import SystemError_
from harness.model import Connection, Experiment, Instance, System
from harness.ssp import export_ssp, load_ssp

FMU = "application/x-fmu-sharedlibrary"
HEAD = ('<?xml version="1.0" encoding="UTF-8"?>\n<ssd:SystemStructureDescription version="1.0" name="m"'
        ' xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"'
        ' xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"'
        ' xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues">')


@pytest.fixture(scope="module")
def ref2(tmp_path_factory) -> dict[str, Path]:
    from test_fmi_content import _build_reference_fmus   # the one build of tests/reference_fmus (or skip)

    return _build_reference_fmus(tmp_path_factory.mktemp("reference_fmus_2"), 2)


def quiet(system, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(system, **kw)


def table_xml(kind: str, table: dict) -> str:
    text = (lambda x: "true" if x else "false") if kind == "Boolean" else str
    entries = "".join(f'<ssc:MapEntry source="{text(k)}" target="{text(v)}"/>' for k, v in table.items())
    return f"<ssc:{kind}MappingTransformation>{entries}</ssc:{kind}MappingTransformation>"


def mapped_ssp(folder: Path, ref2, stop: float) -> Path:
    """Stair's counter (1, 2, 3... one per second) into Feedthrough's Enumeration input (type Option: items 1
    and 2) through {1: 2, 2: 1, 3: 2} and into its Int32 input through {1: 10, 2: 20, 3: 30}; Feedthrough's
    Boolean output (its input bound true) into a second Feedthrough's Boolean input through {true: false,
    false: true}.  Without the tables the counter's 3 is no item of Option (the FMU refuses it)."""
    for m in ("Stair", "Feedthrough"):
        shutil.copy(ref2[m], folder / f"{m}.fmu")
    on = ('<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues><ssv:ParameterSet version="1.0" '
          'name="p"><ssv:Parameters><ssv:Parameter name="Boolean_input"><ssv:Boolean value="true"/></ssv:Parameter>'
          '</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>')
    comps = (f'<ssd:Component name="stair" type="{FMU}" source="Stair.fmu"/>'
             f'<ssd:Component name="ft" type="{FMU}" source="Feedthrough.fmu">{on}</ssd:Component>'
             f'<ssd:Component name="ft2" type="{FMU}" source="Feedthrough.fmu"/>')

    def conn(a, ac, b, bc, inner):
        return (f'<ssd:Connection startElement="{a}" startConnector="{ac}" endElement="{b}" endConnector="{bc}">'
                f'{inner}</ssd:Connection>')

    conns = (conn("stair", "counter", "ft", "Enumeration_input", table_xml("Integer", {1: 2, 2: 1, 3: 2}))
             + conn("stair", "counter", "ft", "Int32_input", table_xml("Integer", {1: 10, 2: 20, 3: 30}))
             + conn("ft", "Boolean_output", "ft2", "Boolean_input", table_xml("Boolean", {True: False, False: True})))
    (folder / "SystemStructure.ssd").write_text(
        HEAD + f'<ssd:System name="m"><ssd:Elements>{comps}</ssd:Elements><ssd:Connections>{conns}'
        f'</ssd:Connections></ssd:System><ssd:DefaultExperiment startTime="0" stopTime="{stop}"/>'
        '</ssd:SystemStructureDescription>')
    ssp = folder / "mapped.ssp"
    with zipfile.ZipFile(ssp, "w") as z:
        for f in ("SystemStructure.ssd", "Stair.fmu", "Feedthrough.fmu"):
            z.write(folder / f, f)
    return ssp


def _as_defined(df, source: str, target: str, table: dict) -> bool:
    """Every value of ``target`` is the table's entry for ``source`` at the same point, or (a master that
    passes discrete values at the step start) at the point before."""
    src, dst = df[source].to_numpy(), df[target].to_numpy()
    want = np.array([table[v] for v in src])
    return bool((dst == want).all() or (dst[1:] == want[:-1]).all())


@pytest.mark.parametrize("master", ["jacobi", "jacobi-sampled", "gauss-seidel"])
def test_integer_and_boolean_mapping_on_connections_as_ssp_defines_them(ref2, tmp_path, master):
    system = load_ssp(mapped_ssp(tmp_path, ref2, 2.5))
    df = quiet(system, step=0.01, master=master, on_error="raise")
    assert df.attrs["complete"] and set(df["stair.counter"]) == {1, 2, 3}
    assert _as_defined(df, "stair.counter", "ft.Enumeration_output", {1: 2, 2: 1, 3: 2})
    assert _as_defined(df, "stair.counter", "ft.Int32_output", {1: 10, 2: 20, 3: 30})
    assert set(df["ft.Enumeration_output"]) == {1, 2} and set(df["ft.Int32_output"]) >= {10, 20, 30}
    assert df["ft.Boolean_output"].all() and not df["ft2.Boolean_output"].iloc[1:].any()


def test_a_value_without_an_entry_stops_the_run_naming_connection_value_and_time(ref2, tmp_path):
    """At 3 s the counter reaches 4, which neither table maps: the run stops there, marked, and keeps the
    points before (the mapping does not say what 4 becomes)."""
    df = quiet(load_ssp(mapped_ssp(tmp_path, ref2, 4.5)), step=0.01, master="jacobi")
    assert not df.attrs["complete"]
    error = df.attrs["error"]
    assert "connection stair.counter -> ft." in error and "has no entry for the value 4" in error
    assert "at t = 3 s" in error and "entries for [1, 2, 3]" in error and "\n" not in error
    assert df.index[-1] == pytest.approx(2.99) and set(df["stair.counter"]) == {1, 2, 3}


def test_mapping_round_trips_through_export_and_composes_through_a_system_connector(ref2, tmp_path):
    system = load_ssp(mapped_ssp(tmp_path, ref2, 1.0))
    tables = {c.target: c.mapping for c in system.connections}
    assert tables == {"ft.Enumeration_input": {1: 2, 2: 1, 3: 2}, "ft.Int32_input": {1: 10, 2: 20, 3: 30},
                      "ft2.Boolean_input": {1: 0, 0: 1}}
    system.experiment.step = 0.01
    back = load_ssp(export_ssp(system, tmp_path / "out" / "again.ssp"))
    assert {c.target: c.mapping for c in back.connections} == tables
    assert quiet(back, on_error="raise").equals(quiet(system, on_error="raise"))
    # a nested system: counter -> Sub.x through {1: 2, 2: 1}, Sub.x -> ft.Enumeration_input through {2: 1, 1: 1}
    inner = (f'<ssd:System name="Sub"><ssd:Connectors><ssd:Connector name="x" kind="input"><ssc:Integer/>'
             f'</ssd:Connector></ssd:Connectors><ssd:Elements><ssd:Component name="ft" type="{FMU}" '
             'source="Feedthrough.fmu"/></ssd:Elements><ssd:Connections><ssd:Connection startConnector="x" '
             f'endElement="ft" endConnector="Enumeration_input">{table_xml("Integer", {2: 1, 1: 1})}'
             '</ssd:Connection></ssd:Connections></ssd:System>')
    (tmp_path / "nested.ssd").write_text(
        HEAD + f'<ssd:System name="m"><ssd:Elements><ssd:Component name="stair" type="{FMU}" source="Stair.fmu"/>'
        f'{inner}</ssd:Elements><ssd:Connections><ssd:Connection startElement="stair" startConnector="counter" '
        f'endElement="Sub" endConnector="x">{table_xml("Integer", {1: 2, 2: 1})}</ssd:Connection>'
        '</ssd:Connections></ssd:System></ssd:SystemStructureDescription>')
    [c] = load_ssp(tmp_path / "nested.ssd").connections
    assert (c.source, c.target, c.mapping) == ("stair.counter", "Sub/ft.Enumeration_input", {1: 1, 2: 1})


@pytest.mark.parametrize("connection, message", [
    (Connection("ft.Float64_continuous_output", "ft2.Float64_continuous_input", mapping={1: 2}),
     "a value mapping applies to Integer, Enumeration and Boolean connections, not to Real"),
    (Connection("ft.Int32_output", "ft2.Int32_input", mapping={1: 2.5}),
     "mapping entry 1 -> 2.5: Integer connections map integers to integers"),
    (Connection("ft.Boolean_output", "ft2.Boolean_input", mapping={True: 2}),
     "mapping entry True -> 2: Boolean connections map booleans to booleans"),
    (Connection("ft.Int32_output", "ft2.Int32_input", mapping={}), "must be a non-empty dict"),
])
def test_a_mapping_that_does_not_fit_the_connection_is_refused_in_one_line(ref2, connection, message):
    system = System("m", [Instance("ft", str(ref2["Feedthrough"])), Instance("ft2", str(ref2["Feedthrough"]))],
                    [connection], experiment=Experiment(stop_time=0.1, step=0.01))
    with pytest.raises(SystemError_) as info:
        quiet(system, on_error="raise")
    assert message in str(info.value) and "\n" not in str(info.value)
    assert f"connection {connection.source} -> {connection.target}" in str(info.value)


def test_a_bad_map_entry_in_the_ssd_is_named(ref2, tmp_path):
    ssp = mapped_ssp(tmp_path, ref2, 1.0)
    text = (tmp_path / "SystemStructure.ssd").read_text().replace('source="3" target="30"', 'source="3" target="x"')
    (tmp_path / "SystemStructure.ssd").write_text(text)
    with pytest.raises(SystemError_) as info:
        load_ssp(tmp_path)
    assert ("connection stair.counter -> ft.Int32_input: ssc:IntegerMappingTransformation has an ssc:MapEntry "
            "that is not a pair of integers") in str(info.value)
    assert ssp.exists()
