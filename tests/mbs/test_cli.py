"""The `mbs` command line: exit statuses, located messages, no tracebacks, atomic outputs."""

import json
import subprocess
import sys

import pytest

from mbs.cli import main
from tests.conftest import ROOT


def run(*args):
    """The real console entry point in a subprocess, as a user would call it."""
    proc = subprocess.run([sys.executable, "-m", "mbs", *args], capture_output=True, text=True, cwd=ROOT)
    return proc.returncode, proc.stdout, proc.stderr


def test_check_accepts_a_model_and_summarises_it(capsys):
    assert main(["check", "-v", "library/examples/pendulum.mbs"]) == 0
    out = capsys.readouterr().out
    assert "model pendulum: 2 parts (1 rigid)" in out
    assert "library/examples/pendulum.mbs: ok (pendulum)" in out


def test_bad_usage_exits_2():
    status, _, err = run("check")
    assert status == 2 and "usage" in err
    status, _, err = run("frobnicate")
    assert status == 2


def test_missing_file_is_a_clear_error_not_a_traceback(tmp_path):
    status, _, err = run("check", str(tmp_path / "nope.mbs"))
    assert status == 1
    assert "cannot read file" in err and "Traceback" not in err


def test_several_files_report_each(tmp_path):
    bad = tmp_path / "bad.mbs"
    bad.write_text("model m {\n    param a = 1 kgg\n}\n")
    status, out, err = run("check", "library/examples/pendulum.mbs", str(bad))
    assert status == 1
    assert "pendulum.mbs: ok" in out
    assert "unknown unit 'kgg'; did you mean 'kg'?" in err and err.rstrip().endswith("1 error")


def test_fmt_check_and_in_place(tmp_path):
    messy = tmp_path / "m.mbs"
    messy.write_text("model m {\n  param a=1 kg\n}\n")
    assert main(["fmt", "--check", str(messy)]) == 1
    assert main(["fmt", "-i", str(messy)]) == 0
    assert messy.read_text() == "model m {\n    param a = 1 kg\n}\n"
    assert main(["fmt", "--check", str(messy)]) == 0
    assert [p.name for p in tmp_path.iterdir()] == ["m.mbs"]  # no temporary file left behind


def test_export_writes_json_atomically(tmp_path):
    out = tmp_path / "sub" / "model.json"
    assert main(["export", "library/examples/double_pendulum.mbs", "--json", "-o", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["name"] == "double_pendulum"


@pytest.mark.parametrize("content", [b"", b"\x00\xff\xfe garbage", b"model", b"model m {", "model m { param \u00e9 = 1 }".encode()])
def test_garbage_never_gives_a_traceback(tmp_path, content):
    path = tmp_path / "g.mbs"
    path.write_bytes(content)
    status, out, err = run("check", str(path))
    assert "Traceback" not in err
    assert status in (0, 1)
