"""Figure formats and figure sets, without importing the renderer (``--figures`` is
parsed by commands that draw nothing)."""

from __future__ import annotations

FORMATS = ("png", "svg", "pdf")
"""File formats a figure can be saved in."""
