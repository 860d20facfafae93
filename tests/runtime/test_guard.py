"""Interrupting a run keeps every sample computed so far, and no run stalls silently (issue 17)."""

import os
import signal
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

    before = signal.getsignal(sig)  # SIG_IGN for SIGINT when the test process was started in the background
    res = mbs.loads(PENDULUM).simulate(t_end=2.0, sample=0.01, progress=progress)
    assert res.metadata["status"] == "interrupted"
    assert res.message.startswith("interrupted at t = ") and f"({how})" in res.message
    _complete_up_to(res, 0.6)
    assert signal.getsignal(sig) is before  # the handler the run found is restored


def test_a_stall_ends_with_time_step_size_activity_and_cause():
    res = mbs.loads(STIFF).simulate(t_end=1e6, integrator="dopri5", stall_time=0.3, max_steps=10**12)
    assert res.metadata["status"] == "stopped" and not res.success
    message = res.message
    assert message.startswith("stalled at t = ")
    for part in ("the simulated time advanced only", "steps in", "% rejected", "step size", "integrator dopri5",
                 "likely cause: the model is stiff here", "use 'rodasp'"):
        assert part in message, part
    assert len(res.t) >= 1 and res.t[0] == 0.0


def test_the_wall_time_limit_keeps_the_samples_and_marks_the_file(tmp_path):
    res = mbs.loads(STIFF).simulate(t_end=100, sample=1e-3, integrator="dopri5", max_wall_time=0.3,
                                    max_steps=10**12)
    assert res.metadata["status"] == "stopped"
    assert res.message.startswith("wall-time limit of 0.3 s reached")
    assert len(res.t) >= 2 and np.allclose(np.diff(res.t), 1e-3)
    res.to_csv(tmp_path / "r.csv")
    text = (tmp_path / "r.csv").read_text()
    assert '# status: "stopped"' in text and "wall-time limit of 0.3 s reached" in text


def _command_line_interrupted(tmp_path, monkeypatch, argv, signal_at=None):
    """`mbs simulate` in this process; the progress bar sends SIGINT once the run passes t = signal_at."""
    from mbs.cli import main
    from mbs.commands import common
    src, out = tmp_path / "p.mbs", tmp_path / "r.csv"
    src.write_text(PENDULUM)
    if signal_at is not None:
        def progress(self, t, t_end):
            if t >= signal_at and not getattr(self, "sent", False):
                self.sent = True
                os.kill(os.getpid(), signal.SIGINT)  # as Ctrl-C in the terminal
        monkeypatch.setattr(common.ProgressBar, "__call__", progress)
    status = main(["simulate", str(src), "--t-end", "2", "--sample", "0.01", "--out", str(out), *argv])
    return status, out.read_text()


def test_ctrl_c_on_the_command_line_writes_what_was_computed(tmp_path, monkeypatch, capsys):
    status, text = _command_line_interrupted(tmp_path, monkeypatch, [], signal_at=0.5)
    assert status == 130
    assert '# status: "interrupted"' in text and "interrupted at t = " in text and "(Ctrl-C)" in text
    rows = [line for line in text.splitlines() if line and not line.startswith("#")][1:]
    assert 50 <= len(rows) < 201  # every sample up to the interruption, none after
    assert "interrupted at t = " in capsys.readouterr().err


def test_max_wall_time_on_the_command_line(tmp_path, monkeypatch):
    status, text = _command_line_interrupted(tmp_path, monkeypatch, ["--max-wall-time", "1e-9"])
    assert status == 1 and '# status: "stopped"' in text and "wall-time limit of 1e-09 s reached" in text


def test_a_watched_solver_goes_with_its_run_not_at_the_cycle_collectors_pass():
    """guard.watch keeps a sampling function on the solver that reaches the solver weakly: after a run (with and
    without events) no solver is left for the cycle collector, and its C memory is freed at once."""
    import gc

    from mbs.runtime.integrators.native import NativeSolver

    system = mbs.loads(PENDULUM)
    system.simulate(t_end=0.2, sample=0.01)  # compiled, warm
    gc.collect()
    gc.disable()
    try:
        res = system.simulate(t_end=0.2, sample=0.01)
        left = [o for o in gc.get_objects() if isinstance(o, NativeSolver)]
    finally:
        gc.enable()
    assert res.metadata["status"] == "finished" and len(res.t) == 21
    assert left == []
