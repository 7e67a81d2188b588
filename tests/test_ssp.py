"""SSP 1.0 export/import (issue 6, part 2): round trip, other tools (libcosim, Ecos), SSP written by others.

* Round trip: export -> load_ssp -> simulate reproduces the original run EXACTLY (DataFrame.equals).
* Peers: the exported archive runs in libcosim and in Ecos; with ``master="jacobi-sampled"`` (the algorithm
  those tools use) the results agree with the harness.  libcosim: every column to 1e-9 of its largest
  magnitude (the only difference is libcosim's integer-nanosecond time, benchmarks.peers docstring; measured
  <= 4e-11).  Ecos: the dynamics are the same (every output WITHOUT direct feed-through agrees to 1e-9,
  measured bit-identical or ~1e-13), but Ecos reads the variables AFTER it has passed the new outputs on to
  the inputs, so an output WITH direct feed-through (ModelStructure dependencies, e.g. a spring torque) is
  reported refreshed with the inputs of t_k+1 (what ``jacobi`` would record), not the value sampled right
  after fmi2DoStep that ``jacobi-sampled`` and libcosim record: those columns are not compared.
  bed_drive needs a short step for the sampled algorithm (2e-4 s, its ``jacobi`` default, blows up within
  0.05 s in all three tools alike; 1e-4 s is stable).
* Import of hand-written SSDs: every supported feature, and a one-line error naming the element/file for
  each unsupported one.
"""
from __future__ import annotations

import shutil
import warnings
import zipfile

import numpy as np
import pytest

import harness.fmi.fmu
from harness import load, simulate
from benchmarks import peers
from harness.errors import SystemError_
from harness.model import Connection, Instance, System, SystemWarning, model_description
from harness.ssp import export_ssp, load_ssp

SYSTEMS = ("two_inertia", "feeder_gto52", "bed_drive", "spine_knife", "proof_press")
# (stop time, step) per system for the cross-tool check: sampled Jacobi stable, a few hundred steps
PEER_RUNS = {"two_inertia": (0.1, 1e-3), "feeder_gto52": (0.02, 1e-4), "bed_drive": (0.02, 1e-4),
             "spine_knife": (0.01, 5e-5), "proof_press": (0.04, 2e-4)}
RTOL = 1e-9
AVAILABLE = peers.available()



def quiet_simulate(system, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SystemWarning)
        df = simulate(system, on_error="raise", **kw)
    assert df.attrs["complete"]
    return df


@pytest.fixture(scope="module")
def archives(fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("ssp")
    return {name: export_ssp(load(name).on_fmus(fmu_dir), out / f"{name}.ssp") for name in SYSTEMS}


# ------------------------------------------------------------------------------------------------ round trip
@pytest.mark.parametrize("name", SYSTEMS)
def test_round_trip_reproduces_the_run_exactly(fmu_dir, archives, name):
    original = load(name).on_fmus(fmu_dir)
    back = load_ssp(archives[name])
    assert [i.name for i in back.instances] == [i.name for i in original.instances]
    assert [i.parameters for i in back.instances] == [i.parameters for i in original.instances]
    # bond kinds are resolved from the FMUs on export (None -> False/True), ports must be the same
    assert [(b.motion_out, b.motion_in) for b in back.bonds] == [(b.motion_out, b.motion_in) for b in original.bonds]
    assert back.experiment == original.experiment and back.connections == original.connections
    stop = 20 * original.experiment.step
    a = quiet_simulate(original, stop_time=stop)
    b = quiet_simulate(back, stop_time=stop)
    assert a.equals(b)


# ------------------------------------------------------------------------------------------------ peers
def _feedthrough(system) -> set[str]:
    out = set()
    for inst in system.instances:
        md = model_description(inst.fmu)
        out.update(f"{inst.name}.{o.variable.name}" for o in md.outputs if o.dependencies)
    return out


@pytest.fixture
def peer_ok(monkeypatch):
    # benchmarks.peers._ssp_fmus imports harness.fmi.fmu._TMP_DIRS, which harness.fmi.fmu no longer defines (reported):
    # provide it for the test so that a .ssp ARCHIVE can be handed to the peers.
    monkeypatch.setattr(harness.fmi.fmu, "_TMP_DIRS", [], raising=False)


@pytest.mark.interop
@pytest.mark.parametrize("tool", ["libcosim", "ecos"])
@pytest.mark.parametrize("name", SYSTEMS)
def test_exported_ssp_runs_in_peer_like_jacobi_sampled(fmu_dir, archives, peer_ok, name, tool):
    if AVAILABLE[tool]:
        pytest.skip(AVAILABLE[tool])
    stop, step = PEER_RUNS[name]
    system = load(name).on_fmus(fmu_dir)
    ref = quiet_simulate(system, stop_time=stop, step=step, master="jacobi-sampled", extrapolation=0)  # peers hold
    cols = list(ref.columns)
    if tool == "libcosim":
        df = peers.run_ssp_libcosim(archives[name], stop, step, cols)
    else:
        df = peers.run_ssp_ecos(archives[name], stop, step, cols, parameter_set="default")
        cols = [c for c in cols if c not in _feedthrough(system)]
    assert len(df) == len(ref)
    np.testing.assert_allclose(df.index.to_numpy(), ref.index.to_numpy(), rtol=1e-12, atol=1e-15)
    # a column of a drive at rest is held absolutely (to 1e-9 SI, as tests/test_hosts.py floors its ranges):
    # spine_knife before its cut carries round-off only (shafts ~1e-11 N.m, the motor ~2e-9 W), which libcosim's
    # time doubles (an ulp off the grid) change entirely; every moving column agrees to 7e-14
    scale = np.maximum(ref[cols].abs().max().to_numpy(), 1.0)
    err = (df[cols] - ref[cols]).abs().max().to_numpy() / scale
    worst = cols[int(np.argmax(err))]
    assert err.max() <= RTOL, f"{tool} {name}: {worst} differs by {err.max():.3g} of its magnitude"
    assert len(cols) >= 2                      # two_inertia under Ecos: a.flange.phi, a.flange.w


# ------------------------------------------------------------------------------------------------ hand-written SSD
SSD_HEAD = ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<ssd:SystemStructureDescription version="1.0" name="hand"'
            ' xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"'
            ' xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"'
            ' xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"'
            ' xmlns:ssm="http://ssp-standard.org/SSP1/SystemStructureParameterMapping"'
            ' xmlns:osp="http://opensimulationplatform.com/SSP/OSPAnnotations">\n')
