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
def ref2() -> dict[str, Path]:
    from reference_builds import reference_fmus   # the one build of tests/reference_fmus

    return reference_fmus(2)


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


def with_connection(folder: Path, connection: str) -> Path:
    """The SSD of :func:`mapped_ssp` in ``folder`` with one more connection; returns the folder (an SSP)."""
    ssd = folder / "SystemStructure.ssd"
    ssd.write_text(ssd.read_text().replace("</ssd:Connections>", connection + "</ssd:Connections>"))
    return folder


SWAP = ('<ssd:Connection startElement="ft" startConnector="Enumeration_output" endElement="ft2" '
        'endConnector="Enumeration_input"><ssc:EnumerationMappingTransformation>'
        '<ssc:MapEntry source="Option 1" target="Option 2"/><ssc:MapEntry source="Option 2" target="Option 1"/>'
        '</ssc:EnumerationMappingTransformation></ssd:Connection>')


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_enumeration_mapping_by_item_names(ref2, tmp_path, master):
    """ssc:EnumerationMappingTransformation maps by item names (SSP 1.0): Option 1 -> Option 2 and back,
    looked up in Feedthrough's type Option (items 1 and 2) at both ends."""
    mapped_ssp(tmp_path, ref2, 2.5)
    system = load_ssp(with_connection(tmp_path, SWAP))
    assert [c.mapping for c in system.connections if c.target == "ft2.Enumeration_input"] == [{1: 2, 2: 1}]
    df = quiet(system, step=0.01, master=master, on_error="raise")
    assert _as_defined(df, "ft.Enumeration_output", "ft2.Enumeration_output", {1: 2, 2: 1})
    assert set(df["ft2.Enumeration_output"].iloc[1:]) == {1, 2}


@pytest.mark.parametrize("change, message", [
    (('source="Option 2" target="Option 1"', 'source="Option 3" target="Option 1"'),
     "ssc:EnumerationMappingTransformation maps 'Option 3', which is no item of ft.Enumeration_output's type "
     "(items: Option 1, Option 2)"),
    (('startConnector="Enumeration_output"', 'startConnector="Int32_output"'),
     "ssc:EnumerationMappingTransformation does not apply to Integer values"),
])
def test_enumeration_mapping_names_a_wrong_item_or_type(ref2, tmp_path, change, message):
    mapped_ssp(tmp_path, ref2, 1.0)
    with pytest.raises(SystemError_) as info:
        load_ssp(with_connection(tmp_path, SWAP.replace(*change)))
    assert message in str(info.value) and "\n" not in str(info.value) and "SystemStructure.ssd" in str(info.value)


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


# ------------------------------------------------------------------------------------------------ terminals (34)
# SSP 1.0 has no terminals: an ssd:Connector is one variable of its component (SystemStructureDescription.xsd),
# and the standard predates FMI 3.0's terminalsAndIcons.xml.  So the export keeps listing a bond's three member
# connections (every SSP host reads those; OMSimulator 3.0 refuses a connector that is no variable), and the
# import reads the FMUs' terminals: a hand-written .ssd may connect two flanges by their terminal names, and
# plain member connections that make up a flange pair become a bond even without this toolkit's annotation.
@pytest.fixture(scope="module")
def pair3(fmu3_dir) -> Path:
    """Inertia and SpringInertia (among the others) as FMI 3.0 FMUs with their flange terminals."""
    return fmu3_dir


def two_inertia_on(folder: Path) -> System:

    from harness import load

    s = load("two_inertia")
    return s.on_fmus(folder)


def without_annotation(ssp: Path, out: Path) -> Path:
    """``ssp`` with the toolkit's pd: annotation (bonds, experiment) removed, as another tool saving it would."""
    import re

    with zipfile.ZipFile(ssp) as z:
        files = {n: z.read(n) for n in z.namelist()}
    text = files["SystemStructure.ssd"].decode()
    files["SystemStructure.ssd"] = re.sub(r'<ssc:Annotation type="org.pressdrive">.*?</ssc:Annotation>', "", text,
                                          flags=re.S).encode()
    assert b"pd:Bond" not in files["SystemStructure.ssd"]
    with zipfile.ZipFile(out, "w") as z:
        for n, b in files.items():
            z.writestr(n, b)
    return out


