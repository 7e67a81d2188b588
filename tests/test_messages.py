"""Issue 19's message cases: each failure is one line on stderr that names the culprit, without a traceback,
an exception type name or an FMI call name (unless the FMU itself failed); results know their units."""
from __future__ import annotations

import inspect
import subprocess
import sys
import warnings
from pathlib import Path

import pandas as pd
import pytest

from harness import RunOptions, simulate
from harness.results import read_csv, to_csv

ROOT = Path(__file__).resolve().parents[1]


def cli(*args, cwd=ROOT):
    r = subprocess.run([sys.executable, "-m", "harness", *map(str, args)], cwd=cwd, capture_output=True,
                       text=True, timeout=600)
    return r.returncode, r.stdout, r.stderr


def one_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    line = lines[0]
    assert line.startswith("error: ") and "Traceback" not in stderr, stderr
    for word in ("SystemError_", "SweepError", "np.float64", "fmi2"):
        assert word not in line, line
    return line


def test_negative_inertia_is_one_line_naming_parameter_value_range_unit_and_writes_nothing(tmp_path):
    rc, out, err = cli("run", "two_inertia", "--set", "a.J=-1", "--out", tmp_path / "x.csv")
    line = one_line(err)
    assert rc == 1 and out == ""
    assert "two_inertia" in line and "parameter J = -1.0 kg.m2" in line and "must be > 0 kg.m2" in line
    assert list(tmp_path.iterdir()) == []          # no 0-row CSV


def test_diverged_run_writes_only_a_marked_partial_file_and_exits_non_zero(tmp_path):
    rc, out, err = cli("run", "bed_drive", "--master", "jacobi-sampled", "--stop-time", "0.5", "--out",
                       tmp_path / "x.csv")
    line = one_line(err)
    assert rc == 1 and out == ""
    assert "the run diverged on power bond" in line and "INCOMPLETE result wrote" in line
    assert "x.partial.csv" in line and not (tmp_path / "x.csv").exists()
    df = pd.read_csv(tmp_path / "x.partial.csv", index_col="time")
    assert 0 < df.index[-1] < 0.2


def test_negative_step_in_exponent_notation_reaches_the_step_check():
    rc, _, err = cli("run", "two_inertia", "--step", "-1e-4")
    assert rc == 1 and one_line(err) == "error: step = -0.0001 is not admissible: must be a positive finite number [s]"


def test_tolerance_is_not_reported_in_seconds():
    rc, _, err = cli("run", "two_inertia", "--tolerance", "-1")
    line = one_line(err)
    assert rc == 1 and "tolerance = -1.0 is not admissible" in line and "[s]" not in line


@pytest.mark.parametrize("system", ["spine_knife", "feeder_gto52", "proof_press", "two_inertia"])
def test_a_shipped_drive_run_prints_nothing_but_its_result(system):
    """Issue 30: a shipped system run with its defaults prints nothing but its result (spine_knife used to warn
    about its unconnected inputs, two_inertia to diverge)."""
    rc, out, err = cli("run", system, "--stop-time", "0.01")
    assert rc == 0 and "points to t = 0.01 s" in out
    assert err.strip() == "", err


def test_blow_up_message_has_a_plain_number():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = simulate("two_inertia", master="jacobi", extrapolation=0, options=RunOptions(divergence=None, blowup=2.0))
    assert not df.attrs["complete"]
    assert "np.float64" not in df.attrs["error"] and "exceeds the blow-up limit 2" in df.attrs["error"]


SPEC = """\
system: two_inertia
stop_time: 0.02
step: 1.0e-3
grid: {b.c: [50.0, 200.0], w: [1.0, 2.0]}
set: {a.w0: "w * 1.5"}
outputs: {w_end: 'final(r["a.flange.w"])'}
"""


@pytest.mark.parametrize("change, args, expected", [
    (None, ["--workers", "-1"], "--workers -1 is not admissible: give an integer >= 0"),
    (("final(", "finl("), [], "outputs.w_end: quantity 'finl(r[\"a.flange.w\"])': unknown name 'finl'"),
    (("a.w0", "a.w00"), [], "set.a.w00: instance a (Inertia) has no parameter 'w00'; did you mean 'w0'? "
                            "(parameters: J,"),
    (("a.flange.w", "a.flange.ww"), [], "names 'a.flange.ww', which is no variable of system two_inertia"),
    (None, ["--out", "{tmp}/x.txt"], "unknown result format '.txt': use .csv"),
])
def test_sweep_checks_before_the_first_point(tmp_path, change, args, expected):
    text = SPEC if change is None else SPEC.replace(*change)
    spec = tmp_path / "s.yaml"
    spec.write_text(text)
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    rc, out, err = cli("sweep", "two_inertia", "--grid", spec, "--workers", "0", *args, cwd=tmp_path)
    assert rc == 1 and out == ""
    line = one_line(err)
    assert expected in line, line
    assert not (tmp_path / "results").exists() and not list(tmp_path.glob("*.partial.csv"))  # no point ran


def test_sweep_system_key_must_match(tmp_path):
    spec = tmp_path / "s.yaml"
    spec.write_text(SPEC)
    rc, _, err = cli("sweep", "bed_drive", "--grid", spec, "--workers", "0", cwd=tmp_path)
    assert rc == 1 and "the spec was written for 'two_inertia', not 'bed_drive'" in one_line(err)


def test_parquet_without_pyarrow_fails_before_the_first_point(tmp_path):
    from harness.results import parquet_engine

    if parquet_engine():   # the run command's check: pyarrow or fastparquet (sweep asked for pyarrow alone)
        pytest.skip(f"{parquet_engine()} is installed: Parquet can be written")
    spec = tmp_path / "s.yaml"
    spec.write_text(SPEC)
    rc, _, err = cli("sweep", "two_inertia", "--grid", spec, "--workers", "0", "--out", tmp_path / "x.parquet",
                     cwd=tmp_path)
    assert rc == 1 and "Parquet needs pyarrow" in one_line(err)
    assert not list(tmp_path.glob("*.csv"))