FMU = "application/x-fmu-sharedlibrary"


def ssv(params: dict, name="p") -> str:
    body = "".join(f'<ssv:Parameter name="{k}"><ssv:Real value="{v!r}"/></ssv:Parameter>' for k, v in params.items())
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<ssv:ParameterSet version="1.0" name="' + name + '"'
            ' xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues">'
            f'<ssv:Parameters>{body}</ssv:Parameters></ssv:ParameterSet>')


def ssd(components: str, connections: str = "", system_extra: str = "", elements_extra: str = "",
        experiment: str = "") -> str:
    return (SSD_HEAD + f'<ssd:System name="hand">{system_extra}<ssd:Elements>{components}{elements_extra}'
            f'</ssd:Elements><ssd:Connections>{connections}</ssd:Connections></ssd:System>{experiment}'
            '</ssd:SystemStructureDescription>')


def comp(name, fmu, inner=""):
    return f'<ssd:Component name="{name}" type="{FMU}" source="{fmu}">{inner}</ssd:Component>'


def conn(a, ac, b, bc, inner=""):
    return f'<ssd:Connection startElement="{a}" startConnector="{ac}" endElement="{b}" endConnector="{bc}">{inner}</ssd:Connection>'


BOND = (conn("a", "flange.phi", "b", "drive.phi") + conn("a", "flange.w", "b", "drive.w")
        + conn("b", "drive.tau", "a", "flange.tau"))


@pytest.fixture
def folder(fmu_dir, tmp_path):
    (tmp_path / "resources").mkdir()
    for m in ("Inertia", "SpringInertia", "Gain"):
        shutil.copy(fmu_dir / f"{m}.fmu", tmp_path / "resources" / f"{m}.fmu")
    return tmp_path


def test_hand_written_ssd_with_every_supported_feature(folder):
    (folder / "a.ssv").write_text(ssv({"J": 0.01, "w0": 1.5}))
    (folder / "sys.ssv").write_text(ssv({"J": 0.02, "c": 80.0}))          # bare names + prefix "b."
    (folder / "g.ssv").write_text(ssv({"b.d": 0.1}))                       # system-level Component.param
    components = (
        comp("a", "resources/Inertia.fmu",
             '<ssd:ParameterBindings><ssd:ParameterBinding source="a.ssv"/></ssd:ParameterBindings>')
        + comp("b", "resources/SpringInertia.fmu")
        + comp("g", "resources/Gain.fmu", '<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>'
               '<ssv:ParameterSet version="1.0" name="x"><ssv:Parameters><ssv:Parameter name="k">'
               '<ssv:Real value="2.0"/></ssv:Parameter></ssv:Parameters></ssv:ParameterSet>'
               '</ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>'))
    bindings = ('<ssd:ParameterBindings><ssd:ParameterBinding source="sys.ssv" prefix="b."/>'
                '<ssd:ParameterBinding source="g.ssv"/></ssd:ParameterBindings>')
    connections = BOND + conn("a", "flange.w", "g", "u",
                              '<ssc:LinearTransformation factor="3.0" offset="0.5"/>')
    experiment = ('<ssd:DefaultExperiment startTime="0" stopTime="0.05"><ssd:Annotations>'
                  '<ssc:Annotation type="com.opensimulationplatform"><osp:Algorithm>'
                  '<osp:FixedStepAlgorithm baseStepSize="0.001"/></osp:Algorithm></ssc:Annotation>'
                  '</ssd:Annotations></ssd:DefaultExperiment>')
    text = ssd(components, connections, system_extra=bindings, experiment=experiment)
    # the unit of g.u is "1", a.flange.w is rad/s: the hand-written SSD does not say it converts, so mark it
    (folder / "hand.ssd").write_text(text)
    s = load_ssp(folder / "hand.ssd")
    assert s.instance("a").parameters == {"J": 0.01, "w0": 1.5}
    assert s.instance("b").parameters == {"J": 0.02, "c": 80.0, "d": 0.1}    # prefix PREPENDED (SSP 1.0)
    assert s.instance("g").parameters == {"k": 2.0}
    assert (s.experiment.stop_time, s.experiment.step) == (0.05, 0.001)
    lin = [c for c in s.connections if c.target == "g.u"][0]
    assert (lin.factor, lin.offset) == (3.0, 0.5)
    lin.unit_conversion = True
    # the same archive as an .ssp zip runs and gives what the hand-built system gives
    ssp = folder / "hand.ssp"
    with zipfile.ZipFile(ssp, "w") as z:
        z.write(folder / "hand.ssd", "SystemStructure.ssd")
        for f in ("a.ssv", "sys.ssv", "g.ssv", *(f"resources/{m}.fmu" for m in ("Inertia", "SpringInertia", "Gain"))):
            z.write(folder / f, f)
    z_sys = load_ssp(ssp)
    [c for c in z_sys.connections if c.target == "g.u"][0].unit_conversion = True
    df = quiet_simulate(z_sys, outputs=["a.flange.w", "g.u", "g.y"])
    assert len(df) == 51 and df["a.flange.w"].iloc[0] == 1.5
    np.testing.assert_allclose(df["g.u"], 3.0 * df["a.flange.w"] + 0.5, rtol=1e-14)
    np.testing.assert_allclose(df["g.y"], 2.0 * df["g.u"], rtol=1e-14)
    assert quiet_simulate(s, outputs=["a.flange.w", "g.u", "g.y"]).equals(df)


