"""xarray objects from NumPy arrays, and reductions of them, without xarray's probe for
other array libraries.

Building a ``Variable`` from data (``Dataset(data)``, ``assign``, a reduction's result)
asks whether the data is a Dask array, which imports ``dask.array`` (and through it
``scipy.fft``) whenever Dask is installed (the ``cluster`` extra): ~0.3 s on a quiet
2-core machine, more than a 36-step run's solve. cyclomesh's results are NumPy arrays,
so the short path of a run builds its variables with ``fastpath=True`` (the data taken
as it is, the argument xarray uses internally for the same purpose) and reduces with
NumPy on ``.values``. ``tests/test_imports.py`` pins that a ``run --figures none``
never imports ``dask.array``. (xarray still imports ``dask.base`` to build an index
when Dask is installed; that part is cheap.)
"""

from __future__ import annotations

import threading
import warnings
from collections.abc import Hashable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import xarray as xr


FIRST_ARRAYS = threading.Lock()
"""Held by a thread while it builds xarray objects that may import Dask (a probe for Dask
arrays imports ``dask.array``, an index ``dask.base``): a command's preload thread
(:mod:`cyclomesh.studies.execute`) probes while the main thread may build its Dataset,
and two threads importing Dask at once can meet in its import cycle (``dask`` and
``dask.base`` import each other: "cannot import name ... from partially initialized
module 'dask.base'")."""


def variable(
    dims: str | Sequence[Hashable], values: Any, attrs: Mapping[str, Any] | None = None
) -> xr.Variable:
    """``xr.Variable(dims, values, attrs)`` of ``np.asarray(values)`` (a numeric NumPy
    array, as xarray would have stored it), without the duck-array probe."""
    import xarray as xr

    return xr.Variable(dims, np.asarray(values), dict(attrs or {}), fastpath=True)


def nan_reduce(
    var: xr.DataArray | xr.Variable, how: str, over: Sequence[Hashable], keep: Sequence[Hashable]
) -> np.ndarray:
    """``var.<how>(over)`` transposed to ``keep`` as a NumPy array, the reduction xarray
    applies by default (``skipna``: ``np.nanmax``/``np.nanmin``/``np.nanmean`` for floats,
    ``np.max``/``np.min``/``np.mean`` otherwise; an all-NaN slice gives NaN silently)."""
    values = var.transpose(*keep, *over).values
    axes = tuple(range(len(keep), values.ndim))
    func = getattr(np, f"nan{how}" if values.dtype.kind in "cf" else how)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return func(values, axis=axes)