def test_pressdrive_help_names_itself_and_every_option_has_a_default():
    exe = Path(sys.executable).with_name("pressdrive")
    if exe.exists():
        r = subprocess.run([str(exe), "--help"], capture_output=True, text=True, timeout=120)
        assert r.stdout.startswith("usage: pressdrive")
    rc, out, _ = cli("run", "--help")
    assert rc == 0
    for opt in ("--stop-time", "--step", "--master", "--extrapolation", "--step-control", "--tolerance", "--set",
                "--output", "--out", "--units", "--plot"):
        assert opt in out
    from harness.masters import MASTERS
    flat = "".join(out.split())  # wrapped lines may break at a hyphen
    assert all(name in flat for name in MASTERS), flat   # the help names every master it accepts (jacobian too)
    from harness.__main__ import _DefaultsFormatter, build_parser
    import argparse

    def walk(p):
        for a in p._actions:
            if isinstance(a, argparse._SubParsersAction):
                for sp in a.choices.values():
                    yield from walk(sp)
            elif a.option_strings and not isinstance(a, (argparse._HelpAction, argparse._VersionAction)):
                yield p, a

    for p, a in walk(build_parser()):
        assert p.formatter_class is _DefaultsFormatter
        text = _DefaultsFormatter(p.prog)._get_help_string(a)
        assert a.help, (p.prog, a.option_strings)
        assert "default" in text.lower() or isinstance(a, (argparse._StoreTrueAction, argparse._StoreFalseAction)), \
            (p.prog, a.option_strings)


def test_help_of_simulate_explains_every_argument():
    doc = inspect.getdoc(simulate)
    for name in inspect.signature(simulate).parameters:
        assert f"``{name}``" in doc, name
    assert "[s]" in doc and "default" in doc.lower()


def test_units_travel_with_the_result_and_the_csv(tmp_path):
    df = simulate("two_inertia", stop_time=0.01)
    units = df.attrs["units"]
    assert units["a.flange.w"] == "rad/s" and units["b.drive.tau"] == "N.m"
    path = to_csv(df, tmp_path / "u.csv", units=True)
    plain = pd.read_csv(path, header=[0, 1], index_col=0)     # as documented: readable by pandas
    assert ("a.flange.w", "rad/s") in plain.columns and len(plain) == len(df)
    back = read_csv(path)
    assert back.attrs["units"]["b.drive.tau"] == "N.m"
    pd.testing.assert_frame_equal(back, df, check_exact=True, check_freq=False)


def test_no_option_help_says_default_none_where_a_default_exists():
    """Issue 30: '(default: none)' was shown for options whose default is computed (the system's steps, the
    sweep's grid): every option whose default is None must say in its help what happens without it."""
    import argparse

    from harness.__main__ import build_parser

    bad = []

    def walk(parser, path):
        for a in parser._actions:
            if isinstance(a, argparse._SubParsersAction):
                for name, sub in a.choices.items():
                    walk(sub, path + [name])
            elif (a.option_strings and a.default is None and not a.required and a.help not in (None, argparse.SUPPRESS)
                  and "default" not in a.help.lower() and "required" not in a.help.lower()
                  and not isinstance(a, (argparse._StoreTrueAction, argparse._StoreFalseAction,
                                         argparse._HelpAction, argparse._VersionAction))):
                bad.append(f"{' '.join(path)} {a.option_strings[-1]}")

    walk(build_parser(), [])
    assert not bad, bad


@pytest.mark.parametrize("args, expected", [
    (("study", "stability", "two_inertia", "--values", "-1e-3", "0.5"), "--values: -0.001 is not admissible"),
    (("run", "two_inertia", "--step", "-1e-4"), "step = -0.0001 is not admissible"),
    (("run", "two_inertia", "--stop-time", "-inf"), "stop_time = -inf is not admissible"),
])
def test_negative_numbers_in_any_notation_reach_the_commands_check(tmp_path, args, expected):
    """argparse took '-1e-3' for an unknown option ('unrecognized arguments' for a list option, issue 30)."""
    rc, out, err = cli(*args, "--out", tmp_path / ("x.csv" if args[0] == "run" else "o"))
    assert rc == 1 and expected in one_line(err), err


def test_the_run_command_alone_parses_and_helps_as_the_full_command_line():
    """``python -m harness run ...`` builds only the run command's parser (the studies are not imported for a
    run); its help, its defaults and what it parses are those of the full command line's ``run``."""
    import argparse
    import subprocess
    import sys

    from harness.__main__ import _command, build_parser

    def run_parser(ap):
        sub = next(a for a in ap._actions if isinstance(a, argparse._SubParsersAction))
        return sub.choices["run"]

    full, alone = build_parser(), build_parser("run")
    assert run_parser(alone).format_help() == run_parser(full).format_help()
    argv = ["run", "bed_drive", "--stop-time", "0.1", "--step", "-1e-4", "--output", "bed.bed.s"]
    got, want = vars(alone.parse_args(argv)), vars(full.parse_args(argv))
    assert got.keys() == want.keys() and all(got[k] == want[k] for k in got if k != "func")
    assert _command(["--debug", "run", "x"]) == "run" and _command(["--help"]) is None and _command([]) is None
    code = ("import sys; from harness.__main__ import build_parser; build_parser('run'); "
            "print(sorted(m for m in sys.modules if m.startswith(('harness.studies', 'harness.synthesis'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out
