"""The one results writer: NetCDF, Parquet, CSV, JSON and TOML files of every kind of study.

Files (see ``docs/study-files.md``):

- NetCDF (:func:`write_netcdf`): a Dataset as it is, units in attributes.
- Parquet (:func:`write_parquet`, pyarrow): the pin-level results in long format, one
  row per crank angle and pin (and ring), the columns of :func:`long_table`; each
  column's unit and long name are in its field metadata (``units``, ``long_name``).
- Pin-level CSV (:func:`write_pin_csv`, opt-in ``--csv``): the same table as text.
- Per-angle CSV (:func:`write_angle_csv`): one row per crank angle with TE, ratio,
  contacts, rotations, and the peak loads and stresses over the pins.
Every file is written atomically (:func:`cyclomesh.output.folder.atomic_write`: a
temporary name in the same folder, renamed into place).

- JSON (:func:`write_json`) through the one cleaner :func:`jsonable` (NaN and
  infinities as ``null``, NumPy scalars as numbers), and TOML (:func:`toml_dumps`).

Column names are the variable names with their unit suffix (:func:`csv_column`:
``pin_load`` in N → ``pin_load_n``). A value that is not finite (an infinite backlash:
the loaded flank cannot reach the pin) is a missing value (``null`` in Parquet, an
empty cell in CSV, which spreadsheets ignore); booleans are 0/1 in CSV.

pyarrow and xarray are imported when a file is written, not on import.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from cyclomesh.output.folder import active_folder, atomic_write, write_text
from cyclomesh.results.arrays import nan_reduce

if TYPE_CHECKING:
    import pyarrow as pa
    import xarray as xr

    from cyclomesh.results.frame import Frame

__all__ = [
    "csv_column",
    "jsonable",
    "write_json",
    "write_netcdf",
    "long_table",
    "write_parquet",
    "write_pin_csv",
    "angle_table",
    "write_angle_csv",
    "toml_dumps",
]

_UNIT_SUFFIX = {
    "N": "n",
    "MPa": "mpa",
    "arcsec": "arcsec",
    "deg": "deg",
    "mm": "mm",
    "um": "um",
    "µm": "um",
    "urad": "urad",
    "µrad": "urad",
    "N·m": "nm",
    "N·m/arcmin": "nm_per_arcmin",
    "%": "pct",
    "1": "",
    "": "",
}


def csv_column(name: str, units: str | None) -> str:
    """Column name: the variable name with its unit suffix (``pin_load`` + N → ``pin_load_n``)."""
    suffix = _UNIT_SUFFIX.get((units or "").strip(), (units or "").strip().lower())
    if not suffix or name.endswith(f"_{suffix}"):
        return name
    return f"{name}_{suffix}"


def jsonable(value: Any) -> Any:
    """Plain JSON values: NaN and infinities as ``None``, NumPy scalars and arrays as
    Python numbers and lists, tuples as lists (recursively)."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return [jsonable(v) for v in value.tolist()]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Path):
        return value.as_posix()
    return value


def write_json(path: Path, document: Mapping[str, Any]) -> Path:
    """Write ``jsonable(document)`` as strict JSON (indented, UTF-8).

    Inside a :class:`~cyclomesh.output.folder.ResultFolder`, its ``summary.json`` is
    kept and written last, as the completion marker."""
    folder = active_folder()
    if folder is not None and Path(path) == folder.marker:
        folder.defer_marker(jsonable(document))
        return path
    text = json.dumps(jsonable(document), indent=2, allow_nan=False, ensure_ascii=False)
    return write_text(path, text + "\n")


COMPRESSION = {"zlib": True, "complevel": 1, "shuffle": True}
"""Lossless NetCDF-4 compression of large variables: a run of the Table 1 pair at 3600
crank angles shrinks from 13.0 to 2.9 MB a case, for 0.14 s more writing (level 4 gains
another 2 % for 0.05 s more)."""
COMPRESS_FROM = 4096
"""Variables with at least this many values are compressed (smaller ones do not pay)."""


