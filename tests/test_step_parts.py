"""The per-FMU-step breakdown (benchmarks.step_parts): its stand-ins make an FMU's Python free in any caller, its
calls-free harness run reaches every instance, its parts and floor follow from the measured variants, and the
profile's parts name the master's pieces."""
from __future__ import annotations

import math

import pytest

from benchmarks import step_parts
from benchmarks.cases import CASES, Case, check_columns, ssp_folder


def _gain_slave():
    from benchmarks.fmu_costs import _slave
    from harness.studies.reference import component_classes

    slave, var = _slave(component_classes()["Gain"], "g", {"k": 2.0, "q0": 1.0})
    slave.setup_experiment(0.0, None, None)
    slave.enter_initialization_mode()
    slave.exit_initialization_mode()
    return slave, var["u"].value_reference, [var["integral"].value_reference, var["y"].value_reference]


def test_free_slave_keeps_the_values_read_at_initialisation():
    slave, u, outs = _gain_slave()
    before = slave.get_real(outs)
    step_parts._free_slave(slave)
    slave.set_real([u], [3.0])
    assert slave.do_step(0.0, 0.1) is True
    assert slave.get_real(outs) == before
    # the same calls on a real slave change the values: the stand-ins are what keeps them
    real, u, outs = _gain_slave()
    real.set_real([u], [3.0])
    real.do_step(0.0, 0.1)
    assert real.get_real(outs) != before


def test_calls_free_harness_run_patches_every_instance(tmp_path):
    case = Case("ring", 1e-3, 30, 30)
    system = CASES["ring"].system()
    folder = ssp_folder(system, tmp_path)
    cols = check_columns(system)
    cpu, fmu_steps = step_parts._harness_run(folder, case, cols, "harness-free")
    assert fmu_steps == 30 * len(system.instances) and cpu > 0
    # a real run of the same case takes the same FMU steps (the stand-ins change values, not the loop)
    assert step_parts._harness_run(folder, case, cols, "harness")[1] == fmu_steps


def test_parts_and_floor_from_the_variants():
    us = {"harness": 30.0, "harness-free": 10.0, "harness-free-nowatch": 6.0, "harness-free-onecol": 9.5,
          "ecos": 25.0, "ecos-free": 8.0}
    p = step_parts.parts({k: {"us": v} for k, v in us.items()})
    assert p["ratio"] == pytest.approx(1.2)
    assert (p["harness_fmus"], p["ecos_fmus"]) == (20.0, 17.0)
    assert (p["watch"], p["recording"]) == (4.0, 0.5)
    assert p["floor_ratio"] == pytest.approx((20.0 + 8.0) / 25.0)
    (what, met, evidence), = step_parts.goal_lines({"bed_drive": p})
    assert met is False and "floor" in evidence and "1.12" in evidence
    failed = step_parts.parts({**{k: {"us": v} for k, v in us.items()}, "ecos": {"error": "x"}})
    assert math.isnan(failed["ratio"]) and step_parts.goal_lines({"x": failed})[0][1] is None


def test_profile_parts_name_the_master_pieces():
    assert step_parts._part("divergence.py", "update") == "divergence watch"
    assert step_parts._part("loop.py", "_hold_all_floats") == "held inputs (extrapolation)"
    assert step_parts._part("loop.py", "_read_all") == "outputs read, history (exchange)"
    assert step_parts._part("loop.py", "_bond_step") == "bonds' power and energy"
    assert step_parts._part("loop.py", "run") == "the loop and the rest"


def test_sweep_parts_summary_and_report():
    from benchmarks import sweep_parts

    def child(first, warm, start):
        pts = [dict(first)] + [dict(warm) for _ in range(3)]
        return {"points": pts, "write": 0.01, "process_cpu": start + sum(p["total"] for p in pts) + 0.01}

    h = sweep_parts._summary(child({"total": 3.0, "load": 0.1, "open": 2.0, "run": 0.8, "rest": 0.1,
                                    "modules_imported": 500},
                                   {"total": 0.6, "load": 0.01, "open": 0.01, "run": 0.57, "rest": 0.01,
                                    "modules_imported": 0}, 1.5))
    o = sweep_parts._summary(child({"total": 2.4, "instantiate": 1.6, "initialize": 0.01, "simulate": 0.75,
                                    "delete": 0.04},
                                   {"total": 1.8, "instantiate": 0.07, "initialize": 0.01, "simulate": 1.71,
                                    "delete": 0.01}, 0.7))
    assert h["outside"] == pytest.approx(1.5) and h["warm_modules"] == 0 and h["warm_mean"] == pytest.approx(0.6)
    text = "\n".join(sweep_parts.report({"drive": "feeder_gto52", "stop": 0.6, "harness": h, "omsimulator": o}))
    ratio = o["total"] / h["total"]
    assert f"{ratio:.2f}x" in text and ("met" if ratio >= 3 else "missed") in text
    assert f"could reach {1.8 / 0.57:.2f}x" in text
