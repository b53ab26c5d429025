"""Fixtures of the compliant-disc (FE) test modules of tests/stage (test_stage_fe,
test_kernel_compliant, test_own_starts, test_active_rows; :mod:`tests.stage.fe_cases` has
their guard and constants). test_stage_fe defines its own ``coarse``, which also returns
its cache folder."""

from __future__ import annotations

import pytest

from tests.stage.fe_cases import COARSE, EXAMPLE


@pytest.fixture(scope="module")
def example():
    """The example's first case (three crankshafts, crankshafts and carrier from geometry)."""
    from cyclomesh.studyfile.schema import load_study

    return load_study(EXAMPLE).cases[0].to_core()


@pytest.fixture(scope="module")
def coarse(example, tmp_path_factory):
    """The example's free disc on the coarse meshes, cached in a folder of its own."""
    from cyclomesh.fe.influence import free_influence  # (after require_fe: gmsh)

    folder = tmp_path_factory.mktemp("cache")
    ex = example
    return free_influence(ex.design, ex.modification, ex.crank_holes, folder, **COARSE)
