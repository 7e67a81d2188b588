"""Each FMU at its own rate (harness/master/multirate.py, issue 60), on the two-inertia benchmark.

What is checked, against the definitions in the module's docstring (closed forms of the extrapolation
polynomial; libcosim's agreement is in tests/test_osp.py):

* an instance declaring the base step as its own runs bit for bit as one declaring none (the single-rate
  path is untouched);
* a slow instance's values stay those of its last point between its points (outputs and other columns);
* the slow side's held input is the newest sample of its source at the start of its step (order 0), or the
  line through the two newest samples at the middle of its own step (order 1);
* a fast instance extrapolates a slow source through the slow source's own samples, a slow step apart;
* the FMU steps counted are each instance's own;
* masters and step controls that cannot hold rates refuse in one line, by name;
* an SSP keeps each instance's step (OSP's osp:StepSizeHint) both ways.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from harness import RunOptions, load, simulate
from harness.errors import SystemDescriptionError
from harness.master.observers import Observer

H = 1e-3
STOP = 0.06
COLS = ["a.flange.phi", "a.flange.w", "b.drive.tau", "b.drive.phi", "b.phi"]   # b.drive.phi: b's held input


@pytest.fixture(scope="module")
def pair(fmu_dir):
    return load("two_inertia").on_fmus(fmu_dir)


def _with_steps(system, **steps):
    return replace(system, instances=[replace(i, step=steps.get(i.name)) for i in system.instances])


def _run(system, master, extrapolation=0, **kw):
    return simulate(system, stop_time=STOP, step=H, master=master, extrapolation=extrapolation, output=COLS, **kw)


class HeldInput(Observer):
    """b's held drive.phi over the step that ends at each point (the master's ``u``; the recorded input is
    the one a feed-through refresh set at the point)."""

    def __init__(self):
        self.held = [np.nan]

    def on_step(self, master, t_prev_ns, t_ns):
        it = master.insts[master.index["b"]]
        self.held.append(float(master.u[it.input_slice.start + it.input_pos["drive.phi"]]))


def _held(system, extrapolation):
    watch = HeldInput()
    df = _run(system, "jacobi", extrapolation, options=RunOptions(observers=(watch,)))
    return df["a.flange.phi"].to_numpy(), np.array(watch.held)


@pytest.mark.parametrize("master", ["jacobi", "jacobi-sampled", "gauss-seidel"])
def test_the_base_step_declared_as_an_instance_step_changes_nothing(pair, master):
    plain = _run(pair, master)
    declared = _run(_with_steps(pair, a=H, b=H), master)
    assert declared.equals(plain) and "rates" not in declared.attrs


def test_a_slow_instance_keeps_its_values_between_its_points_and_steps_less(pair):
    df = _run(_with_steps(pair, b=3 * H), "jacobi")
    assert df.attrs["rates"] == {"b": 3}
    assert df.attrs["fmu_steps"] == round(STOP / H) + round(STOP / (3 * H))   # a every step, b every third
    k = np.arange(len(df))
    between = k % 3 != 0
    for col in ("b.drive.tau", "b.phi", "b.drive.phi"):   # an output, a local, an input: each from b's last point
        v = df[col].to_numpy()
        assert np.array_equal(v[between], v[k[between] - k[between] % 3]), col
    assert not np.array_equal(df["b.phi"].to_numpy()[3::3], df["b.phi"].to_numpy()[:-3:3])   # it does move


def test_the_slow_side_holds_the_newest_sample_at_the_start_of_its_step(pair):
    phi, held = _held(_with_steps(pair, b=2 * H), 0)
    # b's step [t, t + 2H] (t = 2kH) holds a's sample at t, over both base steps
    t = np.arange(0, len(phi) - 2, 2)
    assert np.array_equal(held[t + 1], phi[t]) and np.array_equal(held[t + 2], phi[t])


def test_the_slow_side_extrapolates_to_the_middle_of_its_own_step(pair):
    phi, held = _held(_with_steps(pair, b=2 * H), 1)
    # b's step [t, t + 2H]: the line through a's samples at t - H and t, at t + H: 2 phi(t) - phi(t - H)
    t = np.arange(2, len(phi) - 2, 2)
    assert held[t + 1] == pytest.approx(2 * phi[t] - phi[t - 1], rel=1e-12, abs=1e-15)
    assert np.array_equal(held[t + 1], held[t + 2])


def test_a_fast_instance_extrapolates_a_slow_source_through_its_own_samples(pair):
    phi, held = _held(_with_steps(pair, a=2 * H), 1)
    # b's step [t0, t0 + H] (t0 a point of a): the line through a's samples at t0 - 2H and t0, at t0 + H/2;
    # its step [t0 + H, t0 + 2H]: the same line at t0 + 1.5 H (a's sample at t0 + H does not exist)
    t0 = np.arange(2, len(phi) - 2, 2)
    assert held[t0 + 1] == pytest.approx(phi[t0] + 0.25 * (phi[t0] - phi[t0 - 2]), rel=1e-12, abs=1e-15)
    assert held[t0 + 2] == pytest.approx(phi[t0] + 0.75 * (phi[t0] - phi[t0 - 2]), rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("master", ["iterative", "jacobian"])
def test_masters_that_cannot_hold_rates_refuse_by_name(pair, master):
    with pytest.raises(SystemDescriptionError) as e:
        _run(_with_steps(pair, b=2 * H), master)
    msg = str(e.value)
    assert "\n" not in msg and f"master {master!r} cannot step instances at their own rates: b (every 2 steps)" in msg
    assert "use one of gauss-seidel, jacobi, jacobi-sampled" in msg


def test_a_variable_step_and_sampled_extrapolation_refuse_rates(pair):
    slow = _with_steps(pair, b=2 * H)
    with pytest.raises(SystemDescriptionError, match="step_control = 'ecco' varies the step, but instances b step"):
        _run(slow, "jacobi", step_control="ecco")
    with pytest.raises(SystemDescriptionError, match="'jacobi-sampled' holds each value .* extrapolation 0, not 1"):
        _run(slow, "jacobi-sampled", extrapolation=1)


def test_an_ssp_keeps_each_instance_step(pair, tmp_path):
    from harness.ssp import export_ssp, load_ssp

    back = load_ssp(export_ssp(_with_steps(pair, b=2 * H), tmp_path / "pair.ssp"))
    assert [(i.name, i.step) for i in back.instances] == [("a", None), ("b", 2 * H)]


def test_an_experiments_rates_go_with_its_master_and_step(pair):
    declared = replace(pair, experiment=replace(pair.experiment, master="jacobi", step=H, rates={"b": 2}))
    assert simulate(declared, stop_time=STOP).attrs["rates"] == {"b": 2}
    assert "rates" not in simulate(declared, stop_time=STOP, step=H / 2).attrs          # another step
    assert "rates" not in simulate(declared, stop_time=STOP, master="gauss-seidel").attrs   # another master
    wrong = replace(declared, experiment=replace(declared.experiment, rates={"c": 2}))
    with pytest.raises(SystemDescriptionError, match="experiment rates c=2: must name an instance"):
        simulate(wrong, stop_time=STOP)
