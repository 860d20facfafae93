"""The command line in daily use: version, logging of the compile phases, exit codes, the summary of the
requested outputs with units, export without a redundant flag."""

import logging
import subprocess
import sys

import pytest

import mbs
from mbs.cli import main

PENDULUM = "library/examples/pendulum.mbs"


@pytest.fixture(autouse=True)
def quiet_logger_afterwards():
    yield
    logging.getLogger("mbs").handlers[:] = []
    logging.getLogger("mbs").setLevel(logging.WARNING)


def test_version(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0 and capsys.readouterr().out.strip() == f"mbs {mbs.__version__}"


def test_verbose_logs_the_compile_phases_and_the_build_cache(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("MBS_CACHE_DIR", str(tmp_path))
    assert main(["-v", "simulate", PENDULUM, "--t-end", "0.1"]) == 0
    first = capsys.readouterr().err
    assert "derived the equations of motion in" in first and "cache miss" in first
    assert main(["-v", "simulate", PENDULUM, "--t-end", "0.1"]) == 0
    assert "cache hit" in capsys.readouterr().err
    assert main(["-q", "simulate", PENDULUM, "--t-end", "0.1"]) == 0
    assert capsys.readouterr().err == ""


def test_summary_lists_the_requested_outputs_with_units(capsys):
    assert main(["simulate", PENDULUM, "--t-end", "0.1"]) == 0
    out = capsys.readouterr().out
    lines = [line.split() for line in out.splitlines()[1:] if line.startswith("  ") and "final" in line]
    assert [words[0] for words in lines][:2] == ["hinge.phi", "rate"]   # the scene's order, a coordinate first
    assert lines[0][3] == "rad" and lines[1][3] == "rad/s"
    assert not any(words[0] == "der(hinge.phi)" for words in lines)     # states the scene did not ask for


@pytest.mark.parametrize("args, message", [
    (["simulate", PENDULUM, "--integrator", "rk99"], "unknown integrator 'rk99' (available: dopri5"),
    (["simulate", PENDULUM, "--scene", "nope"], "has no scene 'nope'"),
    (["simulate", PENDULUM, "--out", "r.txt"], "results are written as .csv, .npz or .h5"),
    (["linearize", PENDULUM, "--param", "l=2s"], "expected length (m), got time (s)"),
    (["equilibrium", PENDULUM, "--scene", "nope"], "has no scene 'nope'"),
])
def test_usage_errors_after_parsing_exit_2(capsys, args, message):
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_a_model_error_still_exits_1(capsys, tmp_path):
    bad = tmp_path / "bad.mbs"
    bad.write_text("model m { param a = 1 kg + 1 m }\n")
    assert main(["simulate", str(bad)]) == 1


def test_export_needs_no_json_flag(tmp_path):
    out = tmp_path / "m.json"
    assert main(["export", PENDULUM, "-o", str(out)]) == 0
    assert out.read_text().lstrip().startswith("{")


def test_help_and_check_do_not_load_sympy_or_scipy():
    code = ("import sys; from mbs.cli import main; main(['check', '" + PENDULUM + "']); "
            "print(sorted(m for m in ('sympy', 'scipy', 'matplotlib', 'mbs.compiler') if m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.strip().splitlines()[-1] == "[]"


def test_slow_compile_phases_are_noted_without_verbose(capsys, monkeypatch, tmp_path):
    """A compile phase over SLOW_PHASE seconds is shown by default (a long compile in a CI log is not silent);
    here every phase counts as slow. A fresh cache: a derivation cached before would run no phase at all."""
    from mbs import pipeline
    monkeypatch.setattr(pipeline, "SLOW_PHASE", -1.0)
    monkeypatch.setenv("MBS_CACHE_DIR", str(tmp_path))
    assert main(["simulate", PENDULUM, "--t-end", "0.1"]) == 0
    err = capsys.readouterr().err
    assert "derived the equations of motion in" in err and "compiling pendulum" not in err  # start line: -v
    assert main(["-q", "simulate", PENDULUM, "--t-end", "0.1"]) == 0
    assert capsys.readouterr().err == ""
