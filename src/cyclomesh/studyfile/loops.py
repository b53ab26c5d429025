"""A measured torsional hysteresis loop read from the CSV file ``[stiffness] measured_file``.

Columns exactly ``torque_nm`` (output torque [N·m]) and ``twist_arcmin`` (output twist
[arcmin], growing with the torque), one row per sample in the order measured: one or more
load cycles 0 → +T_r → 0 → −T_r → 0. Lines starting with ``#`` are comments. The loop is
read back by the catalogue definitions of :mod:`cyclomesh.results.datasheet`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from cyclomesh.exceptions import StudyError
from cyclomesh.studyfile.measurements import number_cell, read_csv_table

__all__ = ["LOOP_COLUMNS", "read_loop_csv"]

LOOP_COLUMNS = ("torque_nm", "twist_arcmin")


def read_loop_csv(
    path: Path, key: str = "stiffness.measured_file"
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Torque [N·m] and twist [arcmin] of a measured loop, in the file's order.

    Raises
    ------
    StudyError
        Missing or unreadable file, wrong columns, a value that is not a finite number, or
        fewer than 8 samples.
    """
    where, header, table = read_csv_table(path, key)
    if sorted(header) != sorted(LOOP_COLUMNS):
        raise StudyError(
            f"{where}: columns must be exactly {', '.join(LOOP_COLUMNS)}, got {', '.join(header)}"
        )
    torque, twist = [], []
    for line, row in table:
        torque.append(number_cell(where, line, "torque_nm", row["torque_nm"]))
        twist.append(number_cell(where, line, "twist_arcmin", row["twist_arcmin"]))
    if len(torque) < 8:
        raise StudyError(f"{where}: a loop needs at least 8 samples, got {len(torque)}")
    return np.array(torque), np.array(twist)
