"""Chunks of work in this process, on local processes or on a Dask cluster."""
