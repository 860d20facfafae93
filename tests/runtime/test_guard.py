"""Interrupting a run keeps every sample computed so far, and no run stalls silently (issue 17)."""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import mbs
from mbs.runtime.results import Results

# A stiff spring: dopri5 needs steps of about 1e-7 s for stability, so a long interval takes "forever".
STIFF = """
model stiff {
    param k = 1e12 N/m
    rigid b {
        body {
            mass = 1 kg
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact j {
        connect inertial -> b
        joint prismatic(axis = z) {
            init s = 0.01 m
        }
        force f = spring(k = k)
    }
}
"""

PENDULUM = """
model p {
    gravity = (0, 0, -9.81) m/s^2
    rigid bob {
        body {
            mass = 1 kg
            com = (0, 0, -1) m
            inertia = diag(1e-3, 1e-3, 1e-3) kg*m^2
        }
    }
    interact hinge {
        connect inertial -> bob
        joint revolute(axis = y) {
            init phi = 30 deg
        }
    }
}
"""


def _complete_up_to(res, t_stop):
    """Every sample of the regular grid up to the stop is there, and they are the undisturbed run's."""
    full = mbs.loads(PENDULUM).simulate(t_end=2.0, sample=0.01)
    n = len(res.t)
    assert 0 < n < len(full.t) and res.t[-1] <= t_stop + 1e-12
    assert np.allclose(res.t, full.t[:n]) and np.allclose(res["hinge.phi"], full["hinge.phi"][:n], atol=1e-7)


def test_a_progress_callback_returning_false_keeps_the_samples(tmp_path):
    res = mbs.loads(PENDULUM).simulate(t_end=2.0, sample=0.01, progress=lambda t, t_end: t < 0.5 and None)
    assert res.metadata["status"] == "stopped"
    assert res.message.startswith("stopped by the progress callback at t = ")
    _complete_up_to(res, 0.6)
    res.to_csv(tmp_path / "r.csv")
    back = Results.from_csv(tmp_path / "r.csv")
    assert back.metadata["message"] == res.message and len(back.t) == len(res.t)


@pytest.mark.parametrize("sig, how", [(signal.SIGTERM, "SIGTERM"), (signal.SIGINT, "Ctrl-C")])
def test_a_signal_during_the_run_keeps_the_samples(sig, how):
    sent = []

    def progress(t, t_end):
        if t >= 0.5 and not sent:
            sent.append(t)
            os.kill(os.getpid(), sig)  # delivered to this (the main) thread, as from a terminal
        return None

    res = mbs.loads(PENDULUM).simulate(t_end=2.0, sample=0.01, progress=progress)
    assert res.metadata["status"] == "interrupted"
    assert res.message.startswith("interrupted at t = ") and f"({how})" in res.message
    _complete_up_to(res, 0.6)
    assert signal.getsignal(sig) in (signal.default_int_handler, signal.SIG_DFL)  # handlers restored


def test_a_stall_ends_with_time_step_size_activity_and_cause():
    res = mbs.loads(STIFF).simulate(t_end=1e6, integrator="dopri5", stall_time=0.3)
    assert res.metadata["status"] == "stopped" and not res.success
    message = res.message
    assert message.startswith("stalled at t = ")
    for part in ("the simulated time advanced only", "steps in", "% rejected", "step size", "integrator dopri5",
                 "likely cause: the model is stiff here", "use 'rodasp'"):
        assert part in message, part
    assert len(res.t) >= 1 and res.t[0] == 0.0


def test_the_wall_time_limit_writes_the_file_marked(tmp_path):
    src, out = tmp_path / "stiff.mbs", tmp_path / "r.csv"
    src.write_text(STIFF)
    env = dict(os.environ, MBS_CACHE_DIR=os.environ.get("MBS_CACHE_DIR", str(tmp_path / "cache")))
    proc = subprocess.run([sys.executable, "-m", "mbs", "simulate", str(src), "--t-end", "100", "--sample", "1e-3",
                           "--max-wall-time", "0.5", "--out", str(out)], env=env, capture_output=True, text=True)
    assert proc.returncode == 1, proc.stderr
    text = out.read_text()
    assert '# status: "stopped"' in text and "wall-time limit of 0.5 s reached" in text
    rows = [line for line in text.splitlines() if line and not line.startswith("#")][1:]
    assert len(rows) >= 2  # samples every millisecond up to the stop


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_ctrl_c_on_the_command_line_writes_what_was_computed(tmp_path):
    src, out = tmp_path / "stiff.mbs", tmp_path / "r.csv"
    src.write_text(STIFF)
    env = dict(os.environ, MBS_CACHE_DIR=os.environ.get("MBS_CACHE_DIR", str(tmp_path / "cache")))
    command = [sys.executable, "-m", "mbs", "simulate", str(src), "--sample", "1e-3", "--out", str(out)]
    subprocess.run(command + ["--t-end", "1e-3"], env=env, check=True, capture_output=True)  # compiled once
    for wait in (3, 8, 20):  # the derivation must be done before the signal (a loaded machine is slow)
        proc = subprocess.Popen(command + ["--t-end", "100"], env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        time.sleep(wait)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        if proc.returncode == 130 and "interrupted at t = " in err:
            break
    assert proc.returncode == 130, err
    text = out.read_text()
    assert '# status: "interrupted"' in text and "interrupted at t = " in text and "(Ctrl-C)" in text