def write_netcdf(ds: xr.Dataset, path: Path) -> Path:
    """Write ``ds`` to NetCDF-4 (booleans as 0/1 bytes); ``xarray.open_dataset`` reads
    it back equal, attributes and units included. Variables of :data:`COMPRESS_FROM`
    values or more are compressed losslessly (:data:`COMPRESSION`).

    Datasets of numbers and text with dimension coordinates only (all of cyclomesh's)
    are written with netCDF4 directly: ``Dataset.to_netcdf`` imports dask and
    ``distributed`` when they are installed, which costs more than the writing. Text
    (the solver's message of a tolerance ring, the reason of a design candidate) is
    written as ``Dataset.to_netcdf`` wrote such a Dataset before: variable-length
    strings, uncompressed, without a fill value, and the coordinates uncompressed.
    Anything else goes through ``Dataset.to_netcdf``.
    """
    plain = all(name in ds.dims for name in ds.coords) and all(
        var.dtype.kind in "biufU" for var in ds.variables.values()
    )
    if not plain:
        out = ds.copy()
        for name in list(out.data_vars):
            if out[name].dtype == np.bool_:
                out[name] = out[name].astype(np.int8)
        encoding = {
            name: dict(COMPRESSION)
            for name, var in out.data_vars.items()
            if var.dtype.kind in "biuf" and var.size >= COMPRESS_FROM
        }
        with atomic_write(path) as tmp:
            out.to_netcdf(tmp, encoding=encoding)
        return path
    import netCDF4

    text = any(var.dtype.kind == "U" for var in ds.variables.values())
    with atomic_write(path) as tmp, netCDF4.Dataset(tmp, "w", format="NETCDF4") as nc:
        for dim, size in ds.sizes.items():
            nc.createDimension(str(dim), size)
        for name, var in ds.variables.items():
            values = np.asarray(var.values)
            if values.dtype == np.bool_:
                values = values.astype(np.int8)
            dims = tuple(str(d) for d in var.dims)
            if values.dtype.kind == "U":  # variable-length strings, as xarray writes them
                out = nc.createVariable(str(name), str, dims)
                out[...] = values.astype(object)
                out.setncatts({str(k): _nc_attr(v) for k, v in var.attrs.items()})
                continue
            # a fill value (NaN for floats, netCDF's default otherwise): storage never
            # written reads as missing, not as whatever bytes were there
            fill = np.nan if values.dtype.kind == "f" else None
            out = nc.createVariable(
                str(name),
                values.dtype,
                dims,
                fill_value=fill,
                **(
                    COMPRESSION
                    if values.size >= COMPRESS_FROM and not (text and name in ds.coords)
                    else {}
                ),
            )
            if values.ndim:
                out[...] = values
            else:
                out.assignValue(values)
            out.setncatts({str(k): _nc_attr(v) for k, v in var.attrs.items()})
        nc.setncatts({str(k): _nc_attr(v) for k, v in ds.attrs.items()})
    return path


def write_case_netcdf(
    study: Any,
    out: Path,
    datasets: Mapping[str, xr.Dataset],
    file: str,
    record: Callable[[Any], Mapping[str, Any]],
    extra: Callable[[Any, Path], list[Path]] | None = None,
) -> tuple[list[Path], list[dict[str, Any]]]:
    """Write ``<case>/<file>`` (NetCDF) of every case of ``study`` into ``out``.

    Returns the files written and one ``summary.json`` record a case: ``name``,
    ``results`` (the file, relative to ``out``), then ``record(case)``;
    ``extra(case, folder)`` writes more files of a case (their paths).
    """
    from cyclomesh.studyfile.schema import folder_name

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    records = []
    for case in study.cases:
        folder = out / folder_name(case.name)
        folder.mkdir(parents=True, exist_ok=True)
        written.append(write_netcdf(datasets[case.name], folder / file))
        if extra is not None:
            written += extra(case, folder)
        records.append(
            {"name": case.name, "results": f"{folder_name(case.name)}/{file}", **record(case)}
        )
    return written, records


def _nc_attr(value: Any) -> Any:
    if isinstance(value, bool | np.bool_):
        return np.int8(value)
    return value


def arrow_array(values: np.ndarray, mask: np.ndarray | None = None) -> pa.Array:
    """``pyarrow.array(values, mask=mask)`` of a 1-d NumPy array of numbers or booleans,
    built from its buffers: ``pyarrow.array`` imports pandas (to check for pandas
    objects), 0.3 s of a 36-step run."""
    import pyarrow as pa

    values = np.ascontiguousarray(values)
    validity, nulls = None, 0
    if mask is not None:
        validity = pa.py_buffer(np.packbits(~mask, bitorder="little"))
        nulls = int(np.count_nonzero(mask))
    if values.dtype == np.bool_:
        kind, data = pa.bool_(), pa.py_buffer(np.packbits(values, bitorder="little"))
    else:
        kind, data = pa.from_numpy_dtype(values.dtype), pa.py_buffer(values)
    return pa.Array.from_buffers(kind, len(values), [validity, data], null_count=nulls)


