"""Tabulated profile deviation read from the CSV file named by ``[modification] profile_file``.

Columns (see ``docs/modification.md``):

* ``profile_angle_deg`` — generating angle φ1 within the tooth space [deg], 0 at the
  tooth-space bottom, −180/+180 at the tips; −180 … 0 (same on both flanks) or
  −180 … 180 (both flanks);
* ``normal_deviation_um`` — material removed along the profile normal [µm]
  (positive = relief);
* ``tooth`` (optional) — tooth space 1 … n2, every one with its own table (the same
  number of points each).

Lines starting with ``#`` are comments. Errors name the file and the line.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cyclomesh.core.deviation import ProfileDeviation
from cyclomesh.exceptions import DesignError, StudyError
from cyclomesh.studyfile.measurements import integer_cell, number_cell, read_csv_table

__all__ = ["PROFILE_COLUMNS", "read_profile_csv"]

PROFILE_COLUMNS = ("profile_angle_deg", "normal_deviation_um")
"""Required columns of a profile-deviation CSV (``tooth`` is optional)."""


def read_profile_csv(
    path: Path, teeth: int, key: str = "modification.profile_file"
) -> ProfileDeviation:
    """Read a profile deviation table and convert it to SI.

    Parameters
    ----------
    path : Path
        The CSV file.
    teeth : int
        Number of disc teeth n2 (a ``tooth`` column must give each of 1 … n2).
    key : str
        Dotted study key named in error messages.

    Returns
    -------
    ProfileDeviation
        Angles [rad], deviations [m], with the file's line numbers as ``rows``.

    Raises
    ------
    StudyError
        Missing file or columns, a value that is not a finite number, a bad tooth number,
        or a table the core refuses (not monotone, too coarse, not spanning the flank),
        naming the line.
    """
    where, header, table = read_csv_table(path, key)
    allowed = (*PROFILE_COLUMNS, "tooth")
    missing = [name for name in PROFILE_COLUMNS if name not in header]
    unknown = [name for name in header if name not in allowed]
    if missing or unknown:
        what = f"missing column {missing[0]!r}" if missing else f"unknown column {unknown[0]!r}"
        raise StudyError(f"{where}: {what} (columns: {', '.join(allowed)}; tooth optional)")
    per_tooth = "tooth" in header
    tables: dict[int, list[tuple[float, float, int]]] = {}
    for line, row in table:
        tooth = integer_cell(where, line, "tooth", row["tooth"], teeth) if per_tooth else 1
        values = [number_cell(where, line, name, row[name]) for name in PROFILE_COLUMNS]
        tables.setdefault(tooth, []).append((values[0], values[1], line))
    if not tables:
        raise StudyError(f"{where}: no data rows")
    if per_tooth and len(tables) != teeth:
        absent = [str(t) for t in range(1, teeth + 1) if t not in tables]
        raise StudyError(
            f"{where}: every tooth 1..{teeth} needs a table; missing tooth {', '.join(absent[:5])}"
        )
    order = sorted(tables)
    counts = {len(tables[t]) for t in order}
    if len(counts) > 1:
        raise StudyError(
            f"{where}: every tooth needs the same number of points "
            f"(tooth {order[0]} has {len(tables[order[0]])})"
        )
    data = np.array([tables[t] for t in order])  # (teeth, m, 3)
    squeeze = not per_tooth
    angle = np.deg2rad(data[..., 0])
    deviation = data[..., 1] * 1e-6
    rows = data[..., 2].astype(int)
    try:
        return ProfileDeviation(
            angle[0] if squeeze else angle,
            deviation[0] if squeeze else deviation,
            rows[0] if squeeze else rows,
        )
    except DesignError as exc:
        raise StudyError(f"{where}: {str(exc).replace('profile deviation: ', '')}") from None
