"""Quantities of interest (harness.reporting.qoi): every function against an independent numpy/closed-form value."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from harness.reporting import qoi

N = 1001
T = np.linspace(0.0, 1.0, N)


def frame(**cols) -> pd.DataFrame:
    return pd.DataFrame(cols, index=pd.Index(T, name="time"))


@pytest.fixture
def df():
    return frame(**{"a.x": np.sin(2 * np.pi * T), "a.y": 3.0 * T - 1.0})


def test_peak_and_window(df):
    # |sin| over [0, 0.5] peaks at t = 0.25, a sample point: exactly 1
    assert qoi.evaluate('peak(window(r["a.x"], 0.0, 0.5))', df) == pytest.approx(1.0, abs=1e-15)
    # the window is inclusive at both ends: 3t - 1 on [0.2, 0.4] has max 0.2 and min -0.4
    assert qoi.evaluate('max(window(r["a.y"], 0.2, 0.4))', df) == pytest.approx(0.2, abs=1e-12)
    assert qoi.evaluate('min(window(r["a.y"], 0.2, 0.4))', df) == pytest.approx(-0.4, abs=1e-12)
    assert qoi.evaluate('ptp(window(r["a.y"], 0.2, 0.4))', df) == pytest.approx(0.6, abs=1e-12)
    # peak is max |x|: for 3t - 1 on [0, 0.1] that is |-1| at t = 0, not the max -0.7
    assert qoi.evaluate('peak(window(r["a.y"], 0.0, 0.1))', df) == pytest.approx(1.0)


def test_rms_and_mean(df):
    # sum of sin^2 over the 1000 samples of one period is exactly 500 (the end point adds sin^2(2 pi) ~ 0)
    assert qoi.evaluate('rms(r["a.x"])', df) == pytest.approx(math.sqrt(500.0 / 1001.0), rel=1e-12)
    # mean of the linear ramp 3t - 1 over symmetric samples: its midpoint value 0.5
    assert qoi.evaluate('mean(r["a.y"])', df) == pytest.approx(0.5, abs=1e-12)


def test_at_interpolates_linearly(df):
    t = 0.12345
    k = int(t * (N - 1))
    x0, x1 = math.sin(2 * math.pi * T[k]), math.sin(2 * math.pi * T[k + 1])
    expected = x0 + (x1 - x0) * (t - T[k]) / (T[k + 1] - T[k])
    assert qoi.evaluate('at(r["a.x"], 0.12345)', df) == pytest.approx(expected, rel=1e-12)
    assert qoi.evaluate('final(r["a.y"])', df) == 2.0


def test_count_rises_and_at_rises():
    flag = np.zeros(N)
    flag[[10, 11, 12, 500, 900, 901]] = 1.0   # three contacts
    counter = np.cumsum(np.r_[0.0, (flag[1:] > 0) & (flag[:-1] == 0)])
    d = frame(**{"c.f": flag, "c.n": counter, "c.g": T})
    assert qoi.evaluate('count_rises(r["c.f"])', d) == 3
    flag0 = flag.copy()
    flag0[0] = 1.0                            # a flag set at the first sample counts for count_rises
    assert qoi.evaluate('count_rises(r["c.f"])', frame(**{"c.f": flag0})) == 4
    # at_rises on the flag and on the counter: the same three times
    assert list(qoi._at_rises(flag, T)) == [T[10], T[500], T[900]]
    assert qoi.evaluate('sum(at_rises(r["c.n"], r["c.g"]))', d) == pytest.approx(T[10] + T[500] + T[900])
    assert qoi.evaluate('sum(at_rises(r["c.f"], r["c.g"]) > 0.3)', d) == 2
    # a contact already running at the start of a window is not a rise
    assert qoi.evaluate('sum(at_rises(window(r["c.f"], T11, 1.0), window(r["c.g"], T11, 1.0)))'
                        .replace("T11", repr(float(T[11]))), d) == pytest.approx(T[500] + T[900])


def test_normalize_between_sum(df):
    # 3t - 1 normalised is t itself; t in [0.1, 0.9] holds samples 100 ... 900: 801 of them
    assert qoi.evaluate('max(abs(normalize(r["a.y"]) - t))', df) < 1e-15
    assert qoi.evaluate('sum(between(normalize(r["a.y"]), 0.1, 0.9))', df) == 801


def test_empty_reduction_and_default(df):
    with pytest.raises(qoi.QoIError, match=r"quantity 'peak\(window\(r\[\"a.x\"\], 2.0, 3.0\)\)'"):
        qoi.evaluate('peak(window(r["a.x"], 2.0, 3.0))', df)
    assert qoi.evaluate('peak(window(r["a.x"], 2.0, 3.0), empty=0.0)', df) == 0.0
    assert qoi.evaluate('max(window(r["a.x"], 2.0, 3.0), empty=-1.5)', df) == -1.5


def test_errors_name_the_expression(df):
    with pytest.raises(qoi.QoIError) as e:
        qoi.evaluate('peak(r["a.nope"])', df)
    assert "peak(r[\"a.nope\"])" in str(e.value) and "'a.nope'" in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(qoi.QoIError, match=r"unknown name 'median'"):
        qoi.evaluate('median(r["a.x"])', df)
    with pytest.raises(qoi.QoIError, match=r"Attribute is not allowed"):
        qoi.evaluate('r.df', df)
    with pytest.raises(qoi.QoIError, match=r"not an expression"):
        qoi.check('peak(')
    with pytest.raises(qoi.QoIError, match=r"at_rises"):
        qoi.evaluate('sum(at_rises(r["a.x"], window(r["a.x"], 0.0, 0.5)))', df)


def test_columns():
    expr = 'peak(window(r["a.x"], 0, 1)) + final(r["b.y"]) * at(r["a.x"], 0.5)'
    assert sorted(set(qoi.columns(expr))) == ["a.x", "b.y"]


def test_on_durations():
    # contacts on samples 10-12, 500, 900-901 (still on at the end of a window that stops at 901)
    flag = np.zeros(N)
    flag[[10, 11, 12, 500, 900, 901]] = 1.0
    d = frame(**{"c.f": flag, "c.R": 1.0 + T})
    dt = T[1] - T[0]
    assert list(qoi._on_durations(flag, T)) == pytest.approx([3 * dt, dt, 2 * dt], rel=1e-12)
    assert qoi.evaluate('sum(on_durations(r["c.f"], t) <= 1.5 * 0.001)', d) == 1
    # aligned with at_rises: a per-contact limit compares element by element
    assert qoi.evaluate('sum(on_durations(r["c.f"], t) < at_rises(r["c.f"], r["c.R"]) * 0.002)', d) == 2
    w = 'on_durations(window(r["c.f"], 0.0, T901), window(t, 0.0, T901))'.replace("T901", repr(float(T[901])))
    assert qoi.evaluate(f'sum({w} > 1.0)', d) == 1            # the contact not ended in the window: inf
    assert qoi.evaluate('min(on_durations(r["c.f"], t))', d) == pytest.approx(dt, rel=1e-12)
    assert qoi._on_durations(np.ones(5), np.arange(5.0)).size == 0   # on from the start: no rise
    with pytest.raises(qoi.QoIError, match="on_durations"):
        qoi.evaluate('sum(on_durations(r["c.f"], window(t, 0.0, 0.5)))', d)


def test_rise_times_reads_a_counters_own_instants_where_the_result_carries_them():
    """Without a rise_time column: the rising samples' times (as at_rises over the window); with one (a drive
    FMU's, on its own finer step): its value at each rising sample; the counter is a column the quantity reads."""
    t = np.arange(0.0, 1.0001, 0.1)
    count = np.array([0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3], dtype=float)
    df = pd.DataFrame({"c.n_count": count}, index=pd.Index(t, name="time"))
    plain = qoi.value('rise_times("c.n_count", 0.15, 1.0)', df)
    np.testing.assert_allclose(plain, qoi.value('at_rises(window(r["c.n_count"], 0.15, 1.0), window(t, 0.15, 1.0))', df))
    np.testing.assert_allclose(plain, [0.5, 0.8])
    df["c.n_count.rise_time"] = [0.0, 0.0, 0.13, 0.13, 0.13, 0.42, 0.42, 0.42, 0.77, 0.77, 0.77]
    np.testing.assert_allclose(qoi.value('rise_times("c.n_count", 0.0, 1.0)', df), [0.13, 0.42, 0.77])
    assert qoi.columns('rise_times("c.n_count", 0.2, 0.6)') == ["c.n_count"]
    with pytest.raises(qoi.QoIError, match="no result column 'c.missing'"):
        qoi.value('rise_times("c.missing", 0.0, 1.0)', df)
