"""Every shipped sweep study (systems/studies/*.yaml) runs from the command line: its grid cut to two values of
the chart's x axis and the first value of every other axis (a sampled one to two points), the rest of the spec (stop time, step, set,
outputs, plot) as shipped.  Slow: about a minute."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
# the sweep specs among the shipped study files (each names its system; a --limits file beside them, a mapping of
# quantities to conditions, names none)
STUDIES = sorted(p for p in (ROOT / "systems" / "studies").glob("*.yaml") if "system" in yaml.safe_load(p.read_text()))


@pytest.mark.slow
@pytest.mark.parametrize("spec", STUDIES, ids=lambda p: p.stem)
def test_a_shipped_sweep_study_runs_from_the_command_line(spec, tmp_path):
    data = yaml.safe_load(spec.read_text())
    x = (data.get("plot") or {}).get("x")
    grid = {}
    if "sample" in data:   # a sampled study (a tolerance study): two points of it
        data["sample"]["n"] = 2
        n = 2
    else:
        for axis, values in data["grid"].items():
            assert isinstance(values, list), f"{spec.name}: axis {axis} is not a list of values"
            grid[axis] = values[:2] if axis == x else values[:1]
        data["grid"] = grid
        n = 1
        for values in grid.values():
            n *= len(values)
    cut = tmp_path / spec.name
    cut.write_text(yaml.safe_dump(data))
    out = tmp_path / "out.csv"
    r = subprocess.run([sys.executable, "-m", "harness", "sweep", data["system"], "--grid", str(cut), "--workers", "0",
                        "--out", str(out), "--plot", str(tmp_path)], capture_output=True, text=True, timeout=900,
                       cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
    df = pd.read_csv(out)
    assert len(df) == n
    for name in data.get("outputs", {}):
        assert name in df.columns and df[name].notna().all(), (name, df.to_string())
    assert list(tmp_path.glob("*.png")), "no chart written"
