"""Directional derivatives of the toolkit's FMUs (issues 29 and 34): d outputs / d inputs at the current time, from
each component's physics (``Model.output_jacobian``), in process and through the FMUs' binaries (the host loader
answers fmi2/fmi3GetDirectionalDerivative from the slave), against central differences of the outputs read
through the same path, in step and in initialisation mode; through fmpy's plain slaves and a C host without
Python; per instance, after a reset and from another thread; the ``jacobian`` master's results with them against
its results by perturbation; FMUs without them refused in one line and still run."""
from __future__ import annotations

import sys
import types
import warnings
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest

from fmus import build as build_fmus
from fmus.build import catalog
from harness import load, simulate
from harness.master import jacobian
from harness.errors import FMUError
from harness.fmi import open_instance
from harness.fmi.inprocess import InProcessFMU
from harness.run import RunOptions
from input_ranges import declared_range, fold

NAMES = sorted(catalog())
STEP = 1e-3
# operating points: input j = base + 0.37 j (each after one step from the previous point's inputs); 2.0 puts the
# knife inside its cut
BASES = (0.2, 1.1, 2.0, -0.6)
# parameters that give the loads a slope at all (their defaults are a constant torque; the knife's block arrives
# at t = 0, its entry ramp then half way); the components without feed-through (the torques only drive states)
PARAMETERS = {"TorqueLoad": {"c": 40.0, "d": 0.3, "T_coulomb": 2.0}, "KnifeLoad": {"t_block": -1e-3}}
NO_FEEDTHROUGH = {"Inertia", "FlywheelShaft", "ParallelShafts",
                  "ClutchBrakeShaft"}   # its holding brake feeds its torques through only while it holds, at rest


@pytest.fixture(scope="session")
def fmu3_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("fmus3_dd")
    assert build_fmus.main(["--fmi-version", "3", "--out", str(out)]) == 0, "build_fmus.py failed (see stderr)"
    return out


def _point(inputs: list, base: float) -> np.ndarray:
    """Input j at base + 0.37 j, folded into the range the FMU declares for it (it refuses a value outside)."""
    return np.array([fold(base + 0.37 * j, *declared_range(v)) for j, v in enumerate(inputs)])


def _central(set_inputs, get_outputs, u: np.ndarray) -> np.ndarray:
    """d outputs / d inputs by central differences through the FMU's own set/get (every input set each time)."""
    cols = []
    for j in range(u.size):
        h = 1e-6 * max(1.0, abs(u[j]))
        up, um = u.copy(), u.copy()
        up[j] += h
        um[j] -= h
        set_inputs(up)
        yp = np.array(get_outputs(), dtype=float)
        set_inputs(um)
        ym = np.array(get_outputs(), dtype=float)
        cols.append((yp - ym) / (up[j] - um[j]))
    set_inputs(u)
    return np.column_stack(cols)


def _check(D: np.ndarray, fd: np.ndarray, where: str) -> float:
    """D agrees with the differences to 1e-6 of the largest entry (the differences' own error is ~1e-9 of it);
    returns the largest deviation relative to that scale."""
    scale = max(1.0, float(np.max(np.abs(fd))))
    dev = float(np.max(np.abs(D - fd))) / scale
    assert dev < 1e-6, f"{where}: directional derivatives differ from the differences by {dev:.3g} of {scale:.3g}\n" \
                       f"D =\n{D}\nfd =\n{fd}"
    return dev


def _harness_case(inst, name: str, where: str) -> list[float]:
    """D at each operating point against differences; D is not zero everywhere unless the component has no
    feed-through (a test at points where every slope vanishes would prove nothing)."""
    ins = [v.name for v in inst.md.modelVariables if v.causality == "input"]
    outs = [v.name for v in inst.md.modelVariables if v.causality == "output"]
    inp, out = inst.reals(ins), inst.reals(outs)
    assert inst.provides_directional_derivative, f"{where}: does not declare directional derivatives"
    for key, value in PARAMETERS.get(name, {}).items():
        inst.set_value(key, value)
    inst.setup(0.0)
    inst.enter_initialization()
    inst.exit_initialization()
    devs, t, nonzero = [], 0.0, 0
    for base in BASES:
        u = _point([v for v in inst.md.modelVariables if v.causality == "input"], base)
        inst.set(inp, u)
        inst.do_step(t, STEP)
        t += STEP
        inst.set(inp, u)
        D = np.column_stack([inst.directional_derivative(out, inp, e) for e in np.eye(len(ins))])
        fd = _central(lambda v: inst.set(inp, v), lambda: inst.get(out).copy(), u)
        devs.append(_check(D, fd, f"{where} at inputs {u}"))
        nonzero += int(np.count_nonzero(D))
    assert (nonzero == 0) == (name in NO_FEEDTHROUGH), f"{where}: {nonzero} non-zero slopes"
    return devs


