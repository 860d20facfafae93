"""Error against run time: every integrator over a ladder of tolerances, measured against a trusted reference.

    table = work_precision(model, data, t_end, t_eval=times)           # data: parameters and start state
    table.reference_error, table.rows[0].error, table.to_csv("wp.csv"), table.plot("wp.png")

The reference is computed by the tool itself far below the tightest tolerance (REFERENCE_FACTOR, but not
below the round-off floor) with DOPRI5 in C, and confirmed by a second, independent method and code (scipy's
DOP853, an explicit Runge-Kutta method of order 8) at the same tolerance; the distance between the two is the
reference's own estimated error, reported with the table. A run whose error is not clearly above it cannot be
judged, and the table says so (`judged`).

Error measure. Like the integrators' own error norm (weighted RMS over the components), with a weight that
does not change along the ladder so that errors of different tolerances compare: component i of a sample
counts as |y_i - ref_i| / (a + |ref_i|), a = ATOL_RATIO (the atol/rtol ratio of every run of the ladder). The
table gives the largest such norm over the samples (`error`), the norm at the end (`error_end`), and the same
for the outputs (`error_outputs`). Wall time is the integration's (the outputs are evaluated afterwards for
every method alike), the median over `repeats` runs (the machine may be shared).
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass, field

import numpy as np

from .errors import EvaluationError
from .integrators import get_integrator
from .model import CompiledModel
from .simulate import simulate
from .workspace import Workspace

#: Tolerances run by default (rtol; atol = ATOL_RATIO * rtol).
DEFAULT_TOLERANCES = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
#: Integrators run by default: the C methods, SUNDIALS', and scipy's stiff and high-order ones.
DEFAULT_INTEGRATORS = ("dopri5", "adams", "rodasp", "rodas5p", "auto", "cvode_adams", "cvode_bdf", "ida", "DOP853",
                       "Radau", "BDF")
ATOL_RATIO = 1e-2
#: The reference runs this much below the tightest tolerance ...
REFERENCE_FACTOR = 1e-3
#: ... but not below the round-off floor of double precision.
REFERENCE_FLOOR = 1e-13
COLUMNS = ("integrator", "rtol", "error", "error_end", "error_outputs", "wall_time", "nfev", "njev", "nsteps",
           "nreject", "status")


@dataclass(frozen=True)
class Row:
    integrator: str
    rtol: float
    error: float          # largest error norm over the samples, states
    error_end: float      # error norm at the last sample, states
    error_outputs: float  # largest error norm over the samples, outputs (NaN without outputs)
    wall_time: float      # median over the repeats [s]
    nfev: int
    njev: int
    nsteps: int
    nreject: int
    status: str


@dataclass
class Table:
    """The rows, the reference's estimated error and how it was obtained."""

    rows: list[Row]
    reference_error: float
    reference: str
    times: np.ndarray = field(repr=False)
    reference_states: np.ndarray = field(repr=False)

    def judged(self, row: Row) -> bool:
        """Whether the row's error lies clearly above the reference's own (so it is a measurement). A failed
        run's errors cover only the samples before the failure."""
        return row.error > 10 * self.reference_error

    def text(self) -> str:
        head = (f"reference: {self.reference}; its estimated error {self.reference_error:.2g}\n"
                f"{'integrator':<10} {'rtol':>8} {'error':>9} {'at end':>9} {'outputs':>9} {'wall [s]':>9} "
                f"{'rhs':>8} {'jac':>6} {'steps':>7} {'rejected':>8}  status")
        lines = [head]
        for r in self.rows:
            mark = "" if self.judged(r) or r.status != "finished" else " (at the reference's accuracy)"
            lines.append(f"{r.integrator:<10} {r.rtol:>8.0e} {r.error:>9.2e} {r.error_end:>9.2e} "
                         f"{r.error_outputs:>9.2e} {r.wall_time:>9.3g} {r.nfev:>8} {r.njev:>6} {r.nsteps:>7} "
                         f"{r.nreject:>8}  {r.status}{mark}")
        return "\n".join(lines)

    def to_csv(self, path) -> None:
        from mbs.base.atomic import atomic_path  # the one atomic writer of the project
        with atomic_path(path) as tmp:
            with open(tmp, "w") as f:
                f.write(",".join(COLUMNS) + "\n")
                for r in self.rows:
                    f.write(",".join(repr(getattr(r, c)) if isinstance(getattr(r, c), float) else str(getattr(r, c))
                                     for c in COLUMNS) + "\n")

    def plot(self, path, title: str = "") -> None:
        """Log-log work-precision diagram: error against wall time, one line per integrator."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from mbs.base.atomic import atomic_path
        fig, ax = plt.subplots(figsize=(7, 5))
        for name in dict.fromkeys(r.integrator for r in self.rows):
            rows = [r for r in self.rows if r.integrator == name and r.status == "finished" and r.error > 0]
            if rows:
                ax.loglog([r.wall_time for r in rows], [r.error for r in rows], "o-", label=name)
        ax.axhline(self.reference_error, color="grey", ls=":", label="reference's error")
        ax.set_xlabel("wall time [s] (median)")
        ax.set_ylabel("largest error norm over the samples [-]")
        ax.set_title(title or "work-precision")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format=str(path).rsplit(".", 1)[-1], dpi=120)
        plt.close(fig)


def work_precision(model: CompiledModel, data: Workspace, t_end: float, *, t_eval=None,
                   integrators=None, tolerances=DEFAULT_TOLERANCES, repeats: int = 3,
                   max_steps: int = 2_000_000) -> Table:
    """Run every integrator at every tolerance from (data.t, data.x) to t_end and compare with the reference.
    data is not changed. Integrators the back end cannot run are skipped; None: DEFAULT_INTEGRATORS."""
    integrators = DEFAULT_INTEGRATORS if integrators is None else integrators
    times = np.linspace(data.t, t_end, 201) if t_eval is None else np.asarray(t_eval, dtype=float)
    tight = max(min(tolerances) * REFERENCE_FACTOR, REFERENCE_FLOOR)
    ref, ref_y, _ = _run(model, data, t_end, times,
                         "dopri5" if "dopri5" in model.backend.native_methods else "RK45", tight, max_steps)
    check, _, _ = _run(model, data, t_end, times, "DOP853", tight, max_steps)
    if ref.metadata["status"] != "finished" or check.metadata["status"] != "finished":
        failed = ref if ref.metadata["status"] != "finished" else check
        raise RuntimeError(f"the reference run failed ({failed.metadata['integrator']}): {failed.message}")
    states_ref = _states(model, ref)
    reference_error = _error(_states(model, check), states_ref)
    rows = []
    for name in integrators:
        cls = get_integrator(name)
        if getattr(cls, "native_method", None) and cls.native_method not in model.backend.native_methods:
            continue
        for rtol in tolerances:
            walls, res = [], None
            for _ in range(max(1, repeats)):
                res, ys, wall = _run(model, data, t_end, times, name, rtol, max_steps)
                walls.append(wall)
            states = _states(model, res)
            n = states.shape[0]
            error = _error(states, states_ref[:n]) if n else float("nan")
            error_end = _error(states[-1:], states_ref[n - 1:n]) if n == times.size else float("nan")
            error_y = _error(ys, ref_y[:n]) if ys is not None and n else float("nan")
            stats = res.metadata["stats"]
            rows.append(Row(cls.name, rtol, error, error_end, error_y, statistics.median(walls), stats["nfev"],
                            stats["njev"], stats["nsteps"], stats["nreject"], res.metadata["status"]))
    return Table(rows, reference_error, f"dopri5 at rtol {tight:.0e}, confirmed by DOP853 at the same tolerance",
                 times, states_ref)


def _run(model, data, t_end, times, integrator, rtol, max_steps):
    """One run from data's start on a private workspace: (results, outputs or None, wall time [s]). The wall
    time is the integration's; the outputs are evaluated afterwards, outside it, the same way for every method."""
    run = Workspace(model)
    run.p, run.t, run.x = data.p, data.t, data.x.copy()
    started = time.perf_counter()
    res = simulate(model, run, t_end, t_eval=times, integrator=integrator, rtol=rtol, atol=ATOL_RATIO * rtol,
                   max_steps=max_steps, outputs=False)
    wall = time.perf_counter() - started
    ys = None
    if model.ny and "outputs" in model.functions and len(res.t):
        f = run.function("outputs")
        try:
            ys = np.array([f(t, x) for t, x in zip(res.t, _states(model, res))])
        except EvaluationError:
            ys = None
    return res, ys, wall


def _states(model, res) -> np.ndarray:
    return np.column_stack([res[n] for n in model.x_names])


def _error(y: np.ndarray, ref: np.ndarray) -> float:
    """Largest weighted RMS norm over the samples (see the module docstring)."""
    if y is None or y.size == 0:
        return float("nan")
    scaled = (y - ref) / (ATOL_RATIO + np.abs(ref))
    return float(np.max(np.sqrt(np.mean(scaled**2, axis=1))))


def global_error_estimate(res, fine) -> dict[str, float]:
    """Estimated global error of every column of `res` (largest |difference| over the samples) from a second
    run `fine` of the same problem at a tenth of the tolerances: the first run's error dominates the difference
    (the second's is about 10^(-p/(p+1)) times smaller for a method of order p), so it estimates it, in the
    column's own unit."""
    n = min(len(res.t), len(fine.t))
    return {name: float(np.max(np.abs(res[name][:n] - fine[name][:n]), initial=0.0))
            for name in res.names if name != "time" and name in fine.names}
