"""Our own components' tunable parameters (set between communication steps, FMI 2.0 and 3.0) and their refusal of
an input outside its declared range (the FMU itself answers, whatever its host checks)."""
from __future__ import annotations

import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness import simulate
from harness.errors import SystemError_
from harness.model import Experiment, Instance, System

MODULES = ("pd_inertia", "pd_motor_belt", "pd_torque_load")


@pytest.fixture(scope="module", params=(2, 3), ids=("fmi2", "fmi3"))
def fmus(request) -> tuple[int, Path]:
    """(FMI version, folder) of the toolkit's FMUs (the shared build, tests/build_cache.py)."""
    return request.param, request.getfixturevalue("fmu_dir" if request.param == 2 else "fmu3_dir")


def _variabilities(fmu: Path) -> dict[str, str]:
    with zipfile.ZipFile(fmu) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    out = {}
    for sv in root.find("ModelVariables"):
        if sv.get("causality") == "parameter":
            out[sv.get("name")] = sv.get("variability")
    return out


def test_the_declared_parameters_are_tunable_and_the_others_fixed(fmus):
    from fmus.build import declaration

    _, folder = fmus
    root = Path(__file__).resolve().parents[1] / "fmus" / "components"
    for module in MODULES:
        decl = declaration(root / f"{module}.py")
        found = _variabilities(folder / f"{decl.__name__}.fmu")
        assert decl.tunable, module
        assert {n for n, v in found.items() if v == "tunable"} == set(decl.tunable), (module, found)
        assert all(v == "fixed" for n, v in found.items() if n not in decl.tunable), (module, found)


def test_a_tunable_parameter_steps_mid_run_as_the_closed_form_says(fmus):
    """An inertia's drive torque stepped from T1 to T2 at t_e by a signal on the parameter: the speed is
    T1/J t before and T1/J t_e + T2/J (t - t_e) after, exactly (constant torques integrate exactly)."""
    version, folder = fmus
    J, T1, T2, t_e, h = 0.25, 1.0, -3.0, 0.3, 1e-3
    system = System("tuned", [Instance("a", str(folder / "Inertia.fmu"), {"J": J, "tau_drive": T1})], [],
                    experiment=Experiment(stop_time=0.6, step=h))
    signal = pd.DataFrame({"time": [0.0, t_e, t_e, 0.6], "a.tau_drive": [T1, T1, T2, T2]})
    df = simulate(system, input=signal, on_error="raise")
    t = df.index.to_numpy(dtype=float)
    w = np.where(t <= t_e, T1 / J * t, T1 / J * t_e + T2 / J * (t - t_e))
    np.testing.assert_allclose(df["a.flange.w"].to_numpy(), w, rtol=0, atol=1e-9)
    assert version in (2, 3)


def test_a_fixed_parameter_of_our_fmu_is_still_refused_mid_run(fmus):
    _, folder = fmus
    system = System("fixed", [Instance("a", str(folder / "Inertia.fmu"))], [],
                    experiment=Experiment(stop_time=0.1, step=1e-3))
    with pytest.raises(SystemError_, match=r"parameter J of instance a is not tunable") as e:
        simulate(system, input=pd.DataFrame({"time": [0.0, 0.1], "a.J": [0.01, 0.02]}))
    assert "\n" not in str(e.value)


def test_a_refused_tunable_value_keeps_the_instance_on_its_value_before():
    """A tunable value the model refuses (a negative Coulomb torque) fails the set call through the refusal path,
    and the instance keeps the value it had (in process: the slave itself)."""
    from fmus.build import declaration
    from fmus.slave import fmu_class

    decl = declaration(Path(__file__).resolve().parents[1] / "fmus" / "components" / "pd_torque_load.py")
    slave = fmu_class(decl)(instance_name="load")
    slave.setup_experiment(0.0)
    slave.enter_initialization_mode()
    slave.exit_initialization_mode()
    vr = {v.name: vr for vr, v in slave.vars.items()}
    slave.set_real([vr["T_coulomb"]], [2.0])
    with pytest.raises(RuntimeError, match=r"load \(TorqueLoad\): parameter T_coulomb = -1.0 N.m is not admissible"):
        slave.set_real([vr["T_coulomb"]], [-1.0])
    assert slave.get_real([vr["T_coulomb"]]) == [2.0]
    slave.set_real([vr["flange.w"]], [100.0])
    assert slave.get_real([vr["flange.tau"]]) == [pytest.approx(-2.0)]   # -T_coulomb tanh(w / w_reg)
    with pytest.raises(RuntimeError, match="fixed after initialisation"):
        slave.set_real([vr["c"]], [1.0])


