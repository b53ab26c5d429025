"""Figure formats and figure sets, without importing the renderer (``--figures`` is
parsed by commands that draw nothing)."""

from __future__ import annotations

FORMATS = ("png", "svg", "pdf")
"""File formats a figure can be saved in."""
SETS = ("overview", "all")
"""Figure sets of ``--figures``: ``overview`` (the default) draws the one overview
figure of a run study (:mod:`cyclomesh.figures.overview`); ``all`` every figure. Other
kinds of study draw all their figures either way."""
