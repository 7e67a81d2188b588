"""Input signals, FMPy's way (``simulate(..., input=...)``, ``run --input FILE.csv``): a ramp and a step into a
free input, against closed forms and against ``fmpy.simulate_fmu`` with the same input array; every FMI type
held or interpolated as FMPy's ``Input`` does (the Reference-FMUs' Feedthrough); a driven input through a
connection under every master; the refusals, each one line before the run."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness import simulate
from harness.errors import SystemError_
from harness.master import MASTERS
from harness.model import Connection, Experiment, Instance, System
from harness.signals import Signals

from foreign_builds import plain_lag

ROOT = Path(__file__).resolve().parents[1]
H = 1e-2
T_STEP = 0.5


def quiet(*args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(*args, **kw)


def ramp_then_step() -> np.ndarray:
    """u = t up to 0.5 s (a ramp, interpolated between its rows), then a step to 3 held to the end."""
    return np.array([(0.0, 0.0), (T_STEP, T_STEP), (T_STEP, 3.0), (1.0, 3.0)], dtype=[("time", float), ("u", float)])


def u_closed(t):
    return np.where(t < T_STEP - 1e-12, t, 3.0)


def test_a_ramp_and_a_step_into_a_component_fmu_match_the_closed_form_and_fmpy(fmu_dir):
    """Gain.fmu: y = k u (feed-through), integral = the integral of the held input.  A row at t holds what the
    step that ended at t computed (u set at t - h and held over the step), as FMPy records it."""
    from fmpy import simulate_fmu

    fmu = fmu_dir / "Gain.fmu"
    df = quiet(fmu, stop_time=1.0, step_size=H, input=ramp_then_step(), start_values={"k": 2.0},
               output=["u", "y", "integral"])
    t = df.index.to_numpy()
    held = u_closed(np.maximum(t - H, 0.0))               # the value set at the start of the step ending at t
    np.testing.assert_allclose(df["Gain.u"], held, rtol=0, atol=1e-12)
    np.testing.assert_allclose(df["Gain.y"], 2.0 * held, rtol=0, atol=1e-12)
    n = np.rint(t / H).astype(int)
    integral = np.array([H * u_closed(np.arange(k) * H).sum() for k in n])   # zero-order hold, exactly
    np.testing.assert_allclose(df["Gain.integral"], integral, rtol=0, atol=1e-12)
    assert df["Gain.integral"].iloc[-1] == pytest.approx(0.5 * T_STEP ** 2 + 3.0 * (1.0 - T_STEP) - 0.5 * H * T_STEP,
                                                         abs=1e-9)
    ref = pd.DataFrame(simulate_fmu(str(fmu), stop_time=1.0, output_interval=H, input=ramp_then_step(),
                                    start_values={"k": 2.0}, output=["u", "y", "integral"])).set_index("time")
    np.testing.assert_allclose(df.to_numpy(), ref[["u", "y", "integral"]].to_numpy(), rtol=0, atol=1e-12)


@pytest.mark.parametrize("master", list(MASTERS))
def test_a_driven_input_passes_through_a_connection_without_lag_under_every_master(master):
    """A signal into Gain g whose output torques inertia a: a torque step T at t_e accelerates a at T/J from
    t_e on (the point is refreshed after the signal is set, so no master hands the torque on a step late)."""
    J, T = 0.5, 2.0
    system = System("torque_step", [Instance("g", "Gain", {"k": 1.0}), Instance("a", "Inertia", {"J": J})],
                    [Connection("g.y", "a.flange.tau", unit_conversion=True)], experiment=Experiment(1.0, H))
    signal = pd.DataFrame({"time": [0.0, T_STEP, T_STEP, 1.0], "g.u": [0.0, 0.0, T, T]})
    df = quiet(system, master=master, input=signal)
    t = df.index.to_numpy()
    w = np.where(t > T_STEP, (t - T_STEP) * T / J, 0.0)
    assert df.attrs["complete"] and df.attrs["inputs"] == ["g.u"]
    np.testing.assert_allclose(df["a.flange.w"], w, rtol=0, atol=1e-9)


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel", "jacobian"])
def test_no_coupling_signal_is_extrapolated_across_an_input_step(master, order):
    """The same torque step with extrapolation order 1 and 2: the coupling's history restarts at the step, so
    the torque held over the first step after it is T, not T plus the jump extrapolated across it (which
    would put w off by T/J h/2 at order 1)."""
    J, T = 0.5, 2.0
    system = System("torque_step", [Instance("g", "Gain", {"k": 1.0}), Instance("a", "Inertia", {"J": J})],
                    [Connection("g.y", "a.flange.tau", unit_conversion=True)], experiment=Experiment(1.0, H))
    signal = pd.DataFrame({"time": [0.0, T_STEP, T_STEP, 1.0], "g.u": [0.0, 0.0, T, T]})
    df = quiet(system, master=master, input=signal, extrapolation=order)
    t = df.index.to_numpy()
    np.testing.assert_allclose(df["a.flange.w"], np.where(t > T_STEP, (t - T_STEP) * T / J, 0.0), rtol=0, atol=1e-9)


def test_rows_at_one_time_and_the_table_ends_follow_fmpys_input():
    """The interpolation rules on a table alone (FMPy's Input.interpolate, compared value for value)."""
    from fmpy.simulation import Input

    times = np.array([0.1, 0.3, 0.3, 0.6, 0.8, 0.8, 0.8])
    cont = np.array([1.0, 2.0, 5.0, 4.0, 0.0, 7.0, 9.0])
    system = System("one", [Instance("m", "x.fmu")])
    v_cont = type("V", (), dict(name="c", causality="input", variability="continuous", type="Real", min=None,
                                max=None))
    v_disc = type("V", (), dict(name="d", causality="input", variability="discrete", type="Real", min=None,
                                max=None))
    md = type("MD", (), dict(modelName="X", modelVariables=[v_cont, v_disc]))
    sig = Signals(system, {"m": md}, [], pd.DataFrame({"time": times, "c": cont, "d": cont}))
    for t in [0.0, 0.1, 0.2, 0.3, 0.45, 0.6, 0.7, 0.8, 0.9]:
        t_ns = round(t * 1e9)
        for after in (False, True):
            ours = sig.values(t_ns, after_event=after)
            fc, _ = Input.interpolate(t, times, cont[None, :], discrete=False, after_event=after)
            fd, _ = Input.interpolate(t, times, cont[None, :], discrete=True, after_event=after)
            assert ours[0] == pytest.approx(float(fc[0]), abs=1e-12), (t, after)
            assert ours[1] == pytest.approx(float(fd[0]), abs=1e-12), (t, after)


# -- every FMI type, against FMPy: the Reference-FMUs' Feedthrough --------------------------------------------------
@pytest.fixture(scope="module")
def feedthrough() -> Path:
    from reference_builds import reference_fmus   # the one build of tests/reference_fmus

    return reference_fmus(2)["Feedthrough"]


TYPED = np.array([(0.0, 0.0, 0.0, 0, False, 1), (0.25, 1.0, 1.0, 2, True, 2), (0.5, 0.0, 0.5, 2, True, 2),
                  (0.5, 2.0, 3.0, -4, False, 1), (1.0, 2.0, 3.0, -4, False, 1)],
                 dtype=[("time", float), ("Float64_continuous_input", float), ("Float64_discrete_input", float),
                        ("Int32_input", np.int32), ("Boolean_input", np.bool_), ("Enumeration_input", np.int32)])


def test_every_type_is_interpolated_or_held_as_fmpy_does(feedthrough):
    from fmpy import simulate_fmu

    names = [n for n in TYPED.dtype.names if n != "time"]
    outputs = [n.replace("_input", "_output") for n in names]
    h = 0.05
    df = quiet(feedthrough, stop_time=1.0, step_size=h, input=TYPED, output=outputs)
    ref = pd.DataFrame(simulate_fmu(str(feedthrough), stop_time=1.0, output_interval=h, input=TYPED,
                                    output=outputs)).set_index("time")
    assert len(df) == len(ref) == 21
    for name in outputs:
        np.testing.assert_allclose(df[f"Feedthrough.{name}"].to_numpy(dtype=float),
                                   ref[name].to_numpy(dtype=float), rtol=0, atol=1e-12, err_msg=name)
    # the closed form: a row at t shows the value set at t - h; the continuous input linear between rows
    t_set = np.maximum(df.index.to_numpy() - h, 0.0)
    cont = np.where(t_set < 0.25, 4.0 * t_set, np.where(t_set < 0.5, 1.0 - 4.0 * (t_set - 0.25), 2.0))
    np.testing.assert_allclose(df["Feedthrough.Float64_continuous_output"], cont, atol=1e-12)
    held = np.where(t_set < 0.25 - 1e-12, 0, np.where(t_set < 0.5 - 1e-12, 2, -4))
    np.testing.assert_array_equal(df["Feedthrough.Int32_output"], held)


def test_a_string_input_is_held(feedthrough):
    signal = pd.DataFrame({"time": [0.0, 0.3], "String_input": ["first", "second"]})
    df = quiet(feedthrough, stop_time=0.5, step_size=0.1, input=signal, output=["String_output"])
    assert df["Feedthrough.String_output"].tolist() == ["first", "first", "first", "first", "second", "second"]


# -- refusals: one line, before the run --------------------------------------------------------------------------
def _table(**columns):
    return pd.DataFrame({"time": [0.0, 1.0], **columns})


@pytest.mark.parametrize("system, signal, message", [
    ("two_inertia", _table(**{"b.drive.phi": [0.0, 1.0]}),
     "input signal 'b.drive.phi': input b.drive.phi is connected from a.flange.phi; a signal drives a free input "
     "only (free inputs of b: none)"),
    ("two_inertia", _table(**{"a.flange.w": [0.0, 1.0]}),
     "input signal 'a.flange.w': flange.w of instance a is an output, not an input"),
    ("two_inertia", _table(**{"c.u": [0.0, 1.0]}), "input signal 'c.u': unknown instance 'c' (instances: a, b"),
    ("Gain", _table(uu=[0.0, 1.0]),
     "input signal 'uu': FMU Gain of instance Gain has no variable 'uu' (did you mean 'u'?); free inputs of Gain: u"),
    ("Gain", _table(k=[0.0, 1.0]), "input signal 'k': parameter k of instance Gain is not tunable (its FMU "
                                   "declares variability 'fixed'): it cannot change during the run"),
    ("Gain", _table(u=[0.0, np.nan]), "input signal 'Gain.u' = nan at t = 1 s: not a finite number"),
    ("Gain", pd.DataFrame({"time": [0.0, 0.5, 0.4], "u": [0, 1, 2]}),
     "input: the time column decreases in row 3 (0.4 s after 0.5 s)"),
    ("Gain", pd.DataFrame({"t": [0.0], "u": [0.0]}), "input: no 'time' column (columns: t, u)"),
    ("Gain", pd.DataFrame({"time": [0.0]}), "input: no column besides 'time'"),
    ("Gain", [(0.0, 1.0)], "input: list is not an input table"),
    ("Gain", "no_such_file.csv", "input file no_such_file.csv does not exist"),
])
def test_a_signal_that_cannot_be_applied_is_refused_in_one_line(fmu_dir, system, signal, message):
    if system == "Gain":
        system = fmu_dir / "Gain.fmu"
    with pytest.raises(SystemError_) as err:
        quiet(system, stop_time=0.1, step=0.01, input=signal)
    text = str(err.value)
    assert message in text and "\n" not in text, text


def test_a_value_not_of_the_inputs_type_is_refused(feedthrough):
    with pytest.raises(SystemError_, match=r"input signal 'Feedthrough.Int32_input' = 1.5 at t = 1 s: not an "
                                           r"integer \(Int32_input is Integer\)"):
        quiet(feedthrough, stop_time=0.1, step=0.01, input=_table(Int32_input=[1.0, 1.5]))
    with pytest.raises(SystemError_, match=r"'Feedthrough.Enumeration_input' = 3 at t = 1 s: not one of the values "
                                           r"of its enumeration \(1 = Option 1, 2 = Option 2\)"):
        quiet(feedthrough, stop_time=0.1, step=0.01, input=_table(Enumeration_input=[1, 3]))
    with pytest.raises(SystemError_, match=r"'Feedthrough.Boolean_input' = 2 at t = 1 s: not a Boolean"):
        quiet(feedthrough, stop_time=0.1, step=0.01, input=_table(Boolean_input=[1, 2]))


# -- the command line ------------------------------------------------------------------------------------------
def test_run_input_file_from_the_command_line(fmu_dir, tmp_path, monkeypatch, capsys):
    from harness.__main__ import main

    monkeypatch.setattr(warnings, "showwarning", warnings.showwarning)  # main() sets its own
    csv = tmp_path / "u.csv"
    pd.DataFrame(ramp_then_step()).to_csv(csv, index=False)
    out = tmp_path / "r.csv"
    status = main(["run", str(fmu_dir / "Gain.fmu"), "--stop-time", "1", "--step-size", "0.01", "--output-interval",
                   "0.1", "--input", str(csv), "--out", str(out)])
    assert status == 0, capsys.readouterr().err
    df = pd.read_csv(out, index_col=0)
    assert len(df) == 11
    t = df.index.to_numpy()
    np.testing.assert_allclose(df["Gain.y"], 0.5 * u_closed(np.maximum(t - H, 0.0)), atol=1e-12)  # k = 0.5
    bad = tmp_path / "bad.csv"
    bad.write_text("time,u2\n0,1\n")
    status = main(["run", str(fmu_dir / "Gain.fmu"), "--stop-time", "1", "--step", "0.01", "--input", str(bad)])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 1 and len(err) == 1 and err[0].startswith("error: input signal 'u2'") and "did you mean 'u'" in err[0]


# -- declared ranges: the motor's supply and brake, and a foreign FMU's min/max ------------------------------------
def test_the_motor_declares_its_inputs_ranges_and_an_out_of_range_signal_is_refused_in_one_line(tmp_path):
    from harness import load
    from harness.fmi.cache import model_description
    from harness.model import resolve_fmu

    system = load("bed_drive")
    md = model_description(resolve_fmu(system.instance("motor").fmu))
    declared = {v.name: (float(v.min), float(v.max)) for v in md.modelVariables if v.name in ("supply", "brake")}
    assert declared == {"supply": (0.0, 1.5), "brake": (0.0, 1.0)}
    f = tmp_path / "fast.csv"
    f.write_text("time,motor.supply\n0,1\n0.001,1.6\n")
    with pytest.raises(SystemError_) as e:
        simulate(system, input=str(f), stop_time=0.002)
    text = str(e.value)
    assert "\n" not in text
    for part in (f"input file {f}", "'motor.supply' = 1.6", "t = 0.001 s", "[0, 1.5]", "FMU MotorBelt of instance motor"):
        assert part in text, (part, text)
    # a scenario's value out of range: refused before the run, naming the scenario's file
    sc = tmp_path / "over.yaml"
    sc.write_text("name: over\nkind: speed_change\nstop_time: 1.0\n"
                  "changes:\n  - {time: 0.5, variable: motor.brake, value: 2.0}\n")
    from harness import simulate_scenario

    with pytest.raises(SystemError_) as e:
        simulate_scenario(system, str(sc))
    text = str(e.value)
    assert "\n" not in text
    for part in (f"scenario file {sc}", "scenario over", "motor.brake", "value 2", "[0, 1]",
                 "FMU MotorBelt of instance motor"):
        assert part in text, (part, text)


def test_a_foreign_fmus_declared_input_range_is_honoured(tmp_path):
    """A foreign FMU (plain pythonfmu, its modelDescription given min = -1, max = 1 on its input u): a signal
    inside runs, one outside is refused in one line naming the FMU, instance, variable, value and range."""
    import zipfile

    built = plain_lag()
    fmu = tmp_path / "RangedLag.fmu"
    with zipfile.ZipFile(built) as src, zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "modelDescription.xml":
                text = data.decode()
                head, _, tail = text.partition('name="u"')
                body, sep, rest = tail.partition("/>")
                assert "<Real" in body
                data = (head + 'name="u"' + body.replace("<Real", '<Real min="-1" max="1"', 1) + sep + rest).encode()
            dst.writestr(item, data)
    system = System("ranged", [Instance("lag", str(fmu))], [], experiment=Experiment(stop_time=0.05, step=0.01))
    ok = pd.DataFrame({"time": [0.0, 0.05], "lag.u": [0.0, 1.0]})
    df = quiet(system, input=ok)
    assert df.attrs.get("complete", True) and df["lag.y"].abs().max() > 0
    bad = pd.DataFrame({"time": [0.0, 0.05], "lag.u": [0.0, 1.5]})
    with pytest.raises(SystemError_) as e:
        simulate(system, input=bad)
    text = str(e.value)
    assert "\n" not in text
    for part in ("'lag.u' = 1.5", "t = 0.05 s", "[-1, 1]", "FMU PlainLag of instance lag", "for u"):
        assert part in text, (part, text)


# -- events under step control: a communication point on the event, the step restarted there -----------------------
def test_a_variable_step_lands_on_an_input_step_and_restarts_its_step_there():
    """Under richardson (no coupling error here: its step grows by its largest factor) a torque step at an instant off any
    grid: a communication point falls on it, the step after it is the run's initial step again, and the
    inertia's speed is the closed form w = T/J (t - t_e) to 1e-9 (a step across the event would smear it)."""
    J, T, t_e, h = 0.5, 2.0, 0.3337, 1e-3
    system = System("torque_step", [Instance("g", "Gain", {"k": 1.0}), Instance("a", "Inertia", {"J": J})],
                    [Connection("g.y", "a.flange.tau", unit_conversion=True)], experiment=Experiment(1.0, h))
    signal = pd.DataFrame({"time": [0.0, t_e, t_e, 1.0], "g.u": [0.0, 0.0, T, T]})
    df = quiet(system, input=signal, step_control="richardson")
    t = df.index.to_numpy()
    k = int(np.flatnonzero(np.isclose(t, t_e, rtol=0, atol=1e-9))[0])   # a row on the event
    assert t[k + 1] - t[k] == pytest.approx(h, abs=1e-9)                  # the step restarted at the run's step
    assert t[k] - t[k - 1] > 2 * h                                        # it had grown before the event
    np.testing.assert_allclose(df["a.flange.w"], np.where(t > t_e, (t - t_e) * T / J, 0.0), rtol=0, atol=1e-9)


def test_a_tunable_parameter_changes_mid_run_through_set_real(tmp_path):
    """A foreign FMU's tunable parameter (plain pythonfmu's lag, k declared tunable) stepped at 1 s by a signal:
    set between communication steps and held, the lag follows explicit Euler with k before and after exactly;
    its fixed-parameter counterpart in our FMUs is refused (the Gain case above)."""
    fmu = plain_lag()
    h, t_e = 0.01, 1.0
    system = System("lag", [Instance("lag", str(fmu))], [], experiment=Experiment(stop_time=2.0, step=h))
    signal = pd.DataFrame({"time": [0.0, t_e, t_e, 2.0], "lag.u": [1.0] * 4, "lag.k": [-0.5, -0.5, 2.0, 2.0]})
    df = quiet(system, input=signal)
    y, expected = 0.0, [0.0]
    for n in range(200):
        k = -0.5 if n * h < t_e - 1e-12 else 2.0
        y += h * (k * 1.0 - y) / 1.0
        expected.append(y)
    np.testing.assert_allclose(df["lag.y"].to_numpy(), expected, rtol=0, atol=1e-12)