# -- an input outside its declared range, refused by the FMU itself ------------------------------------------------
def _fmpy_run(fmu: Path, supply: float):
    from fmpy import simulate_fmu

    lines = []
    signal = np.array([(0.0, 1.0), (0.05, 1.0), (0.05, supply), (0.1, supply)],
                      dtype=[("time", np.float64), ("supply", np.float64)])
    try:
        simulate_fmu(str(fmu), stop_time=0.1, step_size=1e-3, input=signal, debug_logging=True,
                     logger=lambda *args: lines.append(args[-1].decode() if isinstance(args[-1], bytes)
                                                       else str(args[-1])))
    except Exception as e:  # FMPy raises on an FMI error or fatal status
        return e, lines
    return None, lines


def test_an_fmu_refuses_an_input_outside_its_range_in_fmpy(fmus):
    """FMPy sets the MotorBelt's supply to 2 (declared 0..1.5) at 0.05 s: the FMU answers the step with the
    refused parameter's error path (fatal in FMI 2.0 and 3.0: the exporters' wrappers answer a Python exception so), logging
    one line naming the instance, the variable, the value and the range; within the range the run completes."""
    version, folder = fmus
    fmu = folder / "MotorBelt.fmu"
    error, lines = _fmpy_run(fmu, 1.2)
    assert error is None, error
    error, lines = _fmpy_run(fmu, 2.0)
    assert error is not None
    assert f"fmi{version}DoStep failed with status 4 (fatal)" in str(error), error
    said = [line for line in lines if "outside its declared range" in line]
    assert len(said) == 1, lines
    for part in ("(MotorBelt): input supply = 2.0", "t = 0.05 s", "[0, 1.5]"):
        assert part in said[0], said[0]


def test_the_monolithic_reference_follows_a_tunable_parameter_step(fmus):
    """The reference rebuilds the model where a signal steps a tunable parameter, as the FMU does: a brake-free
    inertia under a load torque stepped at t_e (TorqueLoad's T_const) against the closed form, and the
    co-simulation of the same signal against it."""
    from harness.signals import Signals
    from harness.fmi.cache import model_description
    from harness.model import Connection
    from harness.studies.reference import reference

    version, folder = fmus      # FMI 3.0 too: the reference reads the FMI 3.0 FMUs' descriptions, the run their calls
    J, T0, T1, T2, t_e = 0.5, 4.0, 1.0, 3.0, 0.25
    system = System("loaded", [Instance("a", str(folder / "Inertia.fmu"), {"J": J, "tau_drive": T0}),
                               Instance("load", str(folder / "TorqueLoad.fmu"), {"T_const": T1})],
                    [Connection("a.flange.phi", "load.flange.phi"), Connection("a.flange.w", "load.flange.w"),
                     Connection("load.flange.tau", "a.flange.tau")], experiment=Experiment(stop_time=0.5, step=1e-3))
    signal = pd.DataFrame({"time": [0.0, t_e, t_e, 0.5], "load.T_const": [T1, T1, T2, T2]})
    mds = {i.name: model_description(i.fmu) for i in system.instances}
    ref = reference(system, 0.5, 1e-3, inputs=Signals(system, mds, system.all_connections(mds), signal))
    t = ref.index.to_numpy(dtype=float)
    w = np.where(t <= t_e, (T0 - T1) / J * t, (T0 - T1) / J * t_e + (T0 - T2) / J * (t - t_e))
    np.testing.assert_allclose(ref["a.flange.w"].to_numpy(), w, rtol=0, atol=1e-8)
    df = simulate(system, input=signal, on_error="raise")
    np.testing.assert_allclose(df["a.flange.w"].to_numpy(), w, rtol=0, atol=1e-9)
