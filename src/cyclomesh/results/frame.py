"""A result held as plain NumPy arrays with names, dimensions and attributes: the one
description of a result's variables that both the NetCDF/Parquet/CSV writers and the
xarray Dataset of the API are made from.

A :class:`Frame` is what :func:`cyclomesh.results.dataset.analyse_frame` returns and what
``cyclomesh run`` computes, summarises and writes: building it imports neither xarray
nor pandas (about 0.4 s of a 36-step run, issue 27). :meth:`Frame.to_xarray` gives the
:class:`xarray.Dataset` of :func:`cyclomesh.analyse`, variable for variable, attribute
for attribute (``tests/results/test_frame.py``); the figures and the notebook API use it.

Frames and Datasets are read the same way by the code that takes either (the writers of
:mod:`cyclomesh.output.writers`, :func:`cyclomesh.results.dataset.summarize`, the
requirement checks): ``ds[name].dims / .values / .attrs / .transpose(...)``,
``ds.sizes``, ``ds.dims``, ``ds.data_vars``, ``ds.coords``, ``ds.variables``,
``ds.attrs``, ``name in ds``, ``ds.assign``, ``ds.drop_vars``. Only that subset exists
here; anything else goes through :meth:`Frame.to_xarray`.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["Var", "Frame", "as_frame", "as_xarray"]


class Var:
    """A named array's dimensions, values (a NumPy array) and attributes (units,
    long name), as ``xarray.Variable`` holds them; ``coords`` are the coordinates of
    the frame it belongs to (for :meth:`sel` and ``var[coordinate]``)."""

    __slots__ = ("dims", "values", "attrs", "coords")

    def __init__(
        self,
        dims: str | Sequence[Hashable],
        values: Any,
        attrs: Mapping[str, Any] | None = None,
        coords: Mapping[str, Var] | None = None,
    ) -> None:
        self.dims = (dims,) if isinstance(dims, str) else tuple(str(d) for d in dims)
        self.values = np.asarray(values)
        self.attrs = dict(attrs or {})
        self.coords = coords if coords is not None else {}
        if self.values.ndim != len(self.dims):
            raise ValueError(f"{self.values.ndim}-d values for dimensions {self.dims}")

    @property
    def ndim(self) -> int:
        return self.values.ndim

    @property
    def shape(self) -> tuple[int, ...]:
        return self.values.shape

    @property
    def size(self) -> int:
        return self.values.size

    @property
    def dtype(self) -> np.dtype:
        return self.values.dtype

    def transpose(self, *dims: str) -> Var:
        """The same variable with its dimensions in the order ``dims`` (all of them)."""
        order = [self.dims.index(d) for d in dims]
        return Var(dims, np.transpose(self.values, order), self.attrs, self.coords)

    def sel(self, indexers: Mapping[str, Any] | None = None, **more: Any) -> Var:
        """The variable at one coordinate value per named dimension (that dimension
        dropped), as ``DataArray.sel(dim=value)``."""
        out = self
        for dim, value in {**(indexers or {}), **more}.items():
            where = np.flatnonzero(out.coords[dim].values == value)
            if len(where) != 1:
                raise KeyError(f"{dim}={value!r}")
            axis = out.dims.index(dim)
            dims = out.dims[:axis] + out.dims[axis + 1 :]
            out = Var(dims, np.take(out.values, where[0], axis=axis), out.attrs, out.coords)
        return out

    def __getitem__(self, name: str) -> Var:
        return self.coords[name]


class Frame:
    """Data variables and dimension coordinates (:class:`Var`), and attributes.

    ``variables`` lists them in the order a file holds them (the data variables, then
    the coordinates), as ``xarray.Dataset.variables`` does for the Dataset that
    :meth:`to_xarray` builds.
    """

    def __init__(
        self,
        data: Mapping[str, Var | tuple],
        coords: Mapping[str, Var | tuple] | None = None,
        attrs: Mapping[str, Any] | None = None,
    ) -> None:
        self.coords: dict[str, Var] = {}
        for name, var in (coords or {}).items():
            self.coords[name] = self._own(var)
        self.data_vars: dict[str, Var] = {name: self._own(var) for name, var in data.items()}
        self.attrs: dict[str, Any] = dict(attrs or {})
        for name, var in self.coords.items():
            if var.dims != (name,):
                raise ValueError(f"coordinate {name} must be a dimension coordinate")
        sizes: dict[str, int] = {}
        for var in (*self.data_vars.values(), *self.coords.values()):
            for dim, size in zip(var.dims, var.shape, strict=True):
                if sizes.setdefault(dim, size) != size:
                    raise ValueError(f"dimension {dim}: sizes {sizes[dim]} and {size}")
        self.sizes = sizes

    def _own(self, var: Var | tuple) -> Var:
        if not isinstance(var, Var):
            var = Var(*var)
        return Var(var.dims, var.values, var.attrs, self.coords)

    @property
    def dims(self) -> dict[str, int]:
        """Dimension → size (membership and iteration as ``Dataset.dims``)."""
        return self.sizes

    @property
    def variables(self) -> dict[str, Var]:
        return {**self.data_vars, **self.coords}

    def __contains__(self, name: object) -> bool:
        return name in self.data_vars or name in self.coords

    def __getitem__(self, name: str) -> Var:
        if name in self.data_vars:
            return self.data_vars[name]
        return self.coords[name]

    def assign(self, variables: Mapping[str, Var | tuple]) -> Frame:
        """A new frame with ``variables`` added (or replaced), attributes copied."""
        data = dict(self.data_vars)
        for name, var in variables.items():
            data[name] = var if isinstance(var, Var) else Var(*var)
        return Frame(data, self.coords, self.attrs)

    def assign_coords(self, **coords: Var | tuple) -> Frame:
        """A new frame with these dimension coordinates replaced or added (last, as
        ``Dataset.assign_coords`` orders them)."""
        kept = {k: v for k, v in self.coords.items() if k not in coords}
        return Frame(self.data_vars, {**kept, **coords}, self.attrs)

    def drop_vars(self, names: str | Iterable[str], errors: str = "raise") -> Frame:
        """A new frame without ``names`` (data variables or coordinates)."""
        drop = {names} if isinstance(names, str) else set(names)
        missing = drop - set(self.data_vars) - set(self.coords)
        if missing and errors == "raise":
            raise KeyError(f"no variable {sorted(missing)[0]!r}")
        data = {k: v for k, v in self.data_vars.items() if k not in drop}
        coords = {k: v for k, v in self.coords.items() if k not in drop}
        return Frame(data, coords, self.attrs)

    def to_xarray(self) -> xr.Dataset:
        """The :class:`xarray.Dataset` of these variables, coordinates and attributes
        (the arrays shared, not copied)."""
        import xarray as xr

        from cyclomesh.results.arrays import variable

        return xr.Dataset(
            {k: variable(v.dims, v.values, v.attrs) for k, v in self.data_vars.items()},
            coords={k: variable(v.dims, v.values, v.attrs) for k, v in self.coords.items()},
            attrs=dict(self.attrs),
        )


def as_xarray(ds: Frame | xr.Dataset) -> xr.Dataset:
    """``ds`` as an :class:`xarray.Dataset` (a Frame converted, a Dataset as it is)."""
    return ds.to_xarray() if isinstance(ds, Frame) else ds


def as_frame(ds: Frame | xr.Dataset) -> Frame:
    """``ds`` as a :class:`Frame` (a Dataset with dimension coordinates only)."""
    if isinstance(ds, Frame):
        return ds
    return Frame(
        {str(k): Var(v.dims, v.values, v.attrs) for k, v in ds.data_vars.items()},
        {str(k): Var(v.dims, v.values, v.attrs) for k, v in ds.coords.items()},
        ds.attrs,
    )