class Column(NamedTuple):
    """One column of a table: its name, values (1-d), missing values (``mask``, True
    where missing, or None), unit and long name."""

    name: str
    values: np.ndarray
    mask: np.ndarray | None
    units: str
    long_name: str


def _column(values: np.ndarray, name: str, units: str, long_name: str) -> Column:
    values = np.ascontiguousarray(values)
    mask = None
    if values.dtype.kind == "f":
        bad = ~np.isfinite(values)
        mask = bad if bad.any() else None
    return Column(name, values, mask, units or "1", long_name or "")


def _table(columns: list[Column]) -> pa.Table:
    """The columns as an Arrow table, each field's ``units`` and ``long_name`` in its
    metadata."""
    import pyarrow as pa

    arrays = [arrow_array(c.values, c.mask) for c in columns]
    fields = [
        pa.field(c.name, a.type, metadata={"units": c.units, "long_name": c.long_name})
        for c, a in zip(columns, arrays, strict=True)
    ]
    return pa.Table.from_arrays(arrays, schema=pa.schema(fields))


def long_table(ds: xr.Dataset | Frame) -> pa.Table:
    """The Dataset's variables in long format: one row per element of the full grid.

    The grid is the Dataset's dimensions in order (e.g. crank angle, then pin);
    coordinates come first (``crank_angle_deg``, ``pin``), then every non-scalar
    variable, broadcast over the dimensions it lacks (per-angle values repeat on every
    pin's row). Non-finite values are missing (null).
    """
    return _table(_long_columns(ds))


def _long_columns(ds: xr.Dataset | Frame) -> list[Column]:
    dims = tuple(ds.sizes)
    shape = tuple(ds.sizes[d] for d in dims)
    columns = []
    for index, dim in enumerate(dims):
        coord = ds[dim]
        values = np.broadcast_to(
            coord.values.reshape([-1 if i == index else 1 for i in range(len(dims))]), shape
        )
        columns.append(
            _column(
                values.ravel(),
                csv_column(dim, coord.attrs.get("units")),
                coord.attrs.get("units", "1"),
                coord.attrs.get("long_name", dim),
            )
        )
    for name, var in ds.data_vars.items():
        if var.ndim == 0:
            continue
        own = [d for d in dims if d in var.dims]
        values = var.transpose(*own).values
        values = np.broadcast_to(
            values.reshape([ds.sizes[d] if d in var.dims else 1 for d in dims]), shape
        )
        units = var.attrs.get("units", "1")
        columns.append(
            _column(
                values.ravel(), csv_column(str(name), units), units, var.attrs.get("long_name", "")
            )
        )
    return columns


PARQUET_OPTIONS = {
    "version": "2.6",
    "use_dictionary": True,
    "compression": "zstd",
    "write_statistics": True,
    "use_deprecated_int96_timestamps": False,
    "writer_engine_version": "V2",
    "data_page_version": "1.0",
    "use_compliant_nested_type": True,
    "store_schema": True,
}
"""The options of every Parquet file: ``pyarrow.parquet.write_table(table, path,
compression="zstd")`` with pyarrow's defaults spelled out, as its ``ParquetWriter``
passes them on to the writer of ``pyarrow._parquet``."""


def write_parquet_table(table: pa.Table, path: Path) -> None:
    """Write ``table`` to the Parquet file ``path``, byte for byte as
    ``pyarrow.parquet.write_table(table, path, compression="zstd")`` does
    (``tests/output/test_outputs.py``), through the writer of ``pyarrow._parquet``:
    ``pyarrow.parquet`` imports pyarrow's file systems (S3, GCS, Azure, HDFS) and
    ``ssl`` to resolve the path, 0.04-0.05 s of a 36-step run. Should a pyarrow version
    not take these options, ``pyarrow.parquet`` writes the file."""
    try:
        from pyarrow import _parquet

        writer = _parquet.ParquetWriter(str(path), table.schema, **PARQUET_OPTIONS)
    except (ImportError, AttributeError, TypeError):  # another pyarrow: its public writer
        import pyarrow.parquet as pq

        pq.write_table(table, path, compression="zstd")
        return
    try:
        writer.write_table(table, row_group_size=None)
    finally:
        writer.close()


