"""Figures: one module of plot functions per kind of study, one renderer.

- :mod:`cyclomesh.figures.run`: figures of a run study (profile, loads, stresses, TE,
  gear ratio, contacts, backlash), after the figures of Li et al. (2022);
- :mod:`cyclomesh.figures.tolerance`: histograms, distribution functions and
  exceedance curves of a tolerance study, and the allocation curve;
- :mod:`cyclomesh.figures.designmap`: contour maps of a design map (``cyclomesh design``);
- :mod:`cyclomesh.figures.render`: :class:`~cyclomesh.figures.render.FigureJob`,
  :func:`~cyclomesh.figures.render.render_figures` (saves PNG/SVG/PDF, a process pool
  when it pays), :func:`~cyclomesh.figures.render.decimate`.

Plot functions take results and return a matplotlib Figure; they write no file. The
run figures are also reachable here (``cyclomesh.figures.plot_loads``); matplotlib is
imported on first use.
"""

from __future__ import annotations

from typing import Any

_RUN = (
    "plot_profile",
    "plot_pin_errors",
    "plot_loads",
    "plot_profile_stress",
    "plot_stress_maps",
    "plot_transmission_error",
    "plot_gear_ratio",
    "plot_contacts",
    "plot_backlash",
)

__all__ = list(_RUN)


def __getattr__(name: str) -> Any:
    if name in _RUN:
        from cyclomesh.figures import run

        return getattr(run, name)
    raise AttributeError(f"module 'cyclomesh.figures' has no attribute {name!r}")
