"""FE influence coefficients of the disc body (coarse meshes: a few seconds each)."""

import numpy as np
import pytest

try:  # the fe extra; gmsh's wheel also needs X11/OpenGL client libraries (see .ci/run)
    import gmsh  # noqa: F401
    import skfem  # noqa: F401
except (ImportError, OSError) as exc:  # pragma: no cover
    pytest.skip(f"fe extra not usable here: {exc}", allow_module_level=True)

from cyclomesh import TABLE1, Modification
from cyclomesh.core.ltca import solve_ltca
from cyclomesh.core.pair import CrankHoles
from cyclomesh.fe.influence import compute_influence, influence

MOD = Modification(pin_radius=8e-6)
COARSE = dict(
    points=7, far_size=4e-3, flank_size=1.5e-3, elements_per_half_width=2.0, load_half_width=4e-4
)
N2 = TABLE1.teeth


@pytest.fixture(scope="module")
def coarse(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cache")
    return influence(TABLE1, MOD, cache_dir=folder, **COARSE), folder


def test_reciprocity_to_round_off(coarse):
    body, _ = coarse
    same = body.table[0, 0]  # loads and responses on one tooth: C_ab = C_ba exactly
    assert np.max(np.abs(same - same.T)) <= 1e-12 * np.max(np.abs(same))


def test_cyclic_symmetry(coarse):
    # load tooth 0 / read tooth d against load tooth −d / read tooth 0, the same pair by
    # the rotation by d teeth: equal up to the mesh, which is not exactly cyclic
    t = body_table = coarse[0].table[0]
    worst = max(np.max(np.abs(t[d] - t[N2 - d].T)) for d in range(1, N2))
    assert worst <= 0.01 * np.max(np.abs(body_table))


def test_positive_definite(coarse):
    t = coarse[0].table[0]
    for a in range(t.shape[-1]):
        m = np.array([[t[(i - j) % N2, a, a] for j in range(N2)] for i in range(N2)])
        assert np.linalg.eigvalsh(0.5 * (m + m.T)).min() > 0
    # with the near field subtracted, the body term plus the contact law's tangent is
    # still positive definite at a light load (10 N a pin)
    from cyclomesh.core.contact import unloaded_contact
    from cyclomesh.core.discbody import tooth_index
    from cyclomesh.core.ltca import pin_compliance

    phi = np.deg2rad([0.0, 3.0])
    geo = unloaded_contact(TABLE1, MOD, None, phi)
    alpha, gamma = pin_compliance(geo, TABLE1, True, "half_plane")
    c = coarse[0].matrix(tooth_index(TABLE1.pins, TABLE1.pitch, phi), geo.profile_angle)
    reach = geo.moment_arm[0] > 1e-3
    tangent = alpha - gamma * (1.0 + np.log(10.0))
    full = c[0][np.ix_(reach, reach)] + np.diag(tangent[0][reach])
    assert np.linalg.eigvalsh(full).min() > 0


def test_crank_holes_reciprocity_and_period():
    holes = CrankHoles(3, 50e-3, 12e-3)
    body = compute_influence(TABLE1, MOD, holes, **{**COARSE, "points": 5})
    assert body.table.shape[:2] == (13, N2)  # 39 teeth, 3 holes: they repeat every 13
    t = body.table
    # load on tooth 0 read on tooth 1 against load on tooth 1 read on tooth 0
    assert np.max(np.abs(t[0, 1] - t[1, N2 - 1].T)) <= 1e-12 * np.max(np.abs(t))


def test_mesh_convergence_of_one_coefficient():
    finer = {**COARSE, "far_size": 2e-3, "flank_size": 0.75e-3, "elements_per_half_width": 4.0}
    a = compute_influence(TABLE1, MOD, **COARSE).table[0]
    b = compute_influence(TABLE1, MOD, **finer).table[0]
    # the neighbour's response at the middle of the flank, and the raw self-compliance
    for block in (1, 0):
        ca, cb = a[block, 3, 3], b[block, 3, 3]
        assert abs(ca - cb) <= 0.03 * abs(cb)


def test_results_independent_of_the_cache(coarse, tmp_path):
    body, folder = coarse
    files = list(folder.glob("influence-*.npz"))
    assert len(files) == 1 and body.key in files[0].name
    again = influence(TABLE1, MOD, cache_dir=folder, **COARSE)  # loaded
    fresh = compute_influence(TABLE1, MOD, **COARSE)  # computed again
    assert again.key == fresh.key == body.key
    phi = np.deg2rad(np.arange(0.0, 6.0, 0.5))
    runs = [
        solve_ltca(TABLE1, MOD, None, 250.0, phi, True, "half_plane", b) for b in (again, fresh)
    ]
    assert np.array_equal(runs[0].pin_load, runs[1].pin_load)
    assert np.array_equal(runs[0].loaded_rotation, runs[1].loaded_rotation)
    # another design is another file
    other = influence(TABLE1, Modification(pin_radius=9e-6), cache_dir=tmp_path, **COARSE)
    assert other.key != body.key


def test_disc_fe_compares_with_the_compliant_ltca(coarse):
    from cyclomesh.fe.disc import solve_disc_fe

    body, _ = coarse
    args = (TABLE1, MOD, 250.0, 0.0, 30e-3, 2.0, 5e-3, "half_plane")
    soft = solve_disc_fe(*args, disc_body=body)
    rigid_ltca = soft.ltca_by_law["half_plane"]
    # the FE disc is softer than the rigid-disc LTCA; the compliant LTCA closes most of it
    assert soft.rotation_fe > soft.rotation_ltca > rigid_ltca[2]
    assert abs(soft.rotation_ltca - soft.rotation_fe) < 0.5 * (soft.rotation_fe - rigid_ltca[2])


def test_cache_folder_from_the_cli_option_or_the_user(monkeypatch, tmp_path):
    from cyclomesh.cli.options import use_cache_dir as _cache_dir
    from cyclomesh.fe.influence import default_cache_dir

    monkeypatch.delenv("CYCLOMESH_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert default_cache_dir() == tmp_path / "xdg" / "cyclomesh"
    _cache_dir(tmp_path / "mine")  # what --cache-dir does
    assert default_cache_dir() == tmp_path / "mine"
