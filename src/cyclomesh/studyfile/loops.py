"""The stage's CSV inputs: a measured torsional hysteresis loop (``[stiffness]
measured_file``) and a duty cycle (``[stage.duty_cycle] file``).

Columns exactly ``torque_nm`` (output torque [N·m]) and ``twist_arcmin`` (output twist
[arcmin], growing with the torque), one row per sample in the order measured: one or more
load cycles 0 → +T_r → 0 → −T_r → 0. Lines starting with ``#`` are comments. The loop is
read back by the catalogue definitions of :mod:`cyclomesh.results.datasheet`.

A duty cycle has the columns exactly ``torque_nm`` (output torque [N·m], negative:
reverse), ``output_speed_rpm`` (output speed [rpm]) and ``time_share`` (share of the time,
any positive weights), one row per step (:mod:`cyclomesh.stage.duty`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from cyclomesh.exceptions import StudyError
from cyclomesh.studyfile.measurements import number_cell, read_csv_table

__all__ = ["LOOP_COLUMNS", "DUTY_COLUMNS", "read_loop_csv", "read_duty_csv"]

LOOP_COLUMNS = ("torque_nm", "twist_arcmin")
DUTY_COLUMNS = ("torque_nm", "output_speed_rpm", "time_share")


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


def read_duty_csv(
    path: Path, key: str = "stage.duty_cycle.file"
) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
    """Torque [N·m], output speed [rpm] and time share of every step of a duty cycle.

    Raises
    ------
    StudyError
        Missing or unreadable file, wrong columns, a value that is not a finite number, or
        no step (the values themselves are checked by
        :class:`~cyclomesh.stage.duty.DutyCycle`).
    """
    where, header, table = read_csv_table(path, key)
    if sorted(header) != sorted(DUTY_COLUMNS):
        raise StudyError(
            f"{where}: columns must be exactly {', '.join(DUTY_COLUMNS)}, got {', '.join(header)}"
        )
    rows = [
        [number_cell(where, line, name, row[name]) for name in DUTY_COLUMNS] for line, row in table
    ]
    if not rows:
        raise StudyError(f"{where}: a duty cycle needs at least one step")
    torque, speed, share = (tuple(column) for column in zip(*rows, strict=True))
    return torque, speed, share