def test_source_base_component_reads_the_ssv_inside_the_fmu(folder):
    fmu = folder / "resources" / "Inertia.fmu"
    with zipfile.ZipFile(fmu, "a") as z:
        z.writestr("resources/start.ssv", ssv({"J": 0.03, "w0": 2.5}))
    inner = ('<ssd:ParameterBindings><ssd:ParameterBinding source="resources/start.ssv" sourceBase="component"/>'
             '</ssd:ParameterBindings>')
    (folder / "c.ssd").write_text(ssd(comp("a", "resources/Inertia.fmu", inner) + comp("b", "resources/SpringInertia.fmu"), BOND))
    assert load_ssp(folder / "c.ssd").instance("a").parameters == {"J": 0.03, "w0": 2.5}
    (folder / "d.ssd").write_text(ssd(comp("a", "resources/Inertia.fmu", inner.replace("start.ssv", "none.ssv"))))
    with pytest.raises(SystemError_, match=r"source resources/none.ssv \(sourceBase='component'\) not found in Inertia.fmu"):
        load_ssp(folder / "d.ssd")
    (folder / "e.ssd").write_text(ssd(comp("a", "resources/Inertia.fmu"), system_extra=inner))
    with pytest.raises(SystemError_, match="sourceBase='component' is only allowed on an ssd:Component"):
        load_ssp(folder / "e.ssd")


A = comp("a", "resources/Inertia.fmu")
B = comp("b", "resources/SpringInertia.fmu")


@pytest.mark.parametrize("text,message", [
    (ssd(A + B, BOND + conn("inner", "x", "a", "w0"), elements_extra='<ssd:System name="inner"/>'),
     "system connector 'x' of system 'inner' drives a.w0 but nothing drives it"),
    (ssd(A, system_extra='<ssd:SignalDictionaries><ssd:SignalDictionary name="sd"/></ssd:SignalDictionaries>'),
     "ssd:SignalDictionaries in system 'hand' are not supported"),
    (ssd(comp("a", "resources/Inertia.fmu", '<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>'
              '<ssv:ParameterSet version="1.0" name="x"><ssv:Parameters><ssv:Parameter name="k">'
              '<ssv:Integer value="2"/></ssv:Parameter></ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues>'
              '<ssd:ParameterMapping><ssm:ParameterMapping version="1.0"><ssm:MappingEntry source="k" target="w0">'
              '<ssc:EnumerationMappingTransformation/></ssm:MappingEntry></ssm:ParameterMapping>'
              '</ssd:ParameterMapping></ssd:ParameterBinding></ssd:ParameterBindings>')),
     "mapping entry 'k' -> 'w0': ssc:EnumerationMappingTransformation is not supported"),
    (ssd(A + '<ssd:Component name="s" type="application/x-ssp-package" source="resources/x.ssp"/>'),
     "component 's' has type 'application/x-ssp-package'; only FMUs"),
    (ssd(A + comp("g", "resources/Gain.fmu"), conn("a", "flange.w", "g", "u",
                                                   '<ssc:BooleanMappingTransformation><ssc:MapEntry source="true" '
                                                   'target="false"/></ssc:BooleanMappingTransformation>')),
     "connection a.flange.w -> g.u: ssc:BooleanMappingTransformation does not apply to Real values"),
    (ssd(A + comp("g", "resources/Gain.fmu"), conn("a", "flange.w", "g", "u",
                                                   '<ssc:EnumerationMappingTransformation><ssc:MapEntry source="x" '
                                                   'target="y"/></ssc:EnumerationMappingTransformation>')),
     "connection a.flange.w -> g.u: ssc:EnumerationMappingTransformation does not apply to Real values"),
    (ssd(A, '<ssd:Connection startConnector="in" endElement="a" endConnector="flange.tau"/>',
         system_extra='<ssd:Connectors><ssd:Connector name="in" kind="input"><ssc:Real/></ssd:Connector></ssd:Connectors>'),
     "system connector 'in' of system 'hand' drives a.flange.tau but nothing drives it (an input of the whole"),
    (ssd(comp("a", "resources/Missing.fmu")), "component 'a': source resources/Missing.fmu not found"),
    (ssd(A.replace('<ssd:Component ', '<ssd:Component implementation="ModelExchange" ')),
     "component 'a': implementation='ModelExchange', but "),   # the toolkit's FMUs are co-simulation only
    (ssd(A.replace('<ssd:Component ', '<ssd:Component implementation="ScheduledExecution" ')),
     "component 'a': implementation='ScheduledExecution' is not supported"),
    (SSD_HEAD + '<ssd:System name="x"><ssd:Elements>', "not well-formed XML"),
])
def test_unsupported_features_fail_with_one_line(folder, text, message):
    path = folder / "bad.ssd"
    path.write_text(text)
    with pytest.raises(SystemError_) as info:
        load_ssp(path)
    text = str(info.value)
    assert message in text and "\n" not in text and str(path) in text