def write_parquet(ds: xr.Dataset, path: Path) -> Path:
    """Write :func:`long_table` of ``ds`` to Parquet (zstd), the Dataset's attributes as
    the file's key-value metadata (``cyclomesh.attrs``, JSON)."""
    table = long_table(ds)
    attrs = json.dumps(jsonable(dict(ds.attrs)), ensure_ascii=False)
    table = table.replace_schema_metadata({"cyclomesh.attrs": attrs})
    with atomic_write(path) as tmp:
        write_parquet_table(table, tmp)
    return path


def _write_csv(table: pa.Table, path: Path) -> Path:
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.csv as pacsv

    arrays = [
        pc.cast(col, pa.int8()) if pa.types.is_boolean(col.type) else col for col in table.columns
    ]
    table = pa.Table.from_arrays(arrays, names=table.column_names)
    options = pacsv.WriteOptions(quoting_style="none", quoting_header="none")
    with atomic_write(path) as tmp:
        pacsv.write_csv(table, tmp, options)
    return path


def write_pin_csv(ds: xr.Dataset, path: Path) -> Path:
    """Write :func:`long_table` of ``ds`` as CSV (shortest round-trip decimals)."""
    return _write_csv(long_table(ds), path)


_ANGLE_PEAKS = (
    ("pin_load", "max_pin_load", "largest pin load Fc over the pins"),
    ("groove_load", "max_groove_load", "largest groove load Fp over the pins"),
    ("contact_stress", "max_contact_stress", "peak tooth contact stress over the pins"),
    ("groove_stress", "max_groove_stress", "peak groove contact stress over the pins"),
)


def angle_table(ds: xr.Dataset | Frame) -> pa.Table:
    """One row per crank angle (per torque and crank angle for a list of torques): the
    per-angle variables (TE, ratio, contacts, rotations, play, mesh force), the peak loads
    and stresses over the pins (and discs), and, for a stack of discs, one column per disc
    of each per-disc variable (``mesh_force_n_disc2``)."""
    return _table(_angle_columns(ds))


def _angle_columns(ds: xr.Dataset | Frame) -> list[Column]:
    if "ring" in ds.dims:
        raise ValueError("angle_table: select one ring first")
    rows = tuple(d for d in ("torque", "crank_angle") if d in ds.dims)
    shape = tuple(ds.sizes[d] for d in rows)

    def grid(values: np.ndarray, dims: tuple[str, ...]) -> np.ndarray:
        values = values.reshape([ds.sizes[d] if d in dims else 1 for d in rows])
        return np.broadcast_to(values, shape).ravel()

    columns = []
    for dim in rows:
        coord = ds[dim]
        units = coord.attrs.get("units", "1")
        columns.append(
            _column(
                grid(coord.values, (dim,)),
                csv_column(dim, units),
                units,
                coord.attrs.get("long_name", "crank angle φin" if dim == "crank_angle" else dim),
            )
        )
    for name, var in ds.data_vars.items():
        own = tuple(d for d in rows if d in var.dims)
        units = var.attrs.get("units", "1")
        long_name = var.attrs.get("long_name", "")
        if "crank_angle" not in var.dims or not set(var.dims) <= {*rows, "disc"}:
            continue
        if "disc" not in var.dims:
            values = grid(var.transpose(*own).values, own)
            columns.append(_column(values, csv_column(str(name), units), units, long_name))
            continue
        for disc in var["disc"].values:
            values = grid(var.sel(disc=disc).transpose(*own).values, own)
            column = f"{csv_column(str(name), units)}_disc{disc}"
            columns.append(_column(values, column, units, f"{long_name}, disc {disc}"))
    for source, name, long_name in _ANGLE_PEAKS:
        if source in ds:
            var = ds[source]
            over = tuple(d for d in ("disc", "pin") if d in var.dims)
            peak = nan_reduce(var, "max", over, rows)
            units = var.attrs.get("units", "1")
            columns.append(_column(grid(peak, rows), csv_column(name, units), units, long_name))
    return columns


def write_angle_csv(ds: xr.Dataset | Frame, path: Path) -> Path:
    """Write :func:`angle_table` of ``ds`` as CSV, as :func:`write_pin_csv` writes a
    table (byte for byte; :func:`csv_text`), without pyarrow (a few rows: Python's
    formatting is fast enough, and a run that writes no Parquet never imports pyarrow's
    CSV and compute modules)."""
    return write_text(path, csv_text(_angle_columns(ds)))


