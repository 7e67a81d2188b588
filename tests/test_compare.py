"""compare: designs of a drive side by side (harness.studies.compare)."""
from __future__ import annotations

import subprocess
import sys

import pytest

from harness import load
from harness.errors import SystemError_
from harness.studies.compare import Variant, check, compare, parse_variant


def test_a_variant_is_a_label_and_values_or_a_result_file(tmp_path):
    assert parse_variant("heavy: flywheel.J_flywheel=16 motor.P_rated=3000") == Variant(
        "heavy", {"flywheel.J_flywheel": 16.0, "motor.P_rated": 3000.0})
    assert parse_variant("as declared:") == Variant("as declared", {})
    f = tmp_path / "r.csv"
    f.write_text("time,x\n0,1\n")
    assert parse_variant(f"saved: {f}") == Variant("saved", result=f)
    for bad, message in (("no colon here", "expected 'LABEL: Instance.param=VALUE"),
                         (": x.y=1", "expected 'LABEL"),
                         ("a: notes.txt", "neither Instance.param=VALUE nor a result file"),
                         (f"a: {tmp_path / 'none.csv'}", "does not exist")):
        with pytest.raises(SystemError_, match=message):
            parse_variant(bad)


@pytest.mark.parametrize("variants, message", [
    (["a: flywheel.J_flywheel=4"], "at least two variants"),
    (["a: flywheel.J_flywheel=4", "a: flywheel.J_flywheel=8"], "variant label 'a' is given twice"),
    (["a:", "b: flywheel.J_flywhel=8"], "did you mean 'J_flywheel'"),
    (["a:", "b: flywhel.J_flywheel=8"], "unknown instance 'flywhel' \\(did you mean 'flywheel'\\?\\)"),
])
def test_bad_variants_are_refused_before_any_run(variants, message):
    with pytest.raises(SystemError_, match=message) as e:
        check(load("bed_drive"), [parse_variant(v) for v in variants])
    assert "\n" not in str(e.value)


def test_the_cli_refuses_a_label_given_twice_in_one_line():
    r = subprocess.run([sys.executable, "-m", "harness", "compare", "bed_drive", "--variant", "x: flywheel.J_flywheel=4",
                        "--variant", "x: flywheel.J_flywheel=8"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 1 and r.stdout == ""
    assert r.stderr.strip() == "error: compare bed_drive: variant label 'x' is given twice", r.stderr


def test_two_designs_side_by_side_and_a_saved_result(tmp_path):
    """The knife drive with its flywheel J1 halved: every quantity's difference and percent change are those of
    the two runs' own quantity tables; a variant read from the first run's saved CSV is that run (difference 0);
    the overlay chart is drawn."""
    from harness.results import write_result

    system = load("spine_knife_rigid")
    result = compare(system, ["paper:", "light J1: shaft.J_flywheel=0.1"], stop_time=0.35)
    f = result.frame()
    a, b = (result.results[k].attrs["quantities"] for k in ("paper", "light J1"))
    checked = 0
    for name in f.index:
        x, y = a[name] if name in a else None, b[name] if name in b else None
        if isinstance(x, float) and isinstance(y, float):
            assert f.loc[name, "light J1 - paper"] == pytest.approx(y - x, abs=1e-12 * max(1.0, abs(x)))
            if x != 0.0:
                assert f.loc[name, "light J1 change %"] == pytest.approx(100 * (y - x) / abs(x), rel=1e-9)
            checked += 1
    assert checked >= 8
    assert f.loc["knife_shaft_twist", "light J1 - paper"] != 0.0     # J1 sets the driven shaft's mode
    saved = write_result(result.results["paper"], tmp_path / "paper.csv", units=True)
    again = compare(system, [Variant("run", {}), Variant("saved", result=saved)], stop_time=0.35)
    g = again.frame()
    numbers = g["saved - run"].dropna()
    assert len(numbers) >= 8 and (numbers.abs() <= 1e-9 * g.loc[numbers.index, "run"].abs().clip(lower=1.0)).all()
    charts = result.plot(tmp_path)
    assert [c.name for c in charts] == ["spine_knife_rigid_compare.png"] and charts[0].stat().st_size > 10_000
    assert "light J1: shaft.J_flywheel = 0.1" in result.table()