def test_bad_parameter_file_and_archive_are_named(folder):
    (folder / "broken.ssv").write_text("<ssv:ParameterSet")
    (folder / "p.ssd").write_text(ssd(comp("a", "resources/Inertia.fmu",
                                           '<ssd:ParameterBindings><ssd:ParameterBinding source="broken.ssv"/>'
                                           '</ssd:ParameterBindings>')))
    with pytest.raises(SystemError_, match=r"broken.ssv: not well-formed XML"):
        load_ssp(folder / "p.ssd")
    (folder / "junk.ssp").write_bytes(b"not a zip")
    with pytest.raises(SystemError_, match=r"junk.ssp: not an SSP archive"):
        load_ssp(folder / "junk.ssp")


# ------------------------------------------------------------------------------------------------ units (issue 33)
RPM = '<ssc:Unit name="rpm"><ssc:BaseUnit rad="1" s="-1" factor="0.10471975511965977"/></ssc:Unit>'


def ssv_with_units(params: dict, units: str = "") -> str:
    """An .ssv whose Real values carry units: params name -> (value, unit); ``units``: its ssv:Units body."""
    body = "".join(f'<ssv:Parameter name="{k}"><ssv:Real value="{v!r}" unit="{u}"/></ssv:Parameter>'
                   for k, (v, u) in params.items())
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<ssv:ParameterSet version="1.0" name="p"'
            ' xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"'
            ' xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon">'
            f'<ssv:Parameters>{body}</ssv:Parameters>'
            + (f'<ssv:Units>{units}</ssv:Units>' if units else "") + '</ssv:ParameterSet>')


def bound(name: str) -> str:
    return comp("a", "resources/Inertia.fmu",
                f'<ssd:ParameterBindings><ssd:ParameterBinding source="{name}"/></ssd:ParameterBindings>')


def test_ssv_value_in_another_unit_is_converted(folder):
    # w0 of Inertia is in rad/s (the FMU's UnitDefinitions); 60 rpm is 2 pi rad/s; J in its own unit stays
    (folder / "a.ssv").write_text(ssv_with_units({"w0": (60.0, "rpm"), "J": (0.25, "kg.m2")}, RPM))
    (folder / "a.ssd").write_text(ssd(bound("a.ssv")))
    p = load_ssp(folder / "a.ssd").instance("a").parameters
    assert p["J"] == 0.25
    assert p["w0"] == pytest.approx(2 * np.pi, rel=1e-15)
    # the same with the unit defined in the .ssd (ssd:Units) and the value inline, on the system
    (folder / "b.ssd").write_text(
        ssd(A, system_extra='<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>'
            '<ssv:ParameterSet version="1.0" name="x"><ssv:Parameters><ssv:Parameter name="a.w0">'
            '<ssv:Real value="-30" unit="rpm"/></ssv:Parameter></ssv:Parameters></ssv:ParameterSet>'
            '</ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>')
        .replace("</ssd:SystemStructureDescription>", f"<ssd:Units>{RPM}</ssd:Units></ssd:SystemStructureDescription>"))
    assert load_ssp(folder / "b.ssd").instance("a").parameters["w0"] == pytest.approx(-np.pi, rel=1e-15)


@pytest.mark.parametrize("value,units,message", [
    ((1.0, "m"), '<ssc:Unit name="m"><ssc:BaseUnit m="1"/></ssc:Unit>',
     "parameter 'w0' = 1.0 m: the FMU's variable is in rad/s; m (m) and rad/s (s-1.rad) are not the same quantity"),
    ((3.0, "furlong/fortnight"), "",
     "parameter 'w0' = 3.0 furlong/fortnight: the FMU's variable is in rad/s, and furlong/fortnight has no unit "
     "definition"),
])
def test_ssv_value_in_an_unconvertible_unit_is_refused(folder, value, units, message):
    (folder / "a.ssv").write_text(ssv_with_units({"w0": value}, units))
    (folder / "a.ssd").write_text(ssd(bound("a.ssv")))
    with pytest.raises(SystemError_) as info:
        load_ssp(folder / "a.ssd")
    text = str(info.value)
    assert message in text and "component 'a'" in text and "a.ssv" in text and "\n" not in text



