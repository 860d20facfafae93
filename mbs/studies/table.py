"""The table of a study: one row per variant with its parameters, its metrics, its status and message.

Written as CSV (``# key: JSON`` metadata lines, then a header, as the run results), as HDF5 (one dataset per
column, units and the study's settings as attributes) and plotted as metric against parameter.
"""

from __future__ import annotations

import csv
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mbs.base.atomic import atomic_path

from .variant import Outcome


@dataclass
class StudyTable:
    """Rows of a study in variant order. ``parameters`` and ``metrics`` name the numeric columns."""

    parameters: tuple[str, ...]
    metrics: tuple[str, ...]
    rows: list[Outcome]
    metadata: dict = field(default_factory=dict)

    def column(self, name: str) -> np.ndarray:
        """A parameter or metric over the variants."""
        if name in self.parameters:
            return np.array([row.values[name] for row in self.rows], dtype=float)
        if name in self.metrics:
            return np.array([row.metrics.get(name, math.nan) for row in self.rows], dtype=float)
        raise KeyError(f"no column '{name}' (columns: {', '.join(self.parameters + self.metrics)})")

    __getitem__ = column

    @property
    def failed(self) -> list[Outcome]:
        return [row for row in self.rows if row.status != "finished"]

    def __len__(self) -> int:
        return len(self.rows)

    def __repr__(self) -> str:
        return f"StudyTable({len(self)} variants, {len(self.failed)} failed, metrics={list(self.metrics)})"

    # -- files -------------------------------------------------------------------------------------------------
    def to_csv(self, path: str | os.PathLike) -> Path:
        """Parameters, metrics, status, message: one line per variant (17 significant digits), atomically."""
        with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8", newline="") as f:
            for key, value in self.metadata.items():
                f.write(f"# {key}: {json.dumps(value)}\n")
            writer = csv.writer(f, lineterminator="\n")
            writer.writerow([*self.parameters, *self.metrics, "status", "message"])
            for row in self.rows:
                numbers = [row.values[p] for p in self.parameters] + [row.metrics.get(m, math.nan)
                                                                       for m in self.metrics]
                writer.writerow([f"{x:.17g}" for x in numbers] + [row.status, row.message])
        return Path(path)

    def to_hdf5(self, path: str | os.PathLike) -> Path:
        """An HDF5 file: group 'parameters' and 'metrics' (a dataset per column), 'status' and 'message' (strings),
        the study's settings and units as attributes of the root."""
        import h5py
        with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
            f.attrs["kind"] = "mbs study"
            for key, value in self.metadata.items():
                f.attrs[key] = json.dumps(value)
            units = self.metadata.get("units", {})
            for group, names in (("parameters", self.parameters), ("metrics", self.metrics)):
                g = f.create_group(group)
                for name in names:
                    d = g.create_dataset(name, data=self.column(name))
                    if units.get(name):
                        d.attrs["unit"] = units[name]
            strings = h5py.string_dtype()
            f.create_dataset("status", data=[row.status for row in self.rows], dtype=strings)
            f.create_dataset("message", data=[row.message for row in self.rows], dtype=strings)
        return Path(path)

    def plot(self, path: str | os.PathLike, *, x: str | None = None, title: str | None = None) -> Path:
        """Each metric against a swept parameter (x, default the first); with a second swept parameter on a grid
        one line per value of it. Failed variants are marked with a red cross on the axis."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        x = x or self.parameters[0]
        others = [p for p in self.parameters if p != x]
        units = self.metadata.get("units", {})
        fig = Figure(figsize=(8, 2.0 + 2.0 * len(self.metrics)), layout="constrained")
        FigureCanvasAgg(fig)
        axes = fig.subplots(max(1, len(self.metrics)), 1, sharex=True, squeeze=False)[:, 0]
        xs = self.column(x)
        groups = {(): np.arange(len(self))}
        if len(others) == 1 and len(set(self.column(others[0]))) <= 8:
            second = self.column(others[0])
            groups = {(others[0], v): np.nonzero(second == v)[0] for v in sorted(set(second))}
        for ax, metric in zip(axes, self.metrics):
            ys = self.column(metric)
            for key, rows in groups.items():
                order = rows[np.argsort(xs[rows])]
                label = f"{key[0]} = {key[1]:g} {units.get(key[0], '')}".rstrip() if key else None
                style = "o-" if len(groups) > 1 or len(others) == 0 else "o"
                ax.plot(xs[order], ys[order], style, label=label)
            bad = ~np.isfinite(ys)
            if bad.any():
                ax.plot(xs[bad], np.zeros(bad.sum()), "x", color="tab:red", label="failed")
            ax.set_ylabel(metric, fontsize=8)
            ax.grid(True, alpha=0.3)
        if len(groups) > 1 or any(not np.all(np.isfinite(self.column(m))) for m in self.metrics):
            axes[0].legend(fontsize=8)
        axes[-1].set_xlabel(f"{x} [{units[x]}]" if units.get(x) else x)
        fig.suptitle(title or self.metadata.get("model", "study"))
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            fig.savefig(f, format=Path(path).suffix.lstrip(".").lower() or "png")
        return Path(path)

    def to_pandas(self):
        """A pandas DataFrame (pandas is optional: installed by the user)."""
        import pandas as pd
        data = {name: self.column(name) for name in self.parameters + self.metrics}
        data["status"] = [row.status for row in self.rows]
        data["message"] = [row.message for row in self.rows]
        return pd.DataFrame(data)
