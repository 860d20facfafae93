"""Results as HDF5 (h5py): one dataset per column, so other tools read a signal by its name with its unit.

Layout: a root attribute ``kind = "mbs results"``; dataset ``time`` and one dataset per column under
``columns/`` (named as the column, which may contain dots and parentheses), each with attributes ``unit`` and
``description`` when known; ``column_order`` (strings) keeps the table's order. The run's metadata (model,
integrator, tolerances, status, message, stats, scene settings) are root attributes, plain numbers and strings
as themselves and anything nested as JSON text; an event log (a list of events in metadata["events"]) is a
dataset ``events`` of JSON lines.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from mbs.base.atomic import atomic_path

KIND = "mbs results"


def _attribute(value):
    if isinstance(value, (bool, int, float, str)) and value is not None:
        return value
    return json.dumps(value, default=lambda v: v.tolist() if hasattr(v, "tolist") else str(v))


def write(results, path: str | os.PathLike, descriptions: dict[str, str] | None = None) -> Path:
    """Write Results atomically (h5py is a dependency of mbs; imported only here)."""
    import h5py
    units = results.metadata.get("units", {})
    descriptions = dict(descriptions or results.metadata.get("descriptions", {}))
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs["kind"] = KIND
        for key, value in results.metadata.items():
            if key == "events":
                continue
            f.attrs[key] = _attribute(value)
        f.create_dataset("column_order", data=list(results.names), dtype=h5py.string_dtype())
        columns = f.create_group("columns")
        for name in results.names:
            d = columns.create_dataset(name.replace("/", "\u2215"), data=results[name])
            unit = "s" if name == "time" else units.get(name)
            if unit:
                d.attrs["unit"] = unit
            if descriptions.get(name):
                d.attrs["description"] = descriptions[name]
        if results.metadata.get("events"):
            f.create_dataset("events", data=[_attribute(e) for e in results.metadata["events"]],
                             dtype=h5py.string_dtype())
    return Path(path)


def read(path: str | os.PathLike):
    """Results from a file written by :func:`write` (units and descriptions back into the metadata)."""
    import h5py

    from .errors import UsageError
    from .results import Results
    with h5py.File(path, "r") as f:
        if f.attrs.get("kind") != KIND:
            raise UsageError(f"{path}: not an mbs results file (no attribute kind = '{KIND}')")
        names = [str(n) for n in f["column_order"].asstr()[()]]
        data = np.column_stack([f["columns"][n.replace("/", "\u2215")][()] for n in names])
        metadata = {}
        for key, value in f.attrs.items():
            if key == "kind":
                continue
            if isinstance(value, str) and value[:1] in "[{\"":
                try:
                    value = json.loads(value)
                except ValueError:
                    pass
            metadata[key] = value.item() if isinstance(value, np.generic) else value
        units, descriptions = {}, {}
        for n in names:
            attrs = f["columns"][n.replace("/", "\u2215")].attrs
            if "unit" in attrs and n != "time":
                units[n] = str(attrs["unit"])
            if "description" in attrs:
                descriptions[n] = str(attrs["description"])
        metadata["units"] = {**metadata.get("units", {}), **units}
        if descriptions:
            metadata["descriptions"] = descriptions
        if "events" in f:
            metadata["events"] = [json.loads(e) if e[:1] in "[{" else e for e in f["events"].asstr()[()]]
    return Results(names, data, metadata)
