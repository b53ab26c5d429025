"""Measured pin-ring errors read from a CSV file named in a study file.

The file has one row per pin and exactly the columns ``pin`` (1 … n1),
``radial_um`` (εa,i [µm], positive outwards), ``angular_urad`` (εψ,i [µrad],
positive counter-clockwise) and ``pin_radius_um`` (ερ,i [µm]), the per-pin errors of
Eq. 5 in [1]. Lines starting with ``#`` are comments.

References
----------
[1] X. Li, L. Tang, H. He, L. Sun, Machines 10 (2022) 672, doi:10.3390/machines10080672.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from cyclomesh.exceptions import StudyError

__all__ = [
    "PIN_ERROR_COLUMNS",
    "read_pin_errors_csv",
    "read_pin_error_rows",
    "name_measured_row",
    "read_csv_table",
    "number_cell",
    "integer_cell",
]

PIN_ERROR_COLUMNS = ("radial_um", "angular_urad", "pin_radius_um")
"""Columns of a measured-pins CSV besides ``pin``, in study units (µm, µrad, µm)."""


def read_pin_errors_csv(path: Path, pins: int, key: str = "errors.file") -> dict[str, NDArray]:
    """Read per-pin errors from a CSV file.

    Parameters
    ----------
    path : Path
        The CSV file.
    pins : int
        Number of pins n1 the file must describe, one row each.
    key : str
        Dotted study key named in error messages.

    Returns
    -------
    dict
        ``{"radial_um": [µm], "angular_urad": [µrad], "pin_radius_um": [µm]}``, arrays
        of shape ``(pins,)`` ordered by pin number.

    Raises
    ------
    StudyError
        Missing or unreadable file, missing or unknown columns, a value that is not a
        finite number, or pins that are not exactly 1 … n1 once each.
    """
    return read_pin_error_rows(path, pins, key)[0]


def read_pin_error_rows(
    path: Path, pins: int, key: str = "errors.file"
) -> tuple[dict[str, NDArray], NDArray]:
    """:func:`read_pin_errors_csv` and the line number of each pin's row, shape ``(pins,)``."""
    where, header, table = read_csv_table(path, key)
    expected = ("pin", *PIN_ERROR_COLUMNS)
    missing = [name for name in expected if name not in header]
    if missing:
        raise StudyError(
            f"{where}: missing column {', '.join(repr(m) for m in missing)} "
            f"(columns must be {', '.join(expected)})"
        )
    unknown = [name for name in header if name not in expected]
    if unknown:
        raise StudyError(
            f"{where}: unknown column {', '.join(repr(u) for u in unknown)} "
            f"(columns must be {', '.join(expected)})"
        )
    rows: dict[int, dict[str, float]] = {}
    lines: dict[int, int] = {}
    for line, row in table:
        pin = integer_cell(where, line, "pin", row["pin"], pins)
        if pin in rows:
            raise StudyError(f"{where} line {line}: pin {pin} appears twice")
        lines[pin] = line
        rows[pin] = {name: number_cell(where, line, name, row[name]) for name in PIN_ERROR_COLUMNS}
    if len(rows) != pins:
        absent = [str(p) for p in range(1, pins + 1) if p not in rows]
        raise StudyError(
            f"{where}: expected {pins} rows (one per pin), got {len(rows)}; "
            f"missing pin {', '.join(absent[:5])}{' …' if len(absent) > 5 else ''}"
        )
    values = {
        name: np.array([rows[p][name] for p in range(1, pins + 1)]) for name in PIN_ERROR_COLUMNS
    }
    return values, np.array([lines[p] for p in range(1, pins + 1)])


def name_measured_row(exc: Exception, path: Path, pins: int, key: str = "errors.file") -> str:
    """The message of ``exc`` (a bound of :func:`cyclomesh.core.pair.check_physical` on
    one pin's error) naming the row of the measured-pins file that holds the value, when
    that row gives the pin an error in that column; else ``str(exc)`` unchanged.

    ``errors.file: measured_pins.csv line 9 (pin 3): pin_radius_um = -3500: ερ = …``
    """
    column, pin = getattr(exc, "column", None), getattr(exc, "pin", None)
    if column not in PIN_ERROR_COLUMNS or pin is None or not 1 <= pin <= pins:
        return str(exc)
    values, lines = read_pin_error_rows(path, pins, key)
    value = float(values[column][pin - 1])
    if value == 0.0:  # the value comes from the study file's lists or random draws
        return str(exc)
    return (
        f"{key}: {path.name} line {int(lines[pin - 1])} (pin {pin}): {column} = {value:.6g}"
        f": {getattr(exc, 'why', exc)}"
    )


def read_csv_table(
    path: Path, key: str
) -> tuple[str, list[str], Iterator[tuple[int, dict[str, str]]]]:
    """Rows of a study's CSV file with their line numbers (comments and blank lines skipped).

    Returns ``(where, header, rows)``: ``where`` (``"<key>: <file name>"``) starts every
    error message, ``header`` the stripped column names, ``rows`` an iterator of (line
    number, row), read after the caller has checked the header.

    Raises
    ------
    StudyError
        Missing, unreadable or empty file; while iterating, a row with the wrong number
        of values.
    """
    where = f"{key}: {path.name}"
    from cyclomesh.studyfile.limits import MAX_CSV_FILE_BYTES, read_regular_file

    try:
        text = read_regular_file(path, "file", MAX_CSV_FILE_BYTES).decode("utf-8-sig")
    except StudyError as exc:
        raise StudyError(f"{key}: {exc}") from None
    except UnicodeDecodeError as exc:
        raise StudyError(f"{key}: cannot read {path}: {exc}") from None
    numbered = [
        (number, line)
        for number, line in enumerate(text.splitlines(), start=1)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not numbered:
        raise StudyError(f"{where}: the file is empty")
    reader = csv.DictReader(line for _, line in numbered)
    header = [name.strip() for name in reader.fieldnames or []]
    reader.fieldnames = header

    def rows() -> Iterator[tuple[int, dict[str, str]]]:
        for (line, _), row in zip(numbered[1:], reader, strict=False):
            if None in row or any(row[name] is None for name in header):
                raise StudyError(f"{where} line {line}: expected {len(header)} values")
            yield line, row

    return where, header, rows()


_DECIMAL = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", re.ASCII)
"""A plain decimal number (optional exponent): no digit separators ``1_0``, no ``inf``,
``nan`` or hexadecimal, which Python's ``float``/``int`` would also read."""
_INTEGER = re.compile(r"[+-]?\d+", re.ASCII)


def number_cell(where: str, line: int, name: str, cell: str) -> float:
    """The finite plain decimal number in a CSV cell, else a one-line StudyError naming
    the line."""
    cell = cell.strip()
    value = float(cell) if _DECIMAL.fullmatch(cell) else math.nan
    if not math.isfinite(value):
        raise StudyError(
            f"{where} line {line}: {name} {cell!r} is not a finite number (write plain "
            "decimals such as -1.5 or 2e-3)"
        )
    return value


def integer_cell(where: str, line: int, name: str, cell: str, stop: int) -> int:
    """The whole number 1 … ``stop`` (plain digits) in a CSV cell, else a one-line
    StudyError."""
    cell = cell.strip()
    if not _INTEGER.fullmatch(cell):
        raise StudyError(f"{where} line {line}: {name} {cell!r} is not an integer")
    value = int(cell)
    if not 1 <= value <= stop:
        raise StudyError(f"{where} line {line}: {name} {value} is not in 1..{stop}")
    return value
