"""A refused parameter value crosses the FMU boundary as data (fmus.refusal), not as message text: every way the
harness calls a toolkit FMU raises harness.errors.ParameterRefused carrying the parameter, value, unit and range."""
from __future__ import annotations

import pytest

from fmus.refusal import CATEGORY, Refusal
from harness.errors import FMUError, ParameterRefused
from harness.fmi import open_instance
from harness.fmi.fmu import ERROR

J_REFUSED = Refusal("J", -1.0, "kg.m2", "must be > 0 kg.m2", low=0.0, high=None, low_open=True, choices=None)


def _refused(path, in_process):
    inst = open_instance(path, "wheel", in_process=in_process)
    inst.set_value("J", -1.0)
    inst.setup(0.0)
    with pytest.raises(ParameterRefused) as info:
        inst.enter_initialization()
        inst.exit_initialization()
    return inst, info.value


@pytest.mark.parametrize("in_process", [False, True], ids=["fmi2-library", "in-process"])
def test_a_refused_parameter_is_a_typed_error_with_its_range(fmu_dir, in_process):
    inst, e = _refused(fmu_dir / "Inertia.fmu", in_process)
    assert e.refusal == J_REFUSED
    assert e.instance == "wheel"
    # the line for people is unchanged, and the record for programs is not in it nor in the log
    assert "wheel (Inertia): parameter J = -1.0 kg.m2 is not admissible: must be > 0 kg.m2" in str(e)
    assert "{" not in str(e) and all(CATEGORY not in text and "{" not in text for _, text in inst.log)


def test_fmi3_refuses_the_same_way(fmu3_dir):
    _, e = _refused(fmu3_dir / "Inertia.fmu", False)
    assert e.refusal == J_REFUSED


def test_the_contract_is_the_category_not_the_text(fmu_dir):
    """A message that merely reads like a refusal is a plain FMUError; a malformed record is an ordinary line."""
    inst = open_instance(fmu_dir / "Inertia.fmu", "lookalike", in_process=False)
    inst._logged(ERROR, "logStatusError", "parameter J = -1.0 kg.m2 is not admissible: must be > 0 kg.m2")
    e = inst._error("fmi2EnterInitializationMode", ERROR)
    assert type(e) is FMUError and "is not admissible" in str(e)
    inst._logged(ERROR, CATEGORY, "not a record")
    assert type(inst._error("fmi2EnterInitializationMode", ERROR)) is FMUError
    inst._logged(0, CATEGORY, J_REFUSED.to_message())
    e = inst._error("fmi2EnterInitializationMode", ERROR)
    assert type(e) is ParameterRefused and e.refusal == J_REFUSED
    inst.free()


def test_a_refusal_round_trips_every_field():
    r = Refusal("mode", 7, "", "must be one of [0, 1]", choices=(0, 1))
    assert Refusal.from_message(r.to_message()) == r
    assert Refusal.from_message('{"parameter": "J"}') is None


def test_simulate_reports_a_refused_parameter_as_bad_input():
    from harness import simulate

    df = simulate("two_inertia", stop_time=0.01, step=1e-3, start_values={"a.J": -1.0})
    assert df.attrs["bad_input"] and not df.attrs["complete"]
    assert df.attrs["error"] == ("system two_inertia: a (Inertia): parameter J = -1.0 kg.m2 is not admissible: "
                                 "must be > 0 kg.m2")
