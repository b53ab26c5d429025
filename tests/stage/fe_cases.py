"""What the compliant-disc (FE) test modules of tests/stage share: the example stage, the
coarse FE meshes their free discs are built on, and the guard that skips a module where
the fe extra cannot be used."""

from __future__ import annotations

from pathlib import Path

import pytest

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rv_stage.toml"
COARSE = dict(points=7, far_size=4e-3, flank_size=1.5e-3, elements_per_half_width=2.0)
"""Coarse meshes of :func:`cyclomesh.fe.influence.free_influence` (fast, the same model)."""


def require_fe() -> None:
    """Skip the importing test module where the fe extra is not usable (gmsh's wheel also
    needs X11/OpenGL client libraries, see .ci/run)."""
    try:
        import gmsh  # noqa: F401
        import skfem  # noqa: F401
    except (ImportError, OSError) as exc:  # pragma: no cover
        pytest.skip(f"fe extra not usable here: {exc}", allow_module_level=True)