# units of a factor other than 1 and an offset: the FMU's variables in them and the values in the others, both ways.
# Expected numbers from the units' definitions: degC = K - 273.15, mm = 1e-3 m, rpm = 2 pi / 60 rad/s.
SCALED_UNITS = {"K": 'K="1"', "degC": 'K="1" offset="273.15"', "m": 'm="1"', "mm": 'm="1" factor="0.001"',
                "rad/s": 'rad="1" s="-1"', "rpm": 'rad="1" s="-1" factor="0.10471975511965977"'}
CONVERSIONS = [  # (the FMU variable's unit, the value as written, its unit, the value in the variable's unit)
    ("degC", 300.0, "K", 300.0 - 273.15), ("K", 25.0, "degC", 25.0 + 273.15),
    ("mm", 0.002, "m", 2.0), ("m", 1500.0, "mm", 1.5),
    ("rpm", 2 * np.pi, "rad/s", 60.0), ("rad/s", 60.0, "rpm", 2 * np.pi),
    ("degC", 77.0, "degF", 25.0),   # degF = 5/9 K + 255.372..: both ends scaled and offset
]


def scaled_unit_fmu(path, units: dict) -> None:
    """An FMI 2.0 archive holding only a modelDescription: one fixed parameter per unit (``x_<unit>``) and the
    UnitDefinitions; enough for the SSP reader, which converts by the FMU's declared units."""
    defs = "".join(f'<Unit name="{u}"><BaseUnit {b}/></Unit>' for u, b in units.items())
    variables = "".join(f'<ScalarVariable name="x_{u}" valueReference="{k}" causality="parameter" '
                        f'variability="fixed" initial="exact"><Real start="0" unit="{u}"/></ScalarVariable>'
                        for k, u in enumerate(units))
    md = ('<?xml version="1.0" encoding="UTF-8"?><fmiModelDescription fmiVersion="2.0" modelName="Scaled" '
          'guid="{5ca1ed00-0000-0000-0000-000000000000}"><CoSimulation modelIdentifier="Scaled"/>'
          f'<UnitDefinitions>{defs}</UnitDefinitions><ModelVariables>{variables}</ModelVariables>'
          '<ModelStructure/></fmiModelDescription>')
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", md)


@pytest.mark.parametrize("target,value,unit,expected", CONVERSIONS)
def test_values_convert_into_and_out_of_scaled_and_offset_units(tmp_path, target, value, unit, expected):
    """A Real value in a unit of another factor and offset than its FMU variable's is converted,
    value_SI = factor * value + offset on both ends; the source unit from the .ssv's ssv:Units."""
    (tmp_path / "resources").mkdir()
    defs = {**SCALED_UNITS, "degF": 'K="1" factor="0.5555555555555556" offset="255.37222222222223"'}
    scaled_unit_fmu(tmp_path / "resources" / "Scaled.fmu", {k: v for k, v in defs.items() if k != "degF"})
    units = "".join(f'<ssc:Unit name="{u}"><ssc:BaseUnit {b}/></ssc:Unit>' for u, b in defs.items() if u == unit)
    (tmp_path / "v.ssv").write_text(ssv_with_units({f"x_{target}": (value, unit)}, units))
    (tmp_path / "s.ssd").write_text(ssd(comp("a", "resources/Scaled.fmu", '<ssd:ParameterBindings>'
                                             '<ssd:ParameterBinding source="v.ssv"/></ssd:ParameterBindings>')))
    assert load_ssp(tmp_path / "s.ssd").instance("a").parameters[f"x_{target}"] == pytest.approx(expected, rel=1e-12)


# ------------------------------------------------------------------------------------------- issue 33: the rest of SSP
def test_ssp_given_as_an_unpacked_folder(folder):
    (folder / "a.ssv").write_text(ssv({"J": 0.02, "w0": 1.5}))
    (folder / "SystemStructure.ssd").write_text(ssd(bound("a.ssv") + B, BOND))
    s = load_ssp(folder)
    assert [i.name for i in s.instances] == ["a", "b"] and s.instance("a").parameters == {"J": 0.02, "w0": 1.5}
    assert s.instance("a").fmu == folder / "resources" / "Inertia.fmu"
    assert load(folder).instance("a").parameters == {"J": 0.02, "w0": 1.5}      # harness.load and the CLI too
    (folder / "SystemStructure.ssd").unlink()
    with pytest.raises(SystemError_, match="a folder given as an SSP must hold SystemStructure.ssd"):
        load_ssp(folder)


SSM = ('<?xml version="1.0" encoding="UTF-8"?>\n<ssm:ParameterMapping version="1.0"'
       ' xmlns:ssm="http://ssp-standard.org/SSP1/SystemStructureParameterMapping"'
       ' xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon">{}</ssm:ParameterMapping>')


def entry(source, target, inner="", extra=""):
    return f'<ssm:MappingEntry source="{source}" target="{target}"{extra}>{inner}</ssm:MappingEntry>'


