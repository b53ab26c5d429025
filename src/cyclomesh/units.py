"""Unit constants, each defined once and named by direction: ``x_rad / RAD_PER_ARCSEC`` is
``x`` in arcseconds, ``x_arcsec * RAD_PER_ARCSEC`` is ``x`` in radians.

Inside the package everything is SI; these convert at the edges (labelled results, study
files, figures).
"""

from __future__ import annotations

import math

__all__ = [
    "M_PER_MM",
    "M_PER_UM",
    "RAD_PER_URAD",
    "PA_PER_GPA",
    "RAD_PER_ARCSEC",
    "RAD_PER_ARCMIN",
    "ARCSEC_PER_RAD",
    "DEG_PER_RAD",
    "MPA_PER_PA",
    "MM_PER_M",
    "UM_PER_M",
    "IN_PER_M",
    "UIN_PER_M",
    "LBF_PER_IN_PER_N_PER_M",
]

RAD_PER_ARCSEC = math.pi / (180.0 * 3600.0)
"""One arcsecond in radians."""

RAD_PER_ARCMIN = math.pi / (180.0 * 60.0)
"""One arcminute in radians (= 60 · RAD_PER_ARCSEC to the last bit)."""

ARCSEC_PER_RAD = 1.0 / RAD_PER_ARCSEC
"""One radian in arcseconds (= 180/π · 3600 to the last bit)."""

DEG_PER_RAD = 180.0 / math.pi
"""One radian in degrees (the value of ``180.0 / np.pi``, bit for bit)."""

MPA_PER_PA = 1e-6
"""One pascal in megapascals."""

MM_PER_M = 1e3
"""One metre in millimetres."""

UM_PER_M = 1e6
"""One metre in micrometres."""

M_PER_MM = 1e-3
"""One millimetre in metres (study-file keys ``_mm``)."""

M_PER_UM = 1e-6
"""One micrometre in metres (study-file keys ``_um``)."""

RAD_PER_URAD = 1e-6
"""One microradian in radians (study-file keys ``_urad``)."""

PA_PER_GPA = 1e9
"""One gigapascal in pascals (study-file keys ``_gpa``)."""

IN_PER_M = 1.0 / 0.0254
"""One metre in inches (the Benedict–Kelley coefficient is fitted in US units)."""

UIN_PER_M = 1e6 / 0.0254
"""One metre in microinches (surface roughness of the Benedict–Kelley coefficient)."""

LBF_PER_IN_PER_N_PER_M = 0.0254 / 4.4482216152605
"""One newton per metre in pound-force per inch (a load per face width)."""
