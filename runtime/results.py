"""Simulation results: named columns (time, states, outputs) with the run's metadata.

Files are written atomically (a temporary file in the same directory, fsync, os.replace): a reader
sees the old file or the complete new one, never a partial one.

CSV layout: metadata lines ``# key: <JSON value>``, one header line of column names, then rows with
17 significant digits (exact round trip of float64).  NPZ layout: arrays ``data`` (n, ncols), ``names``
(ncols,), ``metadata`` and ``events`` (JSON strings; the event log); readable with ``allow_pickle=False``.
"""

from __future__ import annotations

import functools
import io
import json
import os
from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from mbs.base.atomic import atomic_path

from .errors import SimulationError, UsageError

TIME = "time"
EVENT_COLUMNS = ("time", "event", "direction", "changes")
#: A plot marks at most this many events (a chattering contact would paint the plot grey).
MAX_EVENT_MARKS = 500
_FLOAT64 = np.dtype(np.float64)


def _jsonable(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"cannot store {type(value).__name__} in result metadata")


@functools.lru_cache(maxsize=64)
def _column_index(names: tuple[str, ...]) -> dict[str, int]:
    """{name: column} of checked column names (unique, non-empty, without commas or newlines), worked out once per
    set of names: a model's runs all have the same columns."""
    if len(set(names)) != len(names):
        raise UsageError("column names must be unique")
    for name in names:
        if "," in name or "\n" in name or not name:
            raise UsageError(f"column name {name!r} must be non-empty without commas or newlines")
    return {n: i for i, n in enumerate(names)}


@functools.lru_cache(maxsize=64)
def _str_columns(names: tuple) -> tuple[tuple[str, ...], dict[str, int]] | None:
    """(names, _column_index(names)) of a tuple of str column names, worked out once per tuple: str() of each of a
    run's 117 columns was two thirds of making its Results; None when a name is not a str (then str() it is)."""
    if not all(type(n) is str for n in names):
        return None
    return names, _column_index(names)


def _names_and_index(names) -> tuple[tuple[str, ...], dict]:
    """(the column names as a tuple of str, their index): a tuple of str worked out once (_str_columns), anything
    else str() name by name."""
    try:
        known = _str_columns(names) if type(names) is tuple else None
    except TypeError:  # an unhashable name
        known = None
    if known is not None:
        return known
    names = tuple(map(str, names))
    return names, _column_index(names)


