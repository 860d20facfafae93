"""Plots by unit: few panels, units on the axes, zero channels named instead of drawn, the figure returned."""

import numpy as np

from mbs.runtime import plotting
from mbs.runtime.results import Results


def results():
    t = np.linspace(0.0, 1.0, 11)
    columns = {"time": t, "a.phi": np.sin(t), "b.phi": np.cos(t), "load.fx": 3 * t, "load.fy": 0 * t,
               "load.mz": 1e-17 * t, "gain": 2 * t}
    units = {"a.phi": "rad", "b.phi": "rad", "load.fx": "N", "load.fy": "N", "load.mz": "N*m"}
    return Results(list(columns), np.column_stack(list(columns.values())), {"model": "m", "units": units})


def test_channels_are_grouped_by_unit_and_split_when_crowded():
    units = {f"x{i}": "m" for i in range(8)} | {"f": "N"}
    layout = plotting.panels([*units, "free"], units)
    assert [(u, len(n)) for u, n in layout] == [("m", 6), ("m", 2), ("N", 1), (None, 1)]
    quaternions = {f"{j}.q{c}": "1" for j in ("top", "ab") for c in "wxyz"}
    assert [names for _, names in plotting.panels(list(quaternions), quaternions)] == [
        ["top.qw", "top.qx", "top.qy", "top.qz"], ["ab.qw", "ab.qx", "ab.qy", "ab.qz"]]


def test_figure_has_one_panel_per_unit_and_notes_zero_channels(tmp_path):
    res = results()
    fig = res.plot(path=tmp_path / "r.png")
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["angle [rad]", "load.fx [N]", "gain"]  # load.fy and load.mz stay zero: not drawn
    note = " ".join(text.get_text() for text in fig.texts)
    assert "load.fy" in note and "load.mz" in note and "load.fx" not in note
    assert (tmp_path / "r.png").read_bytes()[:4] == b"\x89PNG"


def test_several_runs_share_the_panels():
    a, b = results(), results()
    fig = plotting.figure({"slow": a, "fast": b}, ["a.phi", "load.fx"], title="compare")
    assert len(fig.axes) == 2 and len(fig.axes[0].lines) == 2
    assert [line.get_label() for line in fig.axes[0].lines] == ["slow", "fast"]