def test_parameter_mapping_renames_and_transforms_values(folder):
    values = ('<?xml version="1.0" encoding="UTF-8"?>\n<ssv:ParameterSet version="1.0" name="p"'
              ' xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"'
              ' xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"><ssv:Parameters>'
              '<ssv:Parameter name="inertia_kg_cm2"><ssv:Real value="200"/></ssv:Parameter>'
              '<ssv:Parameter name="speed"><ssv:Real value="60" unit="rpm"/></ssv:Parameter>'
              '<ssv:Parameter name="mode"><ssv:Integer value="3"/></ssv:Parameter>'
              '<ssv:Parameter name="on"><ssv:Boolean value="true"/></ssv:Parameter>'
              '<ssv:Parameter name="J"><ssv:Real value="9.0"/></ssv:Parameter>'
              f'</ssv:Parameters><ssv:Units>{RPM}</ssv:Units></ssv:ParameterSet>')
    (folder / "a.ssv").write_text(values)
    (folder / "a.ssm").write_text(SSM.format(
        entry("inertia_kg_cm2", "J", '<ssc:LinearTransformation factor="1e-4"/>')          # kg.cm2 -> kg.m2
        + entry("speed", "w0")                                                           # rpm -> rad/s by unit
        + entry("speed", "w_rpm", extra=' suppressUnitConversion="true"')               # the number as written
        + entry("mode", "gear", '<ssc:IntegerMappingTransformation><ssc:MapEntry source="3" target="30"/>'
                                '</ssc:IntegerMappingTransformation>')
        + entry("on", "off", '<ssc:BooleanMappingTransformation><ssc:MapEntry source="true" target="false"/>'
                             '</ssc:BooleanMappingTransformation>')))
    binding = ('<ssd:ParameterBindings><ssd:ParameterBinding source="a.ssv"><ssd:ParameterMapping source="a.ssm"/>'
               '</ssd:ParameterBinding></ssd:ParameterBindings>')
    (folder / "m.ssd").write_text(ssd(comp("a", "resources/Inertia.fmu", binding)))
    # the targets Inertia lacks (w_rpm, gear, off) are dropped with one warning when the system loads, as
    # OMSimulator does; the mapping's values themselves are those of the component's bindings
    from harness.model import SystemWarning
    from harness.ssp import _Reader, _q

    with pytest.warns(SystemWarning, match=r"binding\(s\) of a\.w_rpm, a\.gear, a\.off name no variable"):
        p = load_ssp(folder / "m.ssd").instance("a").parameters
    # J is mapped from inertia_kg_cm2 (the set's own J is a target now, so the mapped value wins)
    assert p["J"] == pytest.approx(0.02, rel=1e-15) and p["w0"] == pytest.approx(2 * np.pi, rel=1e-15)
    assert not {"inertia_kg_cm2", "speed", "mode", "on", "w_rpm", "gear", "off"} & set(p)  # sources not by name
    import xml.etree.ElementTree as ET

    el = next(ET.parse(folder / "m.ssd").getroot().iter(_q("ssd:Component")))
    bound = _Reader(folder / "m.ssd", folder).parameter_bindings(el, "component 'a'", folder / "resources/Inertia.fmu")
    assert float(bound["w_rpm"]) == 60.0 and bound["gear"] == 30 and bound["off"] == 0
    # the mapped system runs: J = 0.02 kg.m2, w0 = 2 pi rad/s reach the FMU
    (folder / "a.ssm").write_text(SSM.format(entry("inertia_kg_cm2", "J", '<ssc:LinearTransformation factor="1e-4"/>')
                                             + entry("speed", "w0")))
    unmapped = ('<ssv:Parameter name="mode"><ssv:Integer value="3"/></ssv:Parameter>'
                '<ssv:Parameter name="on"><ssv:Boolean value="true"/></ssv:Parameter>')
    (folder / "values.ssv").write_text(values.replace(unmapped, ""))
    (folder / "m2.ssd").write_text(ssd(comp("a", "resources/Inertia.fmu", binding.replace("a.ssv", "values.ssv"))))
    df = quiet_simulate(load_ssp(folder / "m2.ssd"), stop_time=0.01, step=1e-3)
    assert df["a.flange.w"].iloc[0] == pytest.approx(2 * np.pi, rel=1e-12)


@pytest.mark.parametrize("entries,message", [
    (entry("nothing", "J"), "mapping entry 'nothing' -> 'J': the parameter set has no parameter 'nothing'"),
    (entry("mode", "gear", '<ssc:IntegerMappingTransformation><ssc:MapEntry source="1" target="10"/>'
                           '</ssc:IntegerMappingTransformation>'),
     "ssc:IntegerMappingTransformation has no ssc:MapEntry for the value 3 (entries for [1])"),
])
def test_parameter_mapping_errors_are_one_line(folder, entries, message):
    (folder / "a.ssv").write_text('<?xml version="1.0" encoding="UTF-8"?>\n<ssv:ParameterSet version="1.0" name="p"'
                                  ' xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues">'
                                  '<ssv:Parameters><ssv:Parameter name="mode"><ssv:Integer value="3"/></ssv:Parameter>'
                                  '</ssv:Parameters></ssv:ParameterSet>')
    (folder / "a.ssm").write_text(SSM.format(entries))
    (folder / "m.ssd").write_text(ssd(comp("a", "resources/Inertia.fmu", (
        '<ssd:ParameterBindings><ssd:ParameterBinding source="a.ssv"><ssd:ParameterMapping source="a.ssm"/>'
        '</ssd:ParameterBinding></ssd:ParameterBindings>'))))
    with pytest.raises(SystemError_) as info:
        load_ssp(folder / "m.ssd")
    assert message in str(info.value) and "a.ssm" in str(info.value) and "\n" not in str(info.value)


