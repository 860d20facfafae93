"""Plots people read at a glance: channels grouped by unit into few panels, the unit on each axis, channels
that stay zero left out (and named in a note), one line style per run when several runs are compared.

matplotlib's object API with the Agg canvas: no global pyplot state, no display needed; the figure is
returned, so a notebook shows it and a script can restyle it before saving.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from mbs.base.atomic import atomic_path

#: Most lines in one panel before a unit group is split over several panels.
LINES_PER_PANEL = 6
#: Readable quantity for an axis, by unit (the unit itself is shown too).
QUANTITY = {"m": "length", "rad": "angle", "m/s": "velocity", "rad/s": "angular velocity", "m/s^2": "acceleration",
            "rad/s^2": "angular acceleration", "N": "force", "N*m": "torque", "W": "power", "Pa": "pressure",
            "kg": "mass", "s": "time"}
STYLES = ("-", "--", ":", "-.")


def panels(names: Sequence[str], units: Mapping[str, str]) -> list[tuple[str | None, list[str]]]:
    """[(unit, names)]: the channels grouped by unit in order of first appearance, groups of more than
    LINES_PER_PANEL split between owners (the components of one joint or sensor stay together); a channel
    without a unit is a group of its own."""
    groups: dict[object, list[str]] = {}
    for name in names:
        key = units.get(name) or ("", name)
        groups.setdefault(key, []).append(name)
    out = []
    for key, members in groups.items():
        unit = key if isinstance(key, str) else None
        owners: dict[str, list[str]] = {}  # a joint's or sensor's components stay in one panel: ab.qw .. ab.qz
        for name in members:
            owners.setdefault(name.rsplit(".", 1)[0], []).append(name)
        panel: list[str] = []
        for together in owners.values():
            if panel and len(panel) + len(together) > LINES_PER_PANEL:
                out.append((unit, panel))
                panel = []
            panel += together
        if panel:
            out.append((unit, panel))
    return out


def is_zero(column: np.ndarray) -> bool:
    """All exactly zero or round-off of a quantity that is zero by symmetry (a pendulum's out-of-plane
    moment, 1e-16 N*m): at most 1e-12 in SI."""
    return column.size > 0 and float(np.max(np.abs(column))) <= 1e-12


def figure(runs: Mapping[str, object], names: Sequence[str], *, title: str = ""):
    """One figure of `names` over time for each run ({label: Results}); returns a matplotlib Figure."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    results = list(runs.values())
    units: dict[str, str] = {}
    for res in results:
        units.update(res.units)
    for name in names:
        for res in results:
            res[name]  # an unknown column is a KeyError listing the columns, before any drawing
    zero = [n for n in names if all(is_zero(res[n]) for res in results)]
    shown = [n for n in names if n not in zero] or list(names[:1])
    layout = panels(shown, units)
    fig = Figure(figsize=(8.5, 1.0 + 2.3 * len(layout)), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(layout), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (unit, members) in zip(axes, layout):
        for k, (label, res) in enumerate(runs.items()):
            for j, name in enumerate(members):
                line_label = name if len(runs) == 1 else (f"{name}, {label}" if len(members) > 1 else label)
                color = f"C{k}" if len(members) == 1 else f"C{j}"  # one channel: a colour per run
                ax.plot(res.t, res[name], STYLES[k % len(STYLES)], color=color, lw=1.3, label=line_label)
            if not res.success and len(res):
                ax.axvline(res.t[-1], color="tab:red", lw=0.8, ls=":")
        if len(members) == 1:
            ax.set_ylabel(f"{members[0]} [{unit}]" if unit else members[0])
        else:
            ax.set_ylabel(f"{QUANTITY.get(unit, 'value')} [{unit}]")
        if len(members) > 1 or len(runs) > 1:
            ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5), frameon=False)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    notes = []
    if zero:
        notes.append("zero throughout (not drawn): " + ", ".join(zero))
    failed = [f"{label}: {res.message}" for label, res in runs.items() if not res.success]
    notes += failed
    fig.suptitle(title or results[0].metadata.get("model", ""))
    if notes:
        fig.text(0.01, 0.002, "\n".join(notes), fontsize=7, color="tab:red" if failed else "0.35",
                 va="bottom", wrap=True)
        fig.get_layout_engine().set(h_pad=0.1, rect=(0, 0.03 * len(notes), 1, 1 - 0.03 * len(notes)))
    return fig


def save(fig, path: str | os.PathLike) -> Path:
    """Write a figure atomically, the format from the suffix (png, pdf, svg)."""
    fmt = Path(path).suffix.lstrip(".").lower() or "png"
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        fig.savefig(f, format=fmt, dpi=110)
    return Path(path)