def arrow_float(value: float) -> str:
    """A float as Arrow's CSV writer formats it: the shortest decimal that reads back
    to the same double (Python's ``repr``), written as Arrow's ``ToShortest`` writes it:
    plain decimals for decimal exponents from -6 to 9 (``0.00001``, ``123456789``, no
    ``.0``), else ``1.5e-7`` / ``1e+16`` (no padded exponent); ``nan``, ``inf``."""
    if value != value:
        return "nan"
    if value in (math.inf, -math.inf):
        return "inf" if value > 0 else "-inf"
    text = repr(float(value))
    sign = "-" if text.startswith("-") else ""
    mantissa, _, exponent = text.lstrip("-").partition("e")
    whole, _, fraction = mantissa.partition(".")
    raw = whole + fraction
    digits = raw.lstrip("0")
    point = len(whole) - (len(raw) - len(digits)) + (int(exponent) if exponent else 0)
    digits = digits.rstrip("0")
    if not digits:
        return sign + "0"
    scientific = point - 1
    if -6 <= scientific < 10:
        if point <= 0:
            return f"{sign}0.{'0' * -point}{digits}"
        if point < len(digits):
            return f"{sign}{digits[:point]}.{digits[point:]}"
        return sign + digits + "0" * (point - len(digits))
    head = digits[0] + ("." + digits[1:] if len(digits) > 1 else "")
    return f"{sign}{head}e{'+' if scientific >= 0 else '-'}{abs(scientific)}"


def arrow_floats(values: Sequence[float]) -> list[str]:
    """:func:`arrow_float` of every value, fast: where Python's ``repr`` is a plain
    decimal (no exponent, magnitude below 1e10) Arrow writes the same digits, without a
    trailing ``.0``; only the rest goes through :func:`arrow_float` (a 3600-step run's
    ``angles.csv``: 43,200 numbers in 0.03 s instead of 0.2 s)."""
    out = []
    for value in values:
        text = repr(value)
        if "e" in text or "n" in text or not -1e10 < value < 1e10:  # exponent, inf, nan
            out.append(arrow_float(value))
        elif text.endswith(".0"):
            out.append(text[:-2])
        else:
            out.append(text)
    return out


def csv_text(columns: Sequence[Column]) -> str:
    """The CSV text of ``columns`` as :func:`write_pin_csv` writes a table with pyarrow:
    a header of the names, no quotes, booleans 0/1, missing values empty,
    floats by :func:`arrow_float`."""

    def cells(column: Column) -> list[str]:
        values = column.values
        if values.dtype.kind == "f":
            out = arrow_floats(values.tolist())
        else:
            out = [str(int(v)) for v in values.tolist()]
        if column.mask is not None:
            out = ["" if bad else cell for cell, bad in zip(out, column.mask.tolist(), strict=True)]
        return out

    rows = zip(*(cells(c) for c in columns), strict=True)
    lines = [",".join(c.name for c in columns), *(",".join(row) for row in rows)]
    return "\n".join(lines) + "\n"


# --- TOML (the worst ring of a tolerance study as a study file) -------------------------


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | np.integer):
        return str(int(value))
    if isinstance(value, float | np.floating):
        v = float(value)
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(value, str):
        # a valid TOML basic string: JSON escapes quotes, backslashes and U+0000-U+001F;
        # TOML also forbids a raw U+007F (DEL)
        return json.dumps(value, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(value, Mapping):  # an inline table (inside a list)
        items = ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items())
        return "{ " + items + " }" if items else "{}"
    if isinstance(value, Sequence | np.ndarray):
        return "[" + ", ".join(_toml_value(v) for v in list(value)) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def _toml_key(key: Any) -> str:
    """A bare key if it can be one, else a quoted key."""
    key = str(key)
    return key if re.fullmatch(r"[A-Za-z0-9_-]+", key) else _toml_value(key)


def toml_dumps(data: Mapping[str, Any], _prefix: str = "") -> str:
    """A TOML document for nested dicts of numbers, strings, booleans and lists.

    Floats are written with ``repr`` (the shortest decimal that reads back to the same
    double), so numbers read back bit for bit.
    """
    lines = []
    tables = []
    for key, value in data.items():
        if isinstance(value, Mapping):
            tables.append((key, value))
        else:
            lines.append(f"{_toml_key(key)} = {_toml_value(value)}")
    out = "\n".join(lines)
    for key, value in tables:
        name = f"{_prefix}.{_toml_key(key)}" if _prefix else _toml_key(key)
        body = toml_dumps(value, name)
        out += ("\n\n" if out else "") + f"[{name}]" + ("\n" + body if body else "")
    return out
