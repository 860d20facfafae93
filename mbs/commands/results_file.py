"""Writing one run's results in the format its suffix names (.csv, .npz, .h5), with what the model knows.

HDF5 keeps more than the table: the scene (name, description), the output and parameter descriptions and the
units as attributes, so a file is self-explaining to whoever opens it later.
"""

from __future__ import annotations

from pathlib import Path

RESULT_FORMATS = (".csv", ".npz", ".h5", ".hdf5")


def write_results(res, path, system=None, scene: str | None = None) -> Path:
    """The results in the format of the suffix (CSV, NPZ, HDF5), atomically; a model with events also gets its
    event log beside CSV and NPZ samples (run.csv -> run.events.csv)."""
    if system is not None and system.generate(scene).events and Path(path).suffix.lower() in (".csv", ".npz"):
        res.to_events_csv(events_path(path))
    suffix = Path(path).suffix.lower()
    if suffix == ".npz":
        return res.to_npz(path)
    if suffix in (".h5", ".hdf5"):
        from mbs.runtime import hdf5
        res.metadata.setdefault("scene", scene or "")
        if system is not None:
            sc = system.scene(scene)
            res.metadata.setdefault("scene_description", (sc.description or "") if sc is not None else "")
            res.metadata.setdefault("model_description", system.model.description or "")
            res.metadata.setdefault("parameters", _parameters(system, scene))
        return hdf5.write(res, path, _descriptions(system) if system is not None else None)
    return res.to_csv(path)


def _descriptions(system) -> dict[str, str]:
    model = system.model
    found = {o.name: o.description for o in model.outputs if o.description}
    found.update({c.name: c.description for c in getattr(model, "coordinates", ()) if getattr(c, "description",
                                                                                               None)})
    return found


def _parameters(system, scene) -> dict:
    """Every parameter's value in this run's scene (SI) with its description, as JSON-ready data."""
    from mbs import pipeline
    values = pipeline.parameter_values(system.model, pipeline.scene_overrides(system.scene(scene)))
    return {p.name: {"value": values[p.name], "description": p.description or ""} for p in system.model.parameters}


def events_path(path) -> Path:
    """run.csv -> run.events.csv: the event log next to the samples."""
    p = Path(path)
    return p.with_name(f"{p.stem}.events.csv")
