"""`mbs simulate` with several scenes: the paper's figure 18 from one command (motion and tyre loads of both
speeds), one results file per scene, atomic writes, clean errors. On the quarter car, whose compile is quick."""

import subprocess
import sys

import numpy as np
import pytest

from mbs.cli import main
from mbs.runtime.results import Results
from tests.conftest import ROOT

QUARTER = "library/iltis/quarter_car.mbs"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def image(path):
    """The decoded pixels: a file that is not a complete PNG fails here."""
    from matplotlib.image import imread
    assert path.read_bytes()[:8] == PNG_MAGIC
    pixels = imread(path)
    assert pixels.ndim == 3 and pixels.shape[0] > 200 and pixels.shape[1] > 400
    return pixels


def test_two_scenes_give_one_motion_plot_one_tyre_plot_and_a_results_file_each(tmp_path, capsys):
    status = main(["simulate", QUARTER, "--scene", "bump_5", "--scene", "bump_10", "--t-end", "0.3",
                   "--plot", str(tmp_path / "fig18.png"), "--out", str(tmp_path / "run.csv")])
    assert status == 0
    out = capsys.readouterr().out
    assert "scene bump_5" in out and "scene bump_10" in out
    motion, tyres = image(tmp_path / "fig18.png"), image(tmp_path / "fig18_tyres.png")
    assert not np.array_equal(motion.shape, tyres.shape) or not np.array_equal(motion, tyres)
    slow, fast = Results.from_csv(tmp_path / "run_bump_5.csv"), Results.from_csv(tmp_path / "run_bump_10.csv")
    assert slow.t[-1] == pytest.approx(0.3) and fast.t[-1] == pytest.approx(0.3)
    # the two files are the two speeds: at 10 m/s the wheel is pushed up faster in the first 0.3 s
    assert fast["heave"].max() > slow["heave"].max()
    # the road's bump and the tyre's contact are switches (events by default): each run writes its event log
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig18.png", "fig18_tyres.png", "run_bump_10.csv",
                                                          "run_bump_10.events.csv", "run_bump_5.csv",
                                                          "run_bump_5.events.csv"]  # no temporary file left


def test_one_scene_keeps_the_file_names_it_was_given(tmp_path):
    status = main(["simulate", QUARTER, "--scene", "bump_5", "--t-end", "0.05", "--out", str(tmp_path / "r.csv"),
                   "--plot", str(tmp_path / "r.png")])
    assert status == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.csv", "r.events.csv", "r.png"]
    assert (tmp_path / "r.events.csv").read_text().splitlines() == ["time,event,direction,changes"]  # none by 0.05 s
    image(tmp_path / "r.png")


def run(*args):
    proc = subprocess.run([sys.executable, "-m", "mbs", *args], capture_output=True, text=True, cwd=ROOT)
    return proc.returncode, proc.stdout, proc.stderr


def test_an_unknown_scene_among_several_is_a_clean_error_before_any_run(tmp_path):
    status, out, err = run("simulate", QUARTER, "--scene", "bump_5", "--scene", "bump_50", "--plot",
                           str(tmp_path / "f.png"))
    assert status == 2  # a usage error (exit codes of mbs.cli)
    assert "has no scene 'bump_50'" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_a_plot_format_matplotlib_cannot_write_is_refused_up_front(tmp_path):
    status, _, err = run("simulate", QUARTER, "--scene", "bump_5", "--scene", "bump_10", "--plot",
                         str(tmp_path / "f.xyz"))
    assert status == 2 and "--plot" in err and ".png" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []
