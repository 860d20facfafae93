"""Parameter variation on Dask: a study of one scene over a design of parameter values.

    import mbs
    from mbs.studies import sweep
    system = mbs.load("library/examples/pendulum.mbs")
    table = sweep(system, "swing", {"l": [0.5, 1, 2]}, metrics=["period(hinge.phi)"])
    table["period(hinge.phi)"], table.to_csv("periods.csv"), table.plot("periods.png")

The model is derived and compiled once, here; its package (the built binary) goes to every worker once
(scattered) and each variant only sets run-time parameters: a variant never recompiles. The runs execute on a
Dask cluster: a LocalCluster on this machine (one single-threaded worker process per core) unless a scheduler
address or a Client is given, so a study that outgrows one machine changes one argument.
"""

from __future__ import annotations

import logging
import os
from contextlib import contextmanager
from typing import Callable, Mapping, Sequence

import numpy as np

from mbs import pipeline

from .design import design as make_design
from .metrics import REDUCTIONS, default_metrics, parse
from .package import ModelPackage
from .table import StudyTable
from .variant import Outcome, Variant, run_variant

Progress = Callable[[int, int], None]


def sweep(system, scene: str | None, params: Mapping[str, Sequence[float]], *, design: str = "grid",
          n: int | None = None, seed: int = 0, metrics: Sequence[str] | None = None, fixed: Mapping | None = None,
          scheduler: str | None = None, client=None, workers: int | None = None, progress: Progress | None = None,
          t_end: float | None = None, sample: float | None = None, integrator: str | None = None,
          rtol: float | None = None, atol: float | None = None, hooks=None) -> StudyTable:
    """Run every variant of the design (values of `params`, SI units) and measure it; `fixed` parameters are set
    in every run. Metrics default to the peak and final value of each of the scene's outputs. The runs go to
    `client`, else to the cluster at `scheduler`, else to a local cluster of `workers` processes (default: one
    per core). hooks: the implementations of the model's user hooks, as for System.simulate (package.py: how
    they reach the workers). Returns the table in variant order; failed variants are rows with NaN metrics and
    their message."""
    from mbs.runtime.hooks import bind
    from mbs.system import _settings
    binding = bind(system.model.hooks, hooks, system.model.name)  # checked before anything compiles
    sc = system.scene(scene)
    package = ModelPackage.of(system, scene, binding)  # unpicklable hooks refused before the first run
    compiled = system.compile(scene, hooks=binding)
    gen = system.generate(scene)
    columns = ("time",) + compiled.x_names + compiled.y_names
    texts = list(metrics) if metrics else default_metrics(compiled.y_names or compiled.q_names)
    parsed = [parse(text, columns) for text in texts]  # every metric checked before the first run
    points = make_design({name: list(map(float, v)) for name, v in params.items()}, design, n, seed)
    settings = _settings(sc, t_end, sample, integrator, rtol, atol)
    start = sc.start if sc is not None else "initial"
    variants, early = [], []
    for index, values in enumerate(points):
        overrides = {**pipeline.scene_overrides(sc), **(fixed or {}), **values}
        try:
            every = pipeline.parameter_values(system.model, overrides)
            x0 = pipeline.initial_state(gen, every)
        except Exception as exc:  # a variant whose start cannot be computed is a row, not a lost study
            early.append(Outcome(index, values, {m.text: np.nan for m in parsed}, "failed", str(exc)))
            continue
        variants.append(Variant(index, values, np.array(pipeline.parameter_vector(compiled.p_names, every)), x0, settings,
                                start))
    rows = early + run_on_dask(package, variants, tuple(m.text for m in parsed), scheduler=scheduler,
                               client=client, workers=workers, progress=progress, done=len(early),
                               total=len(points))
    rows.sort(key=lambda row: row.index)
    units = pipeline.units_of(gen)
    metadata = {"model": system.model.name, "scene": scene, "design": design if design == "grid" else
                f"{design} {n} (seed {seed})", "settings": settings, "fixed": dict(fixed or {}),
                "units": {**{p: units[p] for p in params if p in units}, **_metric_units(parsed, units)}}
    return StudyTable(tuple(params), tuple(m.text for m in parsed), rows, metadata)


def _metric_units(parsed, units: Mapping[str, str]) -> dict[str, str]:
    """A reduction of one column has that column's unit (a period is in seconds); other expressions none."""
    import ast
    out = {}
    for metric in parsed:
        node = metric.tree.body
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in REDUCTIONS \
                and len(metric.columns) == 1:
            unit = "s" if node.func.id == "period" else units.get(metric.columns[0])
            if unit:
                out[metric.text] = unit
    return out


def local_cluster(workers: int | None = None):
    """A Client on a LocalCluster of single-threaded worker processes (default: one per core)."""
    from distributed import Client, LocalCluster
    cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR)
    return Client(cluster)


@contextmanager
def dask_client(scheduler: str | None = None, client=None, workers: int | None = None):
    """The given Client; else one on the scheduler at `scheduler`; else one on a new local cluster. What this
    opened it closes on exit (a cluster the caller named keeps running)."""
    if client is not None:
        yield client
        return
    from distributed import Client
    client = Client(scheduler) if scheduler else local_cluster(workers)
    try:
        yield client
    finally:
        cluster = None if scheduler else client.cluster
        client.close()
        if cluster is not None:
            cluster.close()


def run_on_dask(package, variants: Sequence[Variant], metrics: tuple[str, ...], *,
                scheduler: str | None = None, client=None, workers: int | None = None,
                progress: Progress | None = None, done: int = 0, total: int | None = None) -> list[Outcome]:
    """Outcomes of the variants, run as Dask tasks (a lost worker fails its variants, not the study). `package` is
    a ModelPackage, or the future of one already scattered to the cluster (a caller running many batches)."""
    from distributed import as_completed
    total = len(variants) + done if total is None else total
    if not variants:
        return []
    with dask_client(scheduler, client, workers) as client:
        shipped = client.scatter(package, broadcast=True, hash=False) if isinstance(package, ModelPackage) else package
        futures = {client.submit(run_variant, shipped, v, metrics, pure=False): v for v in variants}
        outcomes = []
        for future in as_completed(futures):
            variant = futures[future]
            try:
                outcomes.append(future.result())
            except Exception as exc:  # the worker died or the task could not run
                outcomes.append(Outcome(variant.index, variant.values, {m: np.nan for m in metrics}, "failed",
                                        f"the task failed on the cluster: {type(exc).__name__}: {exc}"))
            done += 1
            if progress is not None:
                progress(done, total)
        return outcomes
