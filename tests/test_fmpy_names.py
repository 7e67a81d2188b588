"""simulate() speaks FMPy's language: ``fmpy.simulate_fmu``'s keywords with the same meaning, a single FMU with
its own (unprefixed) variable names, ``output_interval``; checked against ``fmpy.simulate_fmu`` on one
component FMU, and the table of docs/fmpy.md against simulate()'s own argument handling."""
from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness import simulate
from harness.errors import SystemError_

ROOT = Path(__file__).resolve().parents[1]
OUT = ["rocker.phi", "rocker.w", "crank.tau", "transmission_angle"]


def crank_turning(w: float = 2 * np.pi, stop: float = 1.0) -> np.ndarray:
    """FMPy's input array: the crank turned at a constant speed w (angle a ramp)."""
    t = np.linspace(0.0, stop, 11)
    return np.array(list(zip(t, w * t, np.full_like(t, w))),
                    dtype=[("time", float), ("crank.phi", float), ("crank.w", float)])


def quiet(*args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(*args, **kw)


def fmpy_frame(fmu, instance: str, **kw) -> pd.DataFrame:
    from fmpy import simulate_fmu

    ref = pd.DataFrame(simulate_fmu(str(fmu), **kw)).set_index("time")
    ref.columns = [f"{instance}.{c}" for c in ref.columns]
    return ref


def test_fmpy_keywords_give_fmpys_result_on_a_component_fmu(fmu_dir):
    """The same call as fmpy.simulate_fmu on FourBar.fmu (unprefixed start values, outputs and input columns,
    start and stop time, step, tolerance): the same rows, to rounding."""
    fmu = fmu_dir / "FourBar.fmu"
    kw = dict(start_time=0.0, stop_time=1.0, relative_tolerance=1e-6, start_values={"crank_length": 0.09},
              input=crank_turning(), output=OUT)
    df = quiet(fmu, step_size=1e-3, output_interval=1e-3, **kw)
    ref = fmpy_frame(fmu, "FourBar", output_interval=1e-3, **kw)  # FMPy steps a CS FMU at its output interval
    assert list(df.columns) == [f"FourBar.{c}" for c in OUT] and df.attrs["complete"]
    assert len(df) == len(ref) == 1001
    np.testing.assert_allclose(df.index, ref.index, rtol=0, atol=1e-12)
    np.testing.assert_allclose(df.to_numpy(), ref[df.columns].to_numpy(), rtol=1e-12, atol=1e-12)
    # the start value reached the FMU: the rocker's swing differs from the FMU's own crank length
    own = quiet(fmu, step_size=1e-3, stop_time=1.0, input=crank_turning(), output=OUT)
    assert np.ptp(own["FourBar.rocker.phi"]) - np.ptp(df["FourBar.rocker.phi"]) > 0.01


def test_output_interval_records_every_nth_point_and_the_end(fmu_dir):
    fmu = fmu_dir / "FourBar.fmu"
    h = 1e-3
    fine = quiet(fmu, stop_time=1.0, step_size=h, input=crank_turning(), output=OUT)
    every5 = quiet(fmu, stop_time=1.0, step_size=h, output_interval=5 * h, input=crank_turning(), output=OUT)
    assert len(every5) == 201 and every5.attrs["output_interval"] == pytest.approx(5 * h)
    np.testing.assert_array_equal(every5.to_numpy(), fine.to_numpy()[::5])  # the same run, sampled
    odd = quiet(fmu, stop_time=1.0, step_size=h, output_interval=0.3, input=crank_turning(), output=OUT)
    assert odd.index.tolist() == pytest.approx([0.0, 0.3, 0.6, 0.9, 1.0])  # the end of the run is kept
    # only the interval given: FMPy's co-simulation step, one step per output interval
    alone = quiet(fmu, stop_time=1.0, output_interval=5 * h, input=crank_turning(), output=OUT)
    assert alone.attrs["step"] == pytest.approx(5 * h) and alone.attrs["steps"] == 200
    ref = fmpy_frame(fmu, "FourBar", stop_time=1.0, output_interval=5 * h, input=crank_turning(), output=OUT)
    np.testing.assert_allclose(alone.to_numpy(), ref[alone.columns].to_numpy(), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("kw, match", [
    (dict(step_size=1e-3, output_interval=1.5e-3), r"output_interval = 0.0015 s is not a whole multiple of "
                                                   r"step = 0.001 s: the result holds communication points"),
    (dict(step_size=1e-3, output_interval=5e-4), r"output_interval = 0.0005 s is not a whole multiple"),
    (dict(step_size=1e-3, output_interval=-1.0), r"output_interval = -1.0 is not admissible"),
    (dict(step_size=1e-3, output_interval=2e-3, step_control="richardson", tolerance=1e-4),
     r"output_interval = 0.002 s needs a fixed step: under step_control = 'richardson'"),
])
def test_an_output_interval_that_cannot_be_kept_is_refused_saying_why(fmu_dir, kw, match):
    with pytest.raises(SystemError_, match=match):
        quiet(fmu_dir / "Gain.fmu", stop_time=0.1, **kw)


def test_fmpy_aliases_are_the_toolkits_arguments_and_conflicts_are_refused(fmu_dir):
    fmu = fmu_dir / "Gain.fmu"
    a = quiet(fmu, stop_time=0.05, step_size=1e-3, relative_tolerance=1e-5, start_values={"q0": 1.0})
    b = quiet(fmu, stop_time=0.05, step=1e-3, tolerance=1e-5, start_values={"Gain.q0": 1.0})
    assert a.equals(b) and a.attrs["tolerance"] == 1e-5 and a["Gain.integral"].iloc[0] == 1.0
    with pytest.raises(TypeError, match=r"step_size= and step= are the same argument .*: give one"):
        simulate(fmu, stop_time=0.05, step=1e-3, step_size=1e-3)
    with pytest.raises(TypeError, match=r"relative_tolerance= and tolerance= are the same argument"):
        simulate(fmu, stop_time=0.05, step=1e-3, tolerance=1e-3, relative_tolerance=1e-3)
    with pytest.raises(TypeError, match=r"no argument 'solver' \(fmpy.simulate_fmu's\): a model exchange FMU"):
        simulate(fmu, stop_time=0.05, step=1e-3, solver="CVode")
    with pytest.raises(TypeError, match="unexpected keyword argument 'stepsize'"):
        simulate(fmu, stop_time=0.05, step=1e-3, stepsize=1e-3)


def test_unprefixed_names_only_where_one_fmu_makes_them_unambiguous(fmu_dir):
    fmu = fmu_dir / "Gain.fmu"
    df = quiet(fmu, stop_time=0.01, step=1e-3, output=["integral", "Gain.y"])
    assert list(df.columns) == ["Gain.integral", "Gain.y"]          # the one result type: Instance.variable
    with pytest.raises(SystemError_, match=r"output 'Gain.nothing': FMU Gain of instance Gain has no variable"):
        quiet(fmu, stop_time=0.01, step=1e-3, output=["nothing"])
    with pytest.raises(SystemError_, match="parameter 'w0' must be written 'Instance.parameter'"):
        quiet("two_inertia", stop_time=0.01, start_values={"w0": 1.0})  # two instances: which one?


def test_simulate_docstring_names_every_master():
    from harness.master import MASTERS

    doc = simulate.__doc__
    missing = [m for m in MASTERS if f'``"{m}"``' not in doc]
    assert not missing, f"simulate()'s docstring does not name the masters {missing}"


# -- the docs table -----------------------------------------------------------------------------------------------
def _table_rows(page: Path) -> dict[str, str]:
    """FMPy argument -> the row's text, from the first table of docs/fmpy.md whose first column is FMPy's."""
    rows = {}
    for line in page.read_text(encoding="utf-8").splitlines():
        m = re.match(r"^\|\s*`(\w+)`\s*\|(.*)\|\s*$", line)
        if m:
            rows.setdefault(m.group(1), m.group(2))
    return rows


def test_the_docs_table_maps_every_fmpy_argument_and_matches_simulate():
    """Every argument of fmpy.simulate_fmu has a row; an argument the page says works is accepted by
    simulate(), one it marks "not a keyword here" is refused by simulate() with a reason."""
    import inspect

    from fmpy import simulate_fmu

    from harness import run

    rows = _table_rows(ROOT / "docs" / "fmpy.md")
    fmpy_args = list(inspect.signature(simulate_fmu).parameters)
    assert not [a for a in fmpy_args if a not in rows], "docs/fmpy.md lacks rows for some FMPy arguments"
    ours = set(inspect.signature(simulate).parameters) | set(run._ALIASES)
    for name in fmpy_args:
        if name == "filename":
            continue
        if name in ours:
            assert "not a keyword here" not in rows[name], name
        else:
            assert name in run._FMPY_ONLY and "not a keyword here" in rows[name], name


def test_the_pages_python_example_runs(fmu_dir, tmp_path, monkeypatch, capsys):
    """docs/fmpy.md's example, as printed, next to a build/fmus folder holding the FMUs."""
    page = (ROOT / "docs" / "fmpy.md").read_text(encoding="utf-8")
    examples = re.findall(r"^```python\n(.*?)^```", page, re.M | re.S)
    assert examples
    (tmp_path / "build").mkdir()
    (tmp_path / "build" / "fmus").symlink_to(fmu_dir)
    monkeypatch.chdir(tmp_path)
    for example in examples:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            exec(compile(example, "docs/fmpy.md", "exec"), {})  # noqa: S102 (the page's own example)
    assert capsys.readouterr().out.strip()