def test_nested_systems_are_flattened_and_run_like_the_flat_system(folder):
    """b and g inside system 'sub' (two levels: g inside 'sub/deep'), reached through system connectors,
    with linear transformations on both sides of a connector; the run equals the flat system's exactly."""
    (folder / "b.ssv").write_text(ssv({"J": 0.02, "c": 80.0}))
    inner_connectors = ('<ssd:Connectors><ssd:Connector name="phi" kind="input"/><ssd:Connector name="w" kind="input"/>'
                        '<ssd:Connector name="tau" kind="output"/></ssd:Connectors>')
    deep = ('<ssd:System name="deep"><ssd:Connectors><ssd:Connector name="in" kind="input"/></ssd:Connectors>'
            '<ssd:Elements>' + comp("g", "resources/Gain.fmu") + '</ssd:Elements><ssd:Connections>'
            '<ssd:Connection startConnector="in" endElement="g" endConnector="u">'
            '<ssc:LinearTransformation factor="3.0" offset="0.5"/></ssd:Connection></ssd:Connections></ssd:System>')
    sub = ('<ssd:System name="sub">' + inner_connectors + '<ssd:Elements>'
           + comp("b", "resources/SpringInertia.fmu",
                  '<ssd:ParameterBindings><ssd:ParameterBinding source="b.ssv"/></ssd:ParameterBindings>')
           + deep + '</ssd:Elements><ssd:Connections>'
           '<ssd:Connection startConnector="phi" endElement="b" endConnector="drive.phi"/>'
           '<ssd:Connection startConnector="w" endElement="b" endConnector="drive.w"/>'
           '<ssd:Connection startElement="b" startConnector="drive.tau" endConnector="tau"/>'
           '<ssd:Connection startConnector="w" endElement="deep" endConnector="in">'
           '<ssc:LinearTransformation factor="2.0" offset="1.0"/></ssd:Connection>'
           '</ssd:Connections><ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>'
           '<ssv:ParameterSet version="1.0" name="x"><ssv:Parameters><ssv:Parameter name="deep.g.k">'
           '<ssv:Real value="2.0"/></ssv:Parameter></ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues>'
           '</ssd:ParameterBinding></ssd:ParameterBindings></ssd:System>')
    outer = (conn("a", "flange.phi", "sub", "phi") + conn("a", "flange.w", "sub", "w")
             + conn("sub", "tau", "a", "flange.tau"))
    (folder / "nested.ssd").write_text(ssd(A, outer, elements_extra=sub))
    s = load_ssp(folder / "nested.ssd")
    assert [i.name for i in s.instances] == ["a", "sub/b", "sub/deep/g"]
    assert s.instance("sub/b").parameters == {"J": 0.02, "c": 80.0}
    assert s.instance("sub/deep/g").parameters == {"k": 2.0}
    lin = [c for c in s.connections if c.target == "sub/deep/g.u"][0]
    assert (lin.source, lin.factor, lin.offset) == ("a.flange.w", 6.0, 3.5)   # 3 (2 w + 1) + 0.5
    lin.unit_conversion = True
    flat = System("flat", [Instance("a", folder / "resources" / "Inertia.fmu"),
                           Instance("b", folder / "resources" / "SpringInertia.fmu", {"J": 0.02, "c": 80.0}),
                           Instance("g", folder / "resources" / "Gain.fmu", {"k": 2.0})],
                  [Connection("a.flange.phi", "b.drive.phi"), Connection("a.flange.w", "b.drive.w"),
                   Connection("b.drive.tau", "a.flange.tau"),
                   Connection("a.flange.w", "g.u", factor=6.0, offset=3.5, unit_conversion=True)])
    a = quiet_simulate(s, stop_time=0.05, step=1e-3)
    b = quiet_simulate(flat, stop_time=0.05, step=1e-3)
    assert list(a.columns) == [c.replace("b.", "sub/b.", 1).replace("g.", "sub/deep/g.", 1) if c[:2] in ("b.", "g.")
                               else c for c in b.columns]
    np.testing.assert_array_equal(a.to_numpy(), b.to_numpy())


