"""The explorer in the browser: ``cyclomesh explore STUDY.toml`` (docs/explore.md).

Change the modification, the torque, the contact law or the pin errors and see the loads,
the stresses and the TE move at once. :mod:`cyclomesh.explore.session` turns a state of
the page into a one-case study file and runs it through the pipeline of ``cyclomesh
run`` (no second model); :mod:`cyclomesh.explore.app` serves the page and its JSON API
on 127.0.0.1 (Starlette, uvicorn and Plotly's own JavaScript: the optional ``explore``
extra).
"""

from __future__ import annotations

from typing import Any

__all__ = ["Session", "create_app", "serve"]


def __getattr__(name: str) -> Any:
    if name == "Session":
        from cyclomesh.explore.session import Session

        return Session
    if name in ("create_app", "serve"):
        from cyclomesh.explore import app

        return getattr(app, name)
    raise AttributeError(name)