# how the harness calls an FMU: the open_instance choice and the wrapper class it gives
PATHS = {"in-process": (True, "InProcessFMU"), "fmi2": (False, "FMU"), "fmi3": (None, "FMU3")}


@pytest.mark.parametrize("path", sorted(PATHS))
@pytest.mark.parametrize("name", NAMES)
def test_directional_derivatives_match_differences(fmu_dir, fmu3_dir, name, path):
    """In process (the slave's method), through the FMI 2.0 binary and through the FMI 3.0 binary (the loader)."""
    in_process, kind = PATHS[path]
    inst = open_instance((fmu3_dir if path == "fmi3" else fmu_dir) / f"{name}.fmu", "dd", in_process=in_process)
    assert type(inst).__name__ == kind
    try:
        _harness_case(inst, name, f"{name} {path}")
    finally:
        inst.free()


@pytest.mark.parametrize("path", sorted(PATHS))
@pytest.mark.parametrize("name", NAMES)
def test_directional_derivatives_in_initialisation_mode(fmu_dir, fmu3_dir, name, path):
    """In initialisation mode the outputs are those of the initial state for the inputs, and so are their slopes
    (slave_core._initial_feedthrough): against differences of the outputs read in that mode."""
    in_process, kind = PATHS[path]
    inst = open_instance((fmu3_dir if path == "fmi3" else fmu_dir) / f"{name}.fmu", "init", in_process=in_process)
    assert type(inst).__name__ == kind
    try:
        for key, value in PARAMETERS.get(name, {}).items():
            inst.set_value(key, value)
        ins = [v.name for v in inst.md.modelVariables if v.causality == "input"]
        outs = [v.name for v in inst.md.modelVariables if v.causality == "output"]
        inp, out = inst.reals(ins), inst.reals(outs)
        inst.setup(0.0)
        inst.enter_initialization()
        u = _point([v for v in inst.md.modelVariables if v.causality == "input"], 1.1)
        inst.set(inp, u)
        D = np.column_stack([inst.directional_derivative(out, inp, e) for e in np.eye(len(ins))])
        fd = _central(lambda v: inst.set(inp, v), lambda: inst.get(out).copy(), u)
        _check(D, fd, f"{name} {path} in initialisation mode")
        inst.exit_initialization()
    finally:
        inst.free()


@pytest.mark.parametrize("in_process", [True, False])
def test_initialisation_slopes_end_with_initialisation(fmu_dir, in_process):
    """RackBed's elastic mesh starts relaxed (the bed state is R*phi for the inputs), so in initialisation mode the
    mesh force does not move with the pinion angle; once initialised the bed has its own state and it moves with
    c_mesh*R: the slope asked at the same inputs right after fmi2ExitInitializationMode is the step mode's."""
    inst = open_instance(fmu_dir / "RackBed.fmu", "rack", in_process=in_process)
    try:
        inst.set_value("fidelity", 1)
        inst.setup(0.0)
        inst.enter_initialization()
        phi, force = inst.reals(["pinion.phi", "pinion.w"]), inst.reals(["mesh_force"])
        inst.set(phi, [0.4, 2.0])
        inst.get(force)                 # the initial state for these inputs, as exit_initialization makes it
        initial = inst.directional_derivative(force, phi, [1.0, 0.0])[0]
        inst.exit_initialization()
        after = inst.directional_derivative(force, phi, [1.0, 0.0])[0]
        c, module, teeth = (inst.get_value(n) for n in ("c_mesh", "module", "z_pinion"))
        assert abs(initial) <= 1e-6 * c * module * teeth
        assert after == pytest.approx(c * 0.5 * module * teeth, rel=1e-12)
    finally:
        inst.free()