def terminal_ssd(folder: Path, pair3: Path, connections: str, params: bool = True) -> Path:
    for m in ("Inertia", "SpringInertia"):
        shutil.copy(pair3 / f"{m}.fmu", folder / f"{m}.fmu")
    values = {"a": {"J": 0.01, "w0": 1.0}, "b": {"J": 0.02, "c": 100.0, "d": 0.0}}

    def bound(name):
        if not params:
            return ""
        body = "".join(f'<ssv:Parameter name="{k}"><ssv:Real value="{v!r}"/></ssv:Parameter>'
                       for k, v in values[name].items())
        return ('<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues><ssv:ParameterSet version="1.0" '
                f'name="p"><ssv:Parameters>{body}</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues>'
                '</ssd:ParameterBinding></ssd:ParameterBindings>')

    (folder / "t.ssd").write_text(
        HEAD + f'<ssd:System name="two_inertia"><ssd:Elements>'
        f'<ssd:Component name="a" type="{FMU}" source="Inertia.fmu">{bound("a")}</ssd:Component>'
        f'<ssd:Component name="b" type="{FMU}" source="SpringInertia.fmu">{bound("b")}</ssd:Component>'
        f'</ssd:Elements><ssd:Connections>{connections}</ssd:Connections></ssd:System>'
        '<ssd:DefaultExperiment startTime="0" stopTime="0.2"/></ssd:SystemStructureDescription>')
    return folder / "t.ssd"


def flange(a, ac, b, bc):
    return f'<ssd:Connection startElement="{a}" startConnector="{ac}" endElement="{b}" endConnector="{bc}"/>'


@pytest.mark.parametrize("connection", [flange("a", "flange", "b", "drive"), flange("b", "drive", "a", "flange")])
def test_a_connection_between_two_flange_terminals_is_the_bond(pair3, tmp_path, connection):
    """``a.flange -> b.drive`` (either way round: the members' causalities say which side drives) is the
    power bond of two_inertia, and runs exactly as two_inertia declared in Python on the same FMUs."""
    system = load_ssp(terminal_ssd(tmp_path, pair3, connection))
    assert system.connections == [] and [(b.motion_out, b.motion_in, b.translational) for b in system.bonds] == [
        ("a.flange", "b.drive", False)]
    ref = two_inertia_on(pair3)
    kw = dict(stop_time=0.2, step=1e-3, master="jacobian", extrapolation=1, on_error="raise")
    assert quiet(system, **kw).equals(quiet(ref, **kw))


def test_member_connections_of_two_flange_terminals_become_the_bond_without_the_annotation(pair3, fmu_dir,
                                                                                           tmp_path):
    """The exported two_inertia of FMI 3.0 FMUs with the toolkit's pd: annotation removed (as another tool
    saving the SSP would drop it): the three member connections are recognised from the FMUs' terminals.  The
    FMI 2.0 builds have no terminals: there they stay three plain connections."""
    back = load_ssp(without_annotation(export_ssp(two_inertia_on(pair3), tmp_path / "two3.ssp"), tmp_path / "b3.ssp"))
    assert back.connections == [] and [(b.motion_out, b.motion_in) for b in back.bonds] == [("a.flange", "b.drive")]
    kw = dict(stop_time=0.2, step=1e-3, master="jacobian", extrapolation=1, on_error="raise")
    assert quiet(back, **kw).equals(quiet(two_inertia_on(pair3), **kw))
    back2 = load_ssp(without_annotation(export_ssp(two_inertia_on(fmu_dir), tmp_path / "two2.ssp"), tmp_path / "b2.ssp"))
    assert back2.bonds == [] and len(back2.connections) == 3


@pytest.fixture(scope="module")
def all3(fmu3_dir) -> Path:
    """Every component as an FMI 3.0 FMU."""
    return fmu3_dir


