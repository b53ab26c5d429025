"""Upper bounds on what a study may ask for, and on the files it reads.

The bounds keep a study file from asking for more than a machine can give (memory or
hours) by a slip of a key (``crank_step_deg = 1e-5``, ``rings = 10**15``), and every
bound is named in its message. They are checked before anything is allocated: the
validators count, they never build the arrays they count.

Two kinds of limit:

- per-key bounds in the schema (:mod:`cyclomesh.studyfile.schema`): pins, discs, crank
  angles per case, torque points, design-space points, FE mesh sizes;
- the **work** of a whole study (:func:`check_work`): pin-steps (rings × crank angles ×
  pins × discs × torques × candidates) solved, and pin-steps held in memory, against
  :data:`MAX_SOLVED_PIN_STEPS` and :data:`MAX_STORED_PIN_STEPS`. ``--no-work-limit``
  lifts this one. Each kind of study estimates its work in the registry
  (:func:`cyclomesh.studyfile.kinds.check_study_work`).
"""

from __future__ import annotations

import math
import os
import stat
from pathlib import Path

from cyclomesh.exceptions import StudyError

__all__ = [
    "MAX_PINS",
    "MAX_DISCS",
    "MAX_CRANK_ANGLES",
    "MAX_ABS_CRANK_DEG",
    "MIN_CRANK_STEP_DEG",
    "MAX_STIFFNESS_POINTS",
    "MAX_CANDIDATES",
    "MAX_RINGS",
    "MAX_SOLVED_PIN_STEPS",
    "MAX_STORED_PIN_STEPS",
    "MAX_STUDY_FILE_BYTES",
    "MAX_CSV_FILE_BYTES",
    "count_crank_angles",
    "check_work",
    "read_regular_file",
]

MAX_PINS = 400
"""Most ring pins n1 (cycloid drives have 10 to about 100)."""

MAX_DISCS = 8
"""Most discs on one pin ring (RV reducers have 2, some 3)."""

MAX_CRANK_ANGLES = 100_000
"""Most crank angles of one case or ring (0.0036° over a revolution)."""

MAX_ABS_CRANK_DEG = 36_000.0
"""Largest |crank angle| accepted [deg] (100 revolutions)."""

MIN_CRANK_STEP_DEG = 1e-4
"""Smallest crank angle step [deg]."""

MAX_STIFFNESS_POINTS = 1001
"""Most torques of a torsion curve."""

MAX_CANDIDATES = 100_000
"""Most candidates of a design map."""

MAX_RINGS = 10_000_000
"""Most rings of a tolerance study (or a robust design map)."""

MAX_SEED = 2**63 - 1
"""Largest random seed: it is stored as a signed 64-bit NetCDF attribute."""

MAX_SOLVED_PIN_STEPS = 2e10
"""Most pin-steps (one pin at one crank angle) a study solves: about an hour on a few
cores. ``--no-work-limit`` lifts it."""

MAX_STORED_PIN_STEPS = 2e7
"""Most pin-steps a study holds in memory with every variable (``run``,
``stiffness``): about 3 GB. ``--no-work-limit`` lifts it."""

MAX_STUDY_FILE_BYTES = 16 << 20
"""Largest study file read [bytes]."""

MAX_CSV_FILE_BYTES = 64 << 20
"""Largest CSV (measured pins, profile deviation) read [bytes]."""


def count_crank_angles(start_deg: float, stop_deg: float, step_deg: float) -> float:
    """How many crank angles ``start:stop:step`` has, counted without building them
    (a float, so that an absurd count does not overflow)."""
    if not all(math.isfinite(v) for v in (start_deg, stop_deg, step_deg)) or step_deg <= 0:
        return math.inf
    return max(math.ceil((stop_deg - start_deg) / step_deg - 1e-9), 0)


def check_work(
    what: str,
    solved: float,
    stored: float = 0.0,
    fix: str = "",
    allow: bool = False,
) -> None:
    """Refuse a study that asks for more than :data:`MAX_SOLVED_PIN_STEPS` pin-steps of
    work or :data:`MAX_STORED_PIN_STEPS` held in memory, unless ``allow``.

    Parameters
    ----------
    what : str
        The product that gives the work, e.g. ``"1000 rings x 360 crank angles x 40 pins"``.
    solved, stored : float
        Pin-steps solved and held [-].
    fix : str
        The keys to change, e.g. ``"tolerance.rings or --rings"``.
    allow : bool
        ``--no-work-limit``: no check.
    """
    if allow:
        return
    if solved > MAX_SOLVED_PIN_STEPS:
        raise StudyError(
            f"the study asks for {solved:.3g} pin-steps ({what}), above the limit of "
            f"{MAX_SOLVED_PIN_STEPS:.0e} (hours of computing): reduce {fix}, or pass "
            "--no-work-limit"
        )
    if stored > MAX_STORED_PIN_STEPS:
        raise StudyError(
            f"the study holds {stored:.3g} pin-steps in memory ({what}), above the limit of "
            f"{MAX_STORED_PIN_STEPS:.0e} (about 3 GB): reduce {fix}, or pass --no-work-limit"
        )


def read_regular_file(path: Path, what: str, max_bytes: int) -> bytes:
    """The bytes of ``path`` if it is a regular file of at most ``max_bytes``.

    A FIFO, a device (``/dev/zero``) or a folder is refused before it is opened for
    reading (opening a FIFO blocks; reading ``/dev/zero`` never ends).

    Raises
    ------
    StudyError
        Missing, not a regular file, too large, or unreadable; naming ``what`` and the path.
    """
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise StudyError(f"{what} not found: {path}") from None
    except OSError as exc:
        raise StudyError(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    if not stat.S_ISREG(info.st_mode):
        raise StudyError(f"{what} {path}: not a regular file")
    if info.st_size > max_bytes:
        raise StudyError(
            f"{what} {path}: {info.st_size} bytes, larger than the limit of {max_bytes} bytes"
        )
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as fh:
            if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):  # replaced meanwhile
                raise StudyError(f"{what} {path}: not a regular file")
            data = fh.read(max_bytes + 1)
    except OSError as exc:
        raise StudyError(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    if len(data) > max_bytes:
        raise StudyError(f"{what} {path}: larger than the limit of {max_bytes} bytes")
    return data
