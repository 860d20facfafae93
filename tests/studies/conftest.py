"""One small Dask cluster for the study tests (starting one costs seconds: the tests share it)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def dask_client():
    pytest.importorskip("distributed")
    from mbs.studies import local_cluster
    client = local_cluster(2)
    yield client
    client.close()
    client.cluster.close()
