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

from childproc import harness_command
from harness import RunOptions, simulate
from harness.results import read_csv, to_csv

ROOT = Path(__file__).resolve().parents[1]


CLI_SYSTEMS = ("two_inertia", "bed_drive", "spine_knife", "feeder_gto52", "proof_press")


@pytest.fixture(scope="module", autouse=True)
def built_fmus():
    """The FMUs of the systems these commands run, built before the first one: a command that builds an FMU on
    first use says so on stdout ("built ..."), and the tests below read stdout and stderr exactly (the file
    failed on its first run after a fresh set-up and passed on the second)."""
    from harness import load
    from harness.model import resolve_fmu

    for name in CLI_SYSTEMS:
        for inst in load(name).instances:
            resolve_fmu(inst.fmu)


def cli(*args, cwd=ROOT, parquet=True):
    """``python -m harness ARGS``; ``parquet=False``: as where neither Parquet engine is installed."""
    r = subprocess.run([*harness_command(parquet), *map(str, args)], cwd=cwd, capture_output=True, text=True,
                       timeout=600)
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
    """The run command's check (pyarrow or fastparquet), in a child told that neither is installed (the test
    extras install fastparquet)."""
    spec = tmp_path / "s.yaml"
    spec.write_text(SPEC)
    rc, _, err = cli("sweep", "two_inertia", "--grid", spec, "--workers", "0", "--out", tmp_path / "x.parquet",
                     cwd=tmp_path, parquet=False)
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
    from harness.master import MASTERS
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