@pytest.mark.parametrize("name", ["feeder_gto52", "bed_drive", "spine_knife", "proof_press"])
def test_every_drive_of_fmi3_fmus_keeps_its_bonds_through_an_ssp_without_the_annotation(all3, tmp_path, name):
    """Each shipped drive (rotational and translational flanges) exported from its FMI 3.0 FMUs, the pd:
    annotation removed: the import finds every declared bond from the FMUs' terminals, and no plain
    connection is left over (measured: 3, 6, 3, 3 bonds)."""

    from harness import load

    s = load(name)
    s3 = s.on_fmus(all3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = load_ssp(without_annotation(export_ssp(s3, tmp_path / "d.ssp"), tmp_path / "bare.ssp"))
    assert sorted((b.motion_out, b.motion_in) for b in back.bonds) == sorted(
        (b.motion_out, b.motion_in) for b in s.bonds)
    assert len(back.bonds) >= 3 and back.connections == s.connections == []


@pytest.mark.parametrize("connection, message", [
    (flange("a", "flange", "b", "J"), "connects a terminal to a variable or system connector"),
    (flange("a", "flange", "a", "flange"),
     "member 'phi' is a.flange.phi (output) and a.flange.phi (output): a connected member needs an output"),
])
def test_terminal_connections_that_cannot_be_made_are_refused_in_one_line(pair3, tmp_path, connection, message):
    with pytest.raises(SystemError_) as info:
        load_ssp(terminal_ssd(tmp_path, pair3, connection))
    assert message in str(info.value) and "\n" not in str(info.value) and "t.ssd" in str(info.value)


def test_terminals_of_different_kinds_are_refused(pair3, tmp_path):
    """A rotational flange cannot connect to a translational one (FMI 3.0: one terminalKind)."""
    path = terminal_ssd(tmp_path, pair3, flange("a", "flange", "b", "drive"))
    fmu = tmp_path / "SpringInertia.fmu"
    with zipfile.ZipFile(fmu) as z:
        files = {n: z.read(n) for n in z.namelist()}
    files["terminalsAndIcons/terminalsAndIcons.xml"] = files["terminalsAndIcons/terminalsAndIcons.xml"].replace(
        b"org.pressdrive.RotationalFlange", b"org.pressdrive.TranslationalFlange")
    with zipfile.ZipFile(fmu, "w") as z:
        for n, b in files.items():
            z.writestr(n, b)
    with pytest.raises(SystemError_, match="terminalKind 'org.pressdrive.RotationalFlange' and "
                                           "'org.pressdrive.TranslationalFlange' differ"):
        load_ssp(path)


@pytest.mark.interop
def test_omsimulator_takes_the_member_connections_and_not_terminal_names(pair3, tmp_path):
    """Why the export lists members: OMSimulator 3.0 (an SSP host nobody here wrote) refuses a connection that
    names a terminal, as SSP 1.0 lets it (a connector is a variable); the same drive's export with member
    connections it runs (tests/test_fmi3_export.py compares its numbers)."""
    from test_fmi3_hosts import _omsimulator_missing, _run_script

    reason = _omsimulator_missing()
    if reason:
        pytest.skip(reason)
    terminal_ssd(tmp_path, pair3, flange("a", "flange", "b", "drive"))
    archives = {"terminals": tmp_path / "terminals.ssp", "members": export_ssp(two_inertia_on(pair3),
                                                                                tmp_path / "members.ssp")}
    with zipfile.ZipFile(archives["terminals"], "w") as z:
        z.write(tmp_path / "t.ssd", "SystemStructure.ssd")
        for m in ("Inertia", "SpringInertia"):
            z.write(tmp_path / f"{m}.fmu", f"{m}.fmu")
    out = _run_script(f"""
        from OMSimulator import SSP
        for kind, path in {dict((k, str(v)) for k, v in archives.items())!r}.items():
            try:
                SSP(path)
                print(kind, "loads")
            except Exception as e:
                print(kind, "refused:", " ".join(str(e).split()))
    """)
    assert "members loads" in out
    assert "terminals refused: Connector 'flange' not found in element 'a'" in out


def test_a_connection_with_its_diagram_geometry_loads(pair3, tmp_path):
    """ssd:ConnectionGeometry (the connection's points in a diagram, which OMSimulator writes) changes nothing
    the simulation reads; it used to be refused as 'not supported'."""
    geometry = '<ssd:ConnectionGeometry pointsX="1 2" pointsY="3 4"/>'
    text = flange("a", "flange", "b", "drive").replace("/>", f">{geometry}</ssd:Connection>")
    system = load_ssp(terminal_ssd(tmp_path, pair3, text))
    assert [(b.motion_out, b.motion_in) for b in system.bonds] == [("a.flange", "b.drive")]
