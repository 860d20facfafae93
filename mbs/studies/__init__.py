"""Studies of a model: parameter variation (sweep) on Dask, metrics of runs, designs of experiments.

Parameters are run-time values of the compiled model, so a study compiles once and each variant only sets
parameters (see sweep.py).
"""

from .sweep import local_cluster, sweep
from .table import StudyTable

__all__ = ["sweep", "local_cluster", "StudyTable"]