def test_a_system_connector_given_a_value_drives_its_inputs_with_it(folder):
    """As OMSimulator writes a value set on a system input (its NestedSystemSimulation tests): the value in
    the system's parameter bindings, under the connector's name; an input of the whole system without one
    is refused (test_unsupported_features_fail_with_one_line)."""
    values = ('<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues><ssv:ParameterSet version="1.0" '
              'name="x"><ssv:Parameters><ssv:Parameter name="{}"><ssv:Real value="{}"/></ssv:Parameter>'
              '</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding>'
              '</ssd:ParameterBindings>')
    sub = ('<ssd:System name="sub"><ssd:Connectors><ssd:Connector name="in" kind="input"/></ssd:Connectors>'
           + values.format("in", 10.0) + '<ssd:Elements>' + comp("g", "resources/Gain.fmu")
           + '</ssd:Elements><ssd:Connections><ssd:Connection startConnector="in" endElement="g" endConnector="u"/>'
           '</ssd:Connections></ssd:System>')
    text = ssd(comp("g", "resources/Gain.fmu"),
               '<ssd:Connection startConnector="in" endElement="g" endConnector="u">'
               '<ssc:LinearTransformation factor="2.0" offset="1.0"/></ssd:Connection>',
               system_extra='<ssd:Connectors><ssd:Connector name="in" kind="input"/></ssd:Connectors>'
               + values.format("in", 3.0), elements_extra=sub)
    (folder / "c.ssd").write_text(text)
    s = load_ssp(folder / "c.ssd")
    assert s.connections == []
    assert s.instance("g").parameters == {"u": 7.0} and s.instance("sub/g").parameters == {"u": 10.0}
    df = quiet_simulate(s, stop_time=0.01, step=1e-3)
    k = float(next(v.start for v in model_description(s.instance("g").fmu).modelVariables if v.name == "k"))
    assert (df["g.y"] == k * 7.0).all() and (df["sub/g.y"] == k * 10.0).all()


def test_default_experiment_start_time_is_the_run_start(folder):
    experiment = ('<ssd:DefaultExperiment startTime="0.25" stopTime="0.3"><ssd:Annotations>'
                  '<ssc:Annotation type="com.opensimulationplatform"><osp:Algorithm>'
                  '<osp:FixedStepAlgorithm baseStepSize="0.01"/></osp:Algorithm></ssc:Annotation>'
                  '</ssd:Annotations></ssd:DefaultExperiment>')
    (folder / "s.ssd").write_text(ssd(A + B, BOND, experiment=experiment))
    s = load_ssp(folder / "s.ssd")
    assert (s.experiment.start_time, s.experiment.stop_time) == (0.25, 0.3)
    df = quiet_simulate(s)
    np.testing.assert_allclose(df.index.to_numpy(), np.linspace(0.25, 0.3, 6), rtol=0, atol=1e-12)
    assert quiet_simulate(s, start_time=0.0).index[0] == 0.0        # an explicit start_time still wins
    # export writes it back
    out = export_ssp(s, folder / "back.ssp")
    assert load_ssp(out).experiment.start_time == 0.25


def test_errors_in_an_ssp_archive_name_the_archive_not_the_extraction_cache(folder):
    from harness.fmi.cache import cache_dir

    (folder / "a.ssv").write_text(ssv_with_units({"w0": (1.0, "m")},
                                                 '<ssc:Unit name="m"><ssc:BaseUnit m="1"/></ssc:Unit>'))
    (folder / "SystemStructure.ssd").write_text(ssd(bound("a.ssv")))
    archive = folder / "user.ssp"
    with zipfile.ZipFile(archive, "w") as z:
        for f in ("SystemStructure.ssd", "a.ssv", "resources/Inertia.fmu"):
            z.write(folder / f, f)
    with pytest.raises(SystemError_) as info:
        load_ssp(archive)
    text = str(info.value)
    assert text.startswith(f"{archive}!a.ssv: component 'a', parameter 'w0'") and str(cache_dir()) not in text
    (folder / "SystemStructure.ssd").write_text(ssd(comp("a", "resources/Missing.fmu")))
    with zipfile.ZipFile(archive, "w") as z:
        z.write(folder / "SystemStructure.ssd", "SystemStructure.ssd")
    with pytest.raises(SystemError_, match=rf"^{archive}!SystemStructure.ssd: component 'a': source resources/Missing"):
        load_ssp(archive)


def test_an_ssp_without_a_step_says_so(folder):
    (folder / "n.ssd").write_text(ssd(A + B, BOND, experiment='<ssd:DefaultExperiment startTime="0" stopTime="0.1"/>'))
    with pytest.raises(SystemError_, match=r"its default experiment declares no step: give step \(--step on the"):
        quiet_simulate(load_ssp(folder / "n.ssd"))
    assert len(quiet_simulate(load_ssp(folder / "n.ssd"), step=0.01)) == 11


def test_an_input_given_a_value_is_not_reported_as_keeping_its_start_value(folder):
    """Gain's input u set by a binding (as OMSimulator's LinearTransformation3 case sets Gain1.u through an
    .ssm) holds that value on purpose: no 'keeps its start value' warning; an input left alone still warns."""
    bound_u = ('<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues><ssv:ParameterSet version="1.0" '
               'name="x"><ssv:Parameters><ssv:Parameter name="u"><ssv:Real value="14.0"/></ssv:Parameter>'
               '</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding>'
               '</ssd:ParameterBindings>')
    (folder / "u.ssd").write_text(ssd(comp("g", "resources/Gain.fmu", bound_u) + comp("h", "resources/Gain.fmu")))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        df = simulate(load_ssp(folder / "u.ssd"), stop_time=0.01, step=1e-3, on_error="raise")
    texts = [str(w.message) for w in caught if issubclass(w.category, SystemWarning)]
    assert not [t for t in texts if "input g.u" in t]
    assert [t for t in texts if "input h.u is not connected: it keeps its start value" in t]
    assert (df["g.y"] > 0).all()