class Results:
    """A table of samples: ``names`` (ncols,) column names, ``data`` (n, ncols) values in SI units.

    ``res["hinge.phi"]`` is one column (read-only view), ``res.t`` the time column [s].  ``metadata``
    holds model, integrator, tolerances, status ("finished", "failed", "stopped") and message.
    """

    def __init__(self, names: Iterable[str], data, metadata: Mapping | None = None, events=None, *,
                 copy: bool = True):
        """copy=False: ``data``, when already a 2-D float64 array, is kept as it is and made read-only in place
        (for the simulation driver, whose table is fresh and its own: no copy of every sample).  ``events``: the
        event log's rows, or an object whose rows() gives them, called when ``events`` is first read (the driver's
        log: bump_10's 392 dicts cost 0.66 M instructions, a tenth of its Python after the integration)."""
        self.names, self._index = _names_and_index(names)  # (the index shared by results of the same columns)
        data = np.array(data, dtype=float, ndmin=2, copy=True if copy else None)
        if data.size == 0:
            data = data.reshape(0, len(self.names))
        if data.ndim != 2 or data.shape[1] != len(self.names):
            raise UsageError(f"data of shape {data.shape} does not match {len(self.names)} column names")
        data.flags.writeable = False
        self._data = data
        self._blocks = None  # (Results.of_blocks: the table's columns in blocks, joined when data is first read)
        self._keep(metadata, events)

    def _keep(self, metadata: Mapping | None, events) -> None:
        self.metadata = dict(metadata or {})
        # the event log (the property events): a list, or what makes it when first read (an object with rows(): the
        # simulation driver's log, runtime/event_loop.py EventLog, whose dict per entry is made only if it is read)
        self._events = events if hasattr(events, "rows") else list(events or [])

    @classmethod
    def of_blocks(cls, names: tuple, blocks, metadata: Mapping | None = None, events=None) -> "Results":
        """Results whose table is ``blocks`` side by side: 2-D float64 arrays of as many rows (the simulation driver's
        time, states and outputs, fresh and its own: made read-only in place, kept without a copy). A column is read
        from its block; the joined table (``data``) is made when it is first read: a caller that reads columns by name
        never pays for it (bump_10's 858 rows of 117 columns: 0.8 MB of fresh memory written, 0.23 M instructions).
        ``names``: a tuple, as for the constructor."""
        names, index = _names_and_index(names)
        blocks = tuple(blocks)
        rows = blocks[0].shape[0]
        for b in blocks:
            if b.ndim != 2 or b.dtype != _FLOAT64 or b.shape[0] != rows:
                raise UsageError("blocks of columns: 2-D float64 arrays of as many rows")
        width = sum(b.shape[1] for b in blocks)
        if width != len(names):
            raise UsageError(f"blocks of {width} columns do not match {len(names)} column names")
        for b in blocks:
            b.flags.writeable = False
        results = cls.__new__(cls)  # (no table to check or copy)
        results.names, results._index = names, index
        results._data, results._blocks = None, blocks
        results._keep(metadata, events)
        return results

    @property
    def data(self) -> np.ndarray:
        """(n, ncols) every column, read-only."""
        if self._data is None:
            data = np.concatenate(self._blocks, axis=1)
            data.flags.writeable = False
            self._data, self._blocks = data, None
        return self._data

    @data.setter
    def data(self, value) -> None:
        self._data, self._blocks = value, None

    @property
    def events(self) -> list[dict]:
        """The event log: one dict per event with time [s], event (name), direction, changes (what it set)."""
        if not isinstance(self._events, list):
            self._events = list(self._events.rows())
        return self._events

    @events.setter
    def events(self, value) -> None:
        self._events = list(value or [])

    # -- access ----------------------------------------------------------------------------------

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            column = self._index[name]
        except KeyError:
            raise KeyError(f"no column '{name}' (columns: {', '.join(self.names)})") from None
        if self._blocks is None:
            return self._data[:, column]
        for block in self._blocks:  # (a view of its block, read-only as the table's)
            if column < block.shape[1]:
                return block[:, column]
            column -= block.shape[1]

    def __contains__(self, name: str) -> bool:
        return name in self._index

    def __len__(self) -> int:
        return (self._data if self._blocks is None else self._blocks[0]).shape[0]

    @property
    def t(self) -> np.ndarray:
        return self[TIME]

    def columns(self, names: Iterable[str]) -> np.ndarray:
        """(n, len(names)) array of the named columns."""
        return np.column_stack([self[n] for n in names]) if names else np.empty((len(self), 0))

    @property
    def units(self) -> dict[str, str]:
        """{column: unit} of the columns with a unit (values are SI; units as the model named them)."""
        known = {TIME: "s", **self.metadata.get("units", {})}
        return {n: known[n] for n in self.names if n in known}

    def unit(self, name: str) -> str | None:
        """The unit of a column ('N*m', 'rad', '1' for a plain number), None when unknown."""
        self[name]  # an unknown column is a KeyError listing the columns
        return self.units.get(name)

    @property
    def success(self) -> bool:
        return self.metadata.get("status", "finished") == "finished"

    @property
    def message(self) -> str:
        return self.metadata.get("message", "")

    def check(self) -> "Results":
        """Raise SimulationError with the run's message unless it finished; returns self."""
        if not self.success:
            raise SimulationError(self.message or f"the run ended with status {self.metadata.get('status')}")
        return self

    def __repr__(self) -> str:
        return f"Results({len(self)} rows, columns={list(self.names)}, status={self.metadata.get('status')!r})"

    # -- hand-off to data-analysis libraries (imported only when asked for) --------------------------

    def to_pandas(self):
        """pandas.DataFrame indexed by time [s], one column per name; ``df.attrs`` holds the metadata, units
        under "units"."""
        import pandas as pd
        frame = pd.DataFrame(self.data[:, 1:], columns=list(self.names[1:]),
                             index=pd.Index(self.t, name=TIME))
        frame.attrs = {**self.metadata, "units": self.units}
        return frame

    def to_xarray(self):
        """xarray.Dataset over the coordinate time [s]; each variable's ``attrs["units"]`` is its unit, the
        run's metadata is in ``ds.attrs``."""
        import xarray as xr
        units = self.units
        variables = {n: (TIME, self[n], {"units": units[n]} if n in units else {}) for n in self.names[1:]}
        attrs = {k: json.dumps(v, default=_jsonable) if isinstance(v, (dict, list)) else v
                 for k, v in self.metadata.items() if k != "units"}
        return xr.Dataset(variables, coords={TIME: (TIME, self.t, {"units": "s"})}, attrs=attrs)

    # -- files -------------------------------------------------------------------------------------

    def to_csv(self, path: str | os.PathLike) -> Path:
        """Write CSV atomically; returns the path."""
        with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8", newline="\n") as f:
            for key, value in self.metadata.items():
                f.write(f"# {key}: {json.dumps(value, default=_jsonable)}\n")
            f.write(",".join(self.names) + "\n")
            np.savetxt(f, self.data, delimiter=",", fmt="%.17g")
        return Path(path)

    def to_events_csv(self, path: str | os.PathLike) -> Path:
        """Write the event log as CSV (columns time, event, direction, changes) atomically; returns the path."""
        import csv
        with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8", newline="") as f:
            writer = csv.writer(f, lineterminator="\n")
            writer.writerow(EVENT_COLUMNS)
            for row in self.events:
                writer.writerow([repr(float(row["time"])), row["event"], row["direction"], row["changes"]])
        return Path(path)

    @classmethod
    def from_csv(cls, path: str | os.PathLike) -> "Results":
        metadata, header, rows = {}, None, []
        with open(path, encoding="utf-8") as f:
            for line in f:
                if header is None and line.startswith("# "):
                    key, _, value = line[2:].rstrip("\n").partition(": ")
                    metadata[key] = json.loads(value)
                elif header is None:
                    header = line.rstrip("\n").split(",")
                else:
                    rows.append(line)
        if header is None:
            raise UsageError(f"{path}: no header line; not a results CSV file")
        data = np.loadtxt(io.StringIO("".join(rows)), delimiter=",", ndmin=2) if rows else np.empty((0, len(header)))
        return cls(header, data, metadata)

    def to_npz(self, path: str | os.PathLike) -> Path:
        """Write NPZ atomically (written through a file object, so no '.npz' is appended); returns the path."""
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            np.savez(f, data=self.data, names=np.array(self.names, dtype=str),
                     metadata=np.array(json.dumps(self.metadata, default=_jsonable)),
                     events=np.array(json.dumps(self.events, default=_jsonable)))
        return Path(path)

    @classmethod
    def from_npz(cls, path: str | os.PathLike) -> "Results":
        with np.load(path, allow_pickle=False) as z:
            events = json.loads(str(z["events"])) if "events" in z.files else None
            return cls([str(n) for n in z["names"]], z["data"], json.loads(str(z["metadata"])), events=events)

    def to_hdf5(self, path: str | os.PathLike) -> Path:
        """Write HDF5 atomically: a dataset per column with its unit and description (see hdf5.py)."""
        from . import hdf5
        return hdf5.write(self, path)

    @classmethod
    def from_hdf5(cls, path: str | os.PathLike) -> "Results":
        from . import hdf5
        return hdf5.read(path)

    def plot(self, names: Iterable[str] | str | None = None, path: str | os.PathLike | None = None, *,
             title: str | None = None):
        """The named columns (default: every column but time) over time, grouped by unit into few panels,
        channels that stay zero named in a note instead of drawn (runtime/plotting.py). Returns the matplotlib
        Figure; with `path` it is also written there atomically (format from the suffix)."""
        from . import plotting
        names = [names] if isinstance(names, str) else list(names if names is not None else self.names[1:])
        fig = plotting.figure({"": self}, names, title=title or "")
        if path is not None:
            plotting.save(fig, path)
        return fig