# -- a newcomer's tries ----------------------------------------------------------------------------------------
def test_export_into_a_place_that_cannot_be_written_is_one_clean_line(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    for out, expected in (("/proc/x.ssp", "export /proc/x.ssp: folder /proc is not writable"),
                          (blocker / "x.ssp", f"export {blocker / 'x.ssp'}: {blocker} is a file, not a folder")):
        rc, stdout, err = cli("export", "two_inertia", out)
        line = one_line(err)
        assert rc == 1 and stdout == "" and line.startswith(f"error: {expected}"), line
        assert "Errno" not in line and ".part" not in line, line


@pytest.mark.parametrize("args", [("scene", "two_inertia"), ("study", "stability", "two_inertia", "--quick"),
                                  ("study", "precision", "two_inertia", "--quick")])
def test_study_and_scene_check_their_out_folder_before_the_work(tmp_path, args):
    """They used to run the whole study and fail only when writing the table."""
    blocker = tmp_path / "file"
    blocker.write_text("")
    rc, out, err = cli(*args, "--out", blocker / "sub", cwd=tmp_path)
    line = one_line(err)
    assert rc == 1 and out == "" and f"--out {blocker / 'sub'}: {blocker} is a file, not a folder" in line, line


@pytest.mark.parametrize("args, expected", [
    (("--set", "bed.m_t=300"), "FMU RackBed of instance bed has no variable 'm_t' (did you mean 'm_T'?)"),
    (("--set", "bedd.m_T=300"), "unknown instance 'bedd' (did you mean 'bed'?)"),
    (("--master", "jacobbi"), "master = 'jacobbi' is not admissible (did you mean 'jacobi'?)"),
])
def test_a_misspelt_name_gets_did_you_mean(args, expected):
    rc, out, err = cli("run", "bed_drive", "--stop-time", "0.001", *args)
    assert rc == 1 and out == "" and expected in one_line(err), err


@pytest.mark.parametrize("system", ["feeder_gto52", "spine_knife"])
def test_an_exported_drive_runs_as_quietly_as_the_native_one(tmp_path, system):
    """The export left out the inputs a drive leaves unconnected on purpose (free_inputs): its .ssp warned
    'input flywheel.aux.tau is not connected' where the native run says nothing."""
    from harness import load
    from harness.ssp import export_ssp

    ssp = export_ssp(load(system), tmp_path / f"{system}.ssp")
    assert load(ssp).free_inputs == load(system).free_inputs
    rc, out, err = cli("run", ssp, "--stop-time", "0.002", cwd=tmp_path)
    assert rc == 0 and "points to t = 0.002 s" in out
    assert err.strip() == "", err


def test_an_fmu_without_a_binary_for_this_platform_is_one_line_naming_it_and_its_platforms(tmp_path):
    """fmpy said 'Cannot find shared library <the extraction cache>/binaries/linux64/X.so.'"""
    import zipfile

    from harness.errors import FMUError
    from harness.model import Experiment, Instance, System, resolve_fmu

    src = resolve_fmu("Inertia")
    foreign = tmp_path / "Windows.fmu"
    with zipfile.ZipFile(src) as zi, zipfile.ZipFile(foreign, "w") as zo:
        for n in zi.namelist():
            for other in ("win64", "darwin64"):
                if n.startswith("binaries/linux64/"):
                    zo.writestr(n.replace("linux64", other), zi.read(n))
            if not n.startswith("binaries/"):
                zo.writestr(n, zi.read(n))
    system = System("w", [Instance("w", str(foreign))], experiment=Experiment(stop_time=0.01, step=0.001))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(FMUError) as e:
            simulate(system, on_error="raise", options=RunOptions(in_process=False))
    msg = str(e.value)
    assert f"{foreign} has no binary for this platform" in msg and "binaries for darwin64, win64 only" in msg, msg
    assert "\n" not in msg and "Cannot find shared library" not in msg


def test_an_ssp_binding_of_a_missing_variable_is_one_warning_and_the_run_goes_on(tmp_path):
    """As OMSimulator does; it used to stop the run ('parameter a.J_old: FMU Inertia ... has no variable').  A
    --set of the missing name stays an error."""
    import re
    import zipfile

    from harness import load
    from harness.ssp import export_ssp

    src = export_ssp(load("two_inertia"), tmp_path / "src.ssp")
    ssp = tmp_path / "edited.ssp"
    with zipfile.ZipFile(src) as zi, zipfile.ZipFile(ssp, "w") as zo:
        for n in zi.namelist():
            data = zi.read(n)
            if n == "SystemStructure.ssd":
                text = data.decode()
                m = re.search(r'<ssv:Parameter name="J">.*?</ssv:Parameter>', text, re.S)
                assert m, text[:2000]
                text = text.replace(m.group(0), m.group(0) + m.group(0).replace('name="J"', 'name="J_old"'), 1)
                data = text.encode()
            zo.writestr(n, data)
    rc, out, err = cli("run", ssp, "--stop-time", "0.01", cwd=tmp_path)
    assert rc == 0 and "points to t = 0.01 s" in out, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("warning: ") and ".J_old name no variable" in lines[0], err
    assert "edited.ssp" in lines[0]
    rc, out, err = cli("run", ssp, "--stop-time", "0.01", "--set", "a.J_old=2", cwd=tmp_path)
    last = err.strip().splitlines()[-1]   # after the load's warning
    assert rc == 1 and last.startswith("error: ") and "has no variable 'J_old'" in last, err


def test_sweep_at_a_scheduler_address_without_a_scheduler_is_one_line(tmp_path):
    """In a fresh process (dask's distributed settings not yet loaded: the check read them before their import
    and failed with "KeyError: 'distributed'"): a closed port and a service that answers garbage."""
    import socket
    import threading

    spec = tmp_path / "s.yaml"
    spec.write_text(SPEC)
    closed = socket.socket()
    closed.bind(("127.0.0.1", 0))
    port = closed.getsockname()[1]
    closed.close()
    rc, out, err = cli("sweep", "two_inertia", "--grid", spec, "--scheduler", f"127.0.0.1:{port}", cwd=tmp_path)
    assert rc == 1 and out == "" and f"--scheduler 127.0.0.1:{port}: cannot connect" in one_line(err), err
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(2)

    def serve():
        try:
            conn, _ = srv.accept()
            conn.sendall(b"220 mail.example ESMTP ready\r\n")
            conn.recv(100)
        except OSError:
            pass

    threading.Thread(target=serve, daemon=True).start()
    try:
        rc, out, err = cli("sweep", "two_inertia", "--grid", spec, "--scheduler", f"tcp://127.0.0.1:"
                           f"{srv.getsockname()[1]}", cwd=tmp_path)
    finally:
        srv.close()
    assert rc == 1 and out == "" and "is no dask scheduler" in one_line(err), err
    assert not list(tmp_path.glob("results/*"))


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


def test_the_top_level_help_is_the_full_parsers_without_importing_the_commands():
    """``--help`` is built from harness.__main__.COMMANDS alone: the same text as the full parser's, and
    pandas, matplotlib and scipy stay unimported (they cost the bare help over a second)."""
    import subprocess
    import sys

    from harness.__main__ import COMMANDS, build_parser

    full = build_parser()
    sub = next(a for a in full._actions if a.dest == "command")
    assert [(c.dest, c.help) for c in sub._choices_actions] == list(COMMANDS)
    assert build_parser(top_only=True).format_help() == full.format_help()
    code = ("import sys\nfrom harness.__main__ import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in ('pandas', 'matplotlib', 'scipy', 'networkx') if m in sys.modules))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.stdout.strip().splitlines()[-1] == "[]", p.stdout[-300:] + p.stderr[-300:]
