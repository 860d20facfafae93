"""The reliability audit's cases (issue 19): each was an internal error, a silent wrong result or an unsafe
command line; each is now a located message, a safe path or a correct file."""

import os
import stat
import sys
from pathlib import Path

import pytest

import mbs
from mbs.cli import main

ROOT = Path(__file__).resolve().parents[2]
PENDULUM = ROOT / "library" / "examples" / "pendulum.mbs"
ZERO_INERTIA = PENDULUM.read_text().replace("diag(1e-6, 1e-6, 1e-6) kg*m^2", "diag(0, 0, 0) kg*m^2")

FALLING = """
model fall {
    gravity = (0, 0, -9.81) m/s^2
    rigid b {
        body {
            mass = 1 kg
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact j {
        connect inertial -> b
        joint prismatic(axis = z)
    }
}
"""


def run(capsys, *argv):
    status = main([str(a) for a in argv])
    out = capsys.readouterr()
    return status, out.out + out.err


@pytest.mark.parametrize("argv, message, expected", [
    (["--param", "m=-1"], "the mass of 'bob' must not be negative, but it is -1 kg", 1),  # a model error
    (["--t-end", "inf"], "t_end must be a finite time", 2),  # usage errors
    (["--sample", "1e-9"], "choose a larger sample interval", 2),
])
def test_bad_run_settings_are_messages_not_internal_errors(capsys, argv, message, expected):
    status, text = run(capsys, "simulate", PENDULUM, *argv)
    assert status == expected and message in text and "internal error" not in text


def test_a_huge_mass_parameter_fails_with_the_reason(capsys):
    status, text = run(capsys, "simulate", PENDULUM, "--param", "m=1e308")
    assert status == 1 and "non-finite value" in text and "internal error" not in text


def test_a_zero_mass_names_the_coordinate_time_state_and_parameter(tmp_path, capsys):
    src = tmp_path / "p.mbs"
    src.write_text(ZERO_INERTIA)
    status, text = run(capsys, "simulate", src, "--param", "m=0")
    assert status == 1
    assert ("no mass or inertia determines the motion of hinge.phi, at t = 0 s in the state hinge.phi = 0.523599, "
            "der(hinge.phi) = 0; parameters that are zero, negative or not finite: m = 0") in text


@pytest.mark.parametrize("expression, message", [
    ("2^2^2^2^2^2", "this value overflows"),
    ("1e400 kg", "this value is not a finite number (inf)"),
    (" + ".join(["1 kg"] * 500), "nested 101 levels deep, more than the 100 allowed"),
    ("-" * 2000 + "1 kg", "nested 2000 levels deep"),
    ("(" * 300 + "1 kg" + " * 1)" * 300, "levels deep, more than the 100 allowed"),
])
def test_extreme_expressions_are_located_errors(tmp_path, capsys, expression, message):
    src = tmp_path / "x.mbs"
    src.write_text(PENDULUM.read_text().replace("param m = 1 kg", f"param m = {expression}"))
    status, text = run(capsys, "check", src)
    assert status == 1 and message in text and "internal error" not in text
    assert f"{src.name}:" in text.replace(str(src), src.name)  # located in the file


def test_a_99_term_sum_still_runs(tmp_path):
    src = tmp_path / "x.mbs"
    src.write_text(PENDULUM.read_text().replace("param m = 1 kg", "param m = " + " + ".join(["0.01 kg"] * 99)))
    res = mbs.load(src, backend="numpy").simulate(t_end=0.01)
    assert res.success


def test_compile_output_names_starting_with_a_dash_are_never_compiler_options(tmp_path, capsys, monkeypatch):
    """-o=-B/some/dir made gcc take -B: the compiler must only ever see absolute paths of ours."""
    log = tmp_path / "argv.txt"
    wrapper = tmp_path / "cc-wrapper"
    wrapper.write_text(f"#!/bin/sh\nprintf '%s\\n' \"$@\" > '{log}'\nexec cc \"$@\"\n")
    wrapper.chmod(0o755)
    monkeypatch.setenv("CC", str(wrapper))
    monkeypatch.chdir(tmp_path)
    for name in ("-Bevil", "-o", "--help"):
        status, text = run(capsys, "compile", PENDULUM, f"-o={name}")
        assert status == 0, text
        assert (tmp_path / name / "libpendulum.so").exists()
        args = log.read_text().split("\n")
        paths = [a for a in args if a.endswith((".c", ".so"))]
        assert paths and all(os.path.isabs(p) for p in paths), args
        assert not any(a.startswith("-B") for a in args)


def test_compile_without_a_c_compiler_says_so(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    status, text = run(capsys, "compile", PENDULUM, "-o", tmp_path / "out")
    assert status == 1 and "no C compiler to build" in text and "internal error" not in text
    assert (tmp_path / "out" / "pendulum.c").exists()


def test_out_into_an_unwritable_place_fails_before_the_run(tmp_path, capsys, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setattr("mbs.System.simulate", lambda *a, **k: pytest.fail("the run started"))
    status, text = run(capsys, "simulate", PENDULUM, "--out", blocker / "r.csv")
    assert status == 2 and "cannot be written" in text and "is a file, not a folder" in text


def test_equilibrium_of_a_falling_body_says_why(tmp_path, capsys):
    src = tmp_path / "fall.mbs"
    src.write_text(FALLING)
    status, text = run(capsys, "equilibrium", src)
    assert status == 1 and "'j.s' moved" in text and "free to fall" in text


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX permissions")
def test_written_files_keep_the_users_umask(tmp_path, capsys):
    old = os.umask(0o027)
    try:
        assert main(["simulate", str(PENDULUM), "--t-end", "0.05", "--out", str(tmp_path / "r.csv")]) == 0
        assert main(["compile", str(PENDULUM), "-o", str(tmp_path / "build")]) == 0
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "r.csv").stat().st_mode) == 0o640
    assert stat.S_IMODE((tmp_path / "build" / "pendulum.c").stat().st_mode) == 0o640
    assert stat.S_IMODE((tmp_path / "build" / "libpendulum.so").stat().st_mode) == 0o750


def test_fmt_in_place_keeps_a_symlink_a_symlink(tmp_path):
    real = tmp_path / "real.mbs"
    real.write_text(PENDULUM.read_text().replace("    param m", "param m", 1))  # badly indented
    link = tmp_path / "link.mbs"
    link.symlink_to(real)
    real.chmod(0o604)
    assert main(["fmt", "-i", str(link)]) == 0
    assert link.is_symlink() and os.readlink(link) == str(real)
    assert real.read_text() == PENDULUM.read_text()
    assert stat.S_IMODE(real.stat().st_mode) == 0o604  # a replaced file keeps its permissions