@pytest.mark.parametrize("in_process", [True, False])
def test_slopes_follow_a_parameter_set_in_initialisation_mode(fmu_dir, in_process):
    """SpringInertia's d drive.tau / d drive.phi is -c: asked, then c changed in initialisation mode, then asked
    again at the same inputs, it is the new -c."""
    inst = open_instance(fmu_dir / "SpringInertia.fmu", "spring", in_process=in_process)
    try:
        inst.setup(0.0)
        inst.enter_initialization()
        phi, tau = inst.reals(["drive.phi"]), inst.reals(["drive.tau"])
        inst.set(phi, [0.2])
        inst.get(tau)
        before = inst.directional_derivative(tau, phi, [1.0])[0]
        inst.set_value("c", 3.0 * -before)
        inst.get(tau)
        assert inst.directional_derivative(tau, phi, [1.0])[0] == pytest.approx(3.0 * before, rel=1e-12)
        inst.exit_initialization()
    finally:
        inst.free()


def _fmpy_case(path: Path, version: int) -> None:
    """Through fmpy's plain FMU2Slave / FMU3Slave (a host nobody here wrote): its getDirectionalDerivative on the
    FMU's binary, against differences of its own getReal/getFloat64."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    md = read_model_description(str(path))
    unzip = extract(str(path))
    cls = FMU3Slave if version == 3 else FMU2Slave
    s = cls(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="plain")
    iv = [v.valueReference for v in md.modelVariables if v.causality == "input"]
    ov = [v.valueReference for v in md.modelVariables if v.causality == "output"]
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s.instantiate()
    for key, value in PARAMETERS.get(path.stem, {}).items():
        (s.setFloat64 if version == 3 else s.setReal)([vr[key]], [value])
    if version == 2:
        s.setupExperiment(startTime=0.0)
        get, set_ = s.getReal, s.setReal
    else:
        get, set_ = s.getFloat64, s.setFloat64
    s.enterInitializationMode()
    s.exitInitializationMode()
    t = 0.0
    for base in BASES:
        u = _point([v for v in md.modelVariables if v.causality == "input"], base)
        set_(iv, list(u))
        s.doStep(t, STEP)
        t += STEP
        set_(iv, list(u))
        D = np.column_stack([s.getDirectionalDerivative(ov, iv, list(e)) for e in np.eye(len(iv))])
        fd = _central(lambda v: set_(iv, list(v)), lambda: get(ov), u)
        _check(D, fd, f"{path.name} FMI {version}.0 through fmpy at inputs {u}")
    s.terminate()
    s.freeInstance()


@pytest.mark.parametrize("name", NAMES)
def test_fmpy_plain_slaves_get_directional_derivatives_from_the_binaries(fmu_dir, fmu3_dir, name):
    _fmpy_case(fmu_dir / f"{name}.fmu", 2)
    _fmpy_case(fmu3_dir / f"{name}.fmu", 3)


@pytest.mark.parametrize("path", ["fmi2", "fmi3"])
def test_binary_answers_on_another_thread(fmu_dir, fmu3_dir, path):
    """An instance made on one thread and asked on another (the loader takes the GIL on whatever thread calls)."""
    import threading

    in_process, _ = PATHS[path]
    inst = open_instance((fmu3_dir if path == "fmi3" else fmu_dir) / "SpringInertia.fmu", "thread",
                         in_process=in_process)
    try:
        inst.setup(0.0)
        inst.enter_initialization()
        inst.exit_initialization()
        phi, tau = inst.reals(["drive.phi"]), inst.reals(["drive.tau"])
        got = []
        worker = threading.Thread(target=lambda: got.append(inst.directional_derivative(tau, phi, [1.0])[0]))
        worker.start()
        worker.join(60)
        assert got == [pytest.approx(-inst.get_value("c"), rel=1e-15)]
    finally:
        inst.free()


@pytest.mark.parametrize("version", [2, 3])
def test_reset_instance_answers_from_its_new_slave(fmu_dir, fmu3_dir, version):
    """pythonfmu's and pythonfmu3's fmi*Reset construct a new slave for the instance; the loader then answers from
    that one: SpringInertia with c = 300, reset (c back to its default), answers d drive.tau / d drive.phi = -c of
    the new slave (fmpy's plain slaves)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    path = (fmu3_dir if version == 3 else fmu_dir) / "SpringInertia.fmu"
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    default_c = float(next(v.start for v in md.modelVariables if v.name == "c"))
    s = (FMU3Slave if version == 3 else FMU2Slave)(guid=md.guid, unzipDirectory=extract(str(path)),
                                                    modelIdentifier=md.coSimulation.modelIdentifier,
                                                    instanceName="reset")
    set_ = s.setFloat64 if version == 3 else s.setReal

    def slope(c=None):
        if c is not None:
            set_([vr["c"]], [c])
        if version == 2:
            s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        return s.getDirectionalDerivative([vr["drive.tau"]], [vr["drive.phi"]], [1.0])[0]

    s.instantiate()
    assert slope(300.0) == pytest.approx(-300.0, rel=1e-15)
    s.reset()
    assert slope() == pytest.approx(-default_c, rel=1e-15)
    s.terminate()
    s.freeInstance()


def _cosim(fmu: Path) -> ET.Element:
    with zipfile.ZipFile(fmu) as z:
        return ET.fromstring(z.read("modelDescription.xml")).find("CoSimulation")


@pytest.mark.parametrize("name", NAMES)
def test_model_descriptions_declare_directional_derivatives(fmu_dir, fmu3_dir, name):
    """FMI 2.0's attribute providesDirectionalDerivative, FMI 3.0's providesDirectionalDerivatives (the schemas'
    names; fmpy validate passes on both, build_fmus validates every FMU)."""
    assert _cosim(fmu_dir / f"{name}.fmu").get("providesDirectionalDerivative") == "true"
    assert _cosim(fmu3_dir / f"{name}.fmu").get("providesDirectionalDerivatives") == "true"


@pytest.mark.parametrize("in_process", [True, False])
def test_held_position_enters_the_speed_derivative(fmu_dir, in_process):
    """TorqueLoad's flange.tau = -(d w + c (phi - phi_ref)) (no Coulomb part here) uses the angle held over the
    last step advanced by the speed (slave_core._inputs_now): with only the speed set after a step, d tau / d w is
    -(d + c h), which is what setting the speed alone and reading the torque again gives."""
    inst = open_instance(fmu_dir / "TorqueLoad.fmu", "held", in_process=in_process)
    try:
        c, d = 250.0, 0.5
        for name, value in (("c", c), ("d", d), ("T_coulomb", 0.0)):
            inst.set_value(name, value)
        inst.setup(0.0)
        inst.enter_initialization()
        inst.exit_initialization()
        phi, w, tau = inst.reals(["flange.phi"]), inst.reals(["flange.w"]), inst.reals(["flange.tau"])
        inst.set(phi, [0.1])
        inst.set(w, [2.0])
        inst.do_step(0.0, STEP)
        inst.set(w, [2.0])              # the speed set again, the angle held
        D = inst.directional_derivative(tau, w, [1.0])
        base = inst.get(tau)[0]
        inst.set(w, [2.0 + 1e-6])
        fd = (inst.get(tau)[0] - base) / 1e-6
        assert D[0] == pytest.approx(-(d + c * STEP), rel=1e-12)
        assert D[0] == pytest.approx(fd, rel=1e-6)
    finally:
        inst.free()


@pytest.mark.parametrize("in_process", [True, False])
def test_bad_directional_derivative_calls_are_refused_in_one_line(fmu_dir, in_process):
    inst = open_instance(fmu_dir / "SpringInertia.fmu", "bad", in_process=in_process)
    try:
        inst.setup(0.0)
        inst.enter_initialization()
        inst.exit_initialization()
        tau, phi = inst.reals(["drive.tau"]), inst.reals(["drive.phi"])
        with pytest.raises(FMUError) as e:
            inst.directional_derivative(phi, tau, [1.0])       # an input as unknown, an output as known
        assert "is not an output" in str(e.value) and "\n" not in str(e.value)
    finally:
        inst.free()


def test_fmu_without_directional_derivatives_is_refused_and_perturbed(tmp_path):
    """A plain pythonfmu FMU (no providesDirectionalDerivative): the wrapper refuses the call in one line and the
    jacobian master's feed-through block falls back to forward differences."""
    import subprocess

    exe = Path(sys.executable).with_name("pythonfmu")
    if not exe.is_file():
        pytest.skip("pythonfmu command not installed")
    r = subprocess.run([str(exe), "build", "-f", str(Path(__file__).parent / "foreign" / "plain_lag.py"), "-d",
                        str(tmp_path)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    for in_process in (True, False):
        inst = open_instance(tmp_path / "PlainLag.fmu", f"lag{int(in_process)}", in_process=in_process)
        try:
            assert not inst.provides_directional_derivative
            inst.setup(0.0)
            inst.enter_initialization()
            inst.exit_initialization()
            u, y = inst.reals(["u"]), inst.reals(["y"])
            with pytest.raises(FMUError, match="does not provide directional derivatives"):
                inst.directional_derivative(y, u, [1.0])
            assert jacobian.feedthrough_block(inst, u, y, np.array([0.5])) == pytest.approx(np.zeros((1, 1)))
        finally:
            inst.free()


def _by_differences(fmu, inp, out, point):
    """The feed-through block as the master estimated it before directional derivatives: the FMU seen without them."""
    return _FEEDTHROUGH(types.SimpleNamespace(set=fmu.set, get=fmu.get), inp, out, point)


_FEEDTHROUGH = jacobian.feedthrough_block



@pytest.mark.parametrize("name,stop,path", [("two_inertia", 0.2, "in-process"), ("feeder_gto52", 0.05, "in-process"),
                                            ("proof_press", 0.1, "in-process"), ("two_inertia", 0.2, "fmi2"),
                                            ("feeder_gto52", 0.05, "fmi3")])
def test_jacobian_master_results_unchanged_with_directional_derivatives(name, stop, path, fmu3_dir, monkeypatch):
    """The jacobian master with the FMUs' D blocks against the same run with D by perturbation: the same results to
    1e-6 of each signal's range (measured in process: two_inertia 1e-17, proof_press 4e-12, feeder_gto52 6e-8 over
    0.2 s), and the D blocks did come from the FMUs; in process, through the FMI 2.0 binaries and from the FMI 3.0
    FMUs."""
    used = []

    def spy(fmu, inp, out, point):
        used.append((bool(getattr(fmu, "provides_directional_derivative", False)), type(fmu).__name__))
        return _FEEDTHROUGH(fmu, inp, out, point)

    system = load(name).on_fmus(fmu3_dir) if path == "fmi3" else load(name)
    options = RunOptions(in_process=False) if path == "fmi2" else None
    runs = {}
    for label, block in (("provided", spy), ("perturbed", _by_differences)):
        monkeypatch.setattr(jacobian, "feedthrough_block", block)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            runs[label] = simulate(system, stop_time=stop, master="jacobian", on_error="raise", options=options)
    kind = PATHS[path][1]
    assert used and all(provided and cls == kind for provided, cls in used), set(used)
    a, b = runs["provided"], runs["perturbed"]
    assert list(a.columns) == list(b.columns) and len(a) == len(b)
    for c in b.columns:
        scale = max(float(np.max(np.abs(b[c].values))), 1e-9)
        assert float(np.max(np.abs(a[c].values - b[c].values))) <= 1e-6 * scale, c


def test_binary_instances_answer_from_their_own_slaves(fmu_dir, fmu3_dir):
    """The host loader keeps each instance's slave: instances of one FMU with different stiffness side by side,
    one made after an in-process slave of the same instance name on the same thread (whose offer the loader must
    not take), and one made after another was freed, each answer d drive.tau / d drive.phi = -c of their own."""
    made = []
    try:
        stray = open_instance(fmu_dir / "SpringInertia.fmu", "twin", in_process=True)
        stray.set_value("c", 777.0)
        made.append(stray)
        for path in (fmu_dir, fmu3_dir):
            insts = []
            for i, c in enumerate((100.0, 300.0, 50.0)):
                inst = open_instance(path / "SpringInertia.fmu", "twin", in_process=False)
                assert not isinstance(inst, InProcessFMU)
                inst.set_value("c", c)
                inst.setup(0.0)
                inst.enter_initialization()
                inst.exit_initialization()
                insts.append((inst, c))
                if i == 1:                      # free the second one; the third is made after
                    inst.free()
                    insts.pop()
                else:
                    made.append(inst)
            for inst, c in insts:
                phi, tau = inst.reals(["drive.phi"]), inst.reals(["drive.tau"])
                assert inst.directional_derivative(tau, phi, [1.0])[0] == pytest.approx(-c, rel=1e-15), (path, c)
    finally:
        for inst in made:
            inst.free()


# -- a host without Python: the loader initialises Python itself and answers from the slave ---------------------
C_HOST = r"""
/* dd_host <2|3> <binary.so> <resources> <guid/token> <in vrs a,b,..> <out vrs a,b,..> <inputs u0,u1,..>: instantiate,
   initialise, set the inputs, one step of 1 ms, set them again; print "DEV <max |DD - central difference| / scale>"
   over a unit seed per input (DD from Get...DirectionalDerivative, differences from Set/Get); exit 4 on a failed
   call. */
#include <dlfcn.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
typedef void *I;
typedef int (*SetGet)(I, const unsigned *, size_t, double *);
typedef int (*SetGet3)(I, const unsigned *, size_t, double *, size_t);
static void logger2(void *e, const char *n, int s, const char *c, const char *m, ...) { printf("LOG %d %s\n", s, m); }
static void logger3(void *e, int s, const char *c, const char *m) { printf("LOG %d %s\n", s, m); }
static size_t parse(const char *t, unsigned *v) { size_t n = 0; char *s = strdup(t), *x = NULL;
    for (char *i = strtok_r(s, ",", &x); i; i = strtok_r(NULL, ",", &x)) v[n++] = strtoul(i, NULL, 10);
    free(s); return n; }
static int v3; static I c; static void *lib;
static int set(const unsigned *vr, size_t n, double *v) {
    return v3 ? ((SetGet3)dlsym(lib, "fmi3SetFloat64"))(c, vr, n, v, n) : ((SetGet)dlsym(lib, "fmi2SetReal"))(c, vr, n, v); }
static int get(const unsigned *vr, size_t n, double *v) {
    return v3 ? ((SetGet3)dlsym(lib, "fmi3GetFloat64"))(c, vr, n, v, n) : ((SetGet)dlsym(lib, "fmi2GetReal"))(c, vr, n, v); }
int main(int argc, char **argv) {
    unsigned in[64], out[64]; double u[64], seed[64], dd[64], yp[64], ym[64], D[64][64], F[64][64];
    v3 = argv[1][0] == '3';
    if (!(lib = dlopen(argv[2], RTLD_NOW | RTLD_LOCAL))) { printf("%s\n", dlerror()); return 2; }
    size_t ni = parse(argv[5], in), no = parse(argv[6], out);
    if (v3) {
        c = ((I (*)(const char *, const char *, const char *, bool, bool, bool, bool, const unsigned *, size_t, void *,
                    void *, void *))dlsym(lib, "fmi3InstantiateCoSimulation"))("c", argv[4], argv[3], 0, 0, 0, 0, NULL,
                                                                              0, NULL, (void *)logger3, NULL);
        if (!c) return 3;
        if (((int (*)(I, bool, double, double, bool, double))dlsym(lib, "fmi3EnterInitializationMode"))(c, 0, 0, 0, 0, 0)
            || ((int (*)(I))dlsym(lib, "fmi3ExitInitializationMode"))(c)) return 4;
    } else {
        struct { void *l, *a, *f, *s, *e; } cb = {(void *)logger2, (void *)calloc, (void *)free, NULL, NULL};
        char uri[4200]; snprintf(uri, sizeof uri, "file://%s", argv[3]);
        c = ((I (*)(const char *, int, const char *, const char *, void *, int, int))dlsym(lib, "fmi2Instantiate"))(
            "c", 1, argv[4], uri, &cb, 0, 0);
        if (!c) return 3;
        if (((int (*)(I, int, double, double, int, double))dlsym(lib, "fmi2SetupExperiment"))(c, 0, 0, 0, 0, 0)
            || ((int (*)(I))dlsym(lib, "fmi2EnterInitializationMode"))(c)
            || ((int (*)(I))dlsym(lib, "fmi2ExitInitializationMode"))(c)) return 4;
    }
    { char *s = strdup(argv[7]), *x = NULL; size_t j = 0;
      for (char *i = strtok_r(s, ",", &x); i && j < ni; i = strtok_r(NULL, ",", &x)) u[j++] = strtod(i, NULL);
      free(s); if (j != ni) return 5; }
    if (set(in, ni, u)) return 4;
    bool b1, b2, b3; double last;
    if (v3 ? ((int (*)(I, double, double, bool, bool *, bool *, bool *, double *))dlsym(lib, "fmi3DoStep"))(
                 c, 0.0, 1e-3, 1, &b1, &b2, &b3, &last)
           : ((int (*)(I, double, double, int))dlsym(lib, "fmi2DoStep"))(c, 0.0, 1e-3, 1)) return 4;
    if (set(in, ni, u)) return 4;
    double scale = 1.0, dev = 0.0;
    for (size_t j = 0; j < ni; j++) {
        for (size_t k = 0; k < ni; k++) seed[k] = k == j;
        int s = v3 ? ((int (*)(I, const unsigned *, size_t, const unsigned *, size_t, const double *, size_t, double *,
                               size_t))dlsym(lib, "fmi3GetDirectionalDerivative"))(c, out, no, in, ni, seed, ni, dd, no)
                   : ((int (*)(I, const unsigned *, size_t, const unsigned *, size_t, const double *, double *))dlsym(
                         lib, "fmi2GetDirectionalDerivative"))(c, out, no, in, ni, seed, dd);
        if (s) return 4;
        double h = 1e-6 * fmax(1.0, fabs(u[j])), uj = u[j];
        u[j] = uj + h; set(in, ni, u); get(out, no, yp);
        u[j] = uj - h; set(in, ni, u); get(out, no, ym);
        u[j] = uj; set(in, ni, u);
        for (size_t i = 0; i < no; i++) { D[i][j] = dd[i]; F[i][j] = (yp[i] - ym[i]) / (2 * h);
                                          scale = fmax(scale, fabs(F[i][j])); }
    }
    for (size_t i = 0; i < no; i++) for (size_t j = 0; j < ni; j++) dev = fmax(dev, fabs(D[i][j] - F[i][j]));
    printf("DEV %.3e\n", dev / scale);
    if (v3) ((void (*)(I))dlsym(lib, "fmi3FreeInstance"))(c); else ((void (*)(I))dlsym(lib, "fmi2FreeInstance"))(c);
    return 0;
}
"""


@pytest.fixture(scope="module")
def dd_host(tmp_path_factory) -> Path:
    import os
    import shutil
    import subprocess

    folder = tmp_path_factory.mktemp("dd_host")
    cc = os.environ.get("CC", "cc")
    if shutil.which(cc) is None:
        pytest.skip(f"no C compiler {cc!r} to build the test host")
    (folder / "dd_host.c").write_text(C_HOST)
    r = subprocess.run([cc, "-O2", "-o", str(folder / "dd_host"), str(folder / "dd_host.c"), "-ldl", "-lm"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return folder / "dd_host"


@pytest.mark.parametrize("version", [2, 3])
def test_c_host_without_python_gets_directional_derivatives(fmu_dir, fmu3_dir, dd_host, tmp_path, version):
    """A C program with no Python in it or in its environment: the loader initialises the recorded Python, and
    fmi2/fmi3GetDirectionalDerivative (the GIL taken with PyGILState_Ensure after the loader released it) agree
    with the host's own central differences of the outputs for every FMU, to 1e-6 of scale."""
    import os
    import subprocess

    from fmpy import extract, read_model_description

    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("PYTHON", "PRESSDRIVE_", "VIRTUAL_ENV", "LD_PRELOAD"))}
    platform = "x86_64-linux" if version == 3 else "linux64"
    for name in NAMES:
        fmu = (fmu3_dir if version == 3 else fmu_dir) / f"{name}.fmu"
        folder = Path(extract(str(fmu), unzipdir=str(tmp_path / name)))
        md = read_model_description(str(fmu))
        ins = ",".join(str(v.valueReference) for v in md.modelVariables if v.causality == "input")
        outs = ",".join(str(v.valueReference) for v in md.modelVariables if v.causality == "output")
        u = ",".join(repr(float(x)) for x in _point([v for v in md.modelVariables if v.causality == "input"], 0.3))
        resources = folder / "resources"
        r = subprocess.run([str(dd_host), str(version), str(folder / "binaries" / platform / f"{name}.so"),
                            str(resources), md.guid, ins, outs, u],
                           capture_output=True, text=True, env=env, timeout=300)
        assert r.returncode == 0, f"{name}: exit {r.returncode}: {(r.stdout + r.stderr)[-800:]}"
        dev = float(next(line.split()[1] for line in r.stdout.splitlines() if line.startswith("DEV")))
        assert dev < 1e-6, (name, dev)
