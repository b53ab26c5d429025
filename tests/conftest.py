"""Shared fixtures."""

import pytest


@pytest.fixture(scope="session")
def cluster():
    """A real 2-worker Dask ``LocalCluster`` on loopback and a client: (cluster, client)."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        silence_logs=50,
    ) as local:
        with distributed.Client(local, set_as_default=False) as client:
            yield local, client
