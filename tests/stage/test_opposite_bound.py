"""The facts a safe bound on the stage's opposite flanks rests on (docs/stage.md, "A
thirteenth look"): the mirror problem's contact of an opposite flank could be computed only
where that flank can close, if its distance gap l'·|φ'bl| is known beforehand.

1. The opposite flank's moment arm from the mirror problem's contact, l', is this mesh's
   moment arm l of the same pin to ~1e-10 of itself (the same tooth phase: the pin's
   distance from the disc centre is the same, taken in the reflected frame), and the
   opposite flanks without a law are exactly those whose l is not positive or whose
   unloaded opposite-flank rotation is not finite; so l·|φ'bl| from this mesh alone is the
   distance gap to a margin of 1e-9 of itself.
2. On the RV-40E stage with pin errors, rigid bearings with clearance at 412 N·m and the
   tolerance study's stage (crankshafts and carrier from geometry, crank hole errors
   beyond the clearance) at 412 and 12.36 N·m: about half of the opposite flanks are more than 20 µm
   away, and at the solution each of them is still open by more than 5 µm against the
   largest closing a disc's rotation θ and translation u can give, l·(θ − φ'bl) − |u|
   (|n·u| ≤ |u|, unit normals).

Both kernels (the NumPy reference and CYCLOMESH_KERNEL=numba)."""

import numpy as np
import pytest

import cyclomesh.stage.equilibrium as eq
from cyclomesh.core import kernel
from cyclomesh.core.pair import PinErrors
from cyclomesh.drive.mesh import stack_meshes
from cyclomesh.stage import StageDesign, solve_stage
from tests.stage.test_newton import BEARING, HOLES, LIGHT, MOD, RV40, _hard_stage

PHI = np.radians(np.arange(0.0, 360.0, 4.0))


def _errors() -> PinErrors:
    rng = np.random.default_rng(37)
    return PinErrors(radial=rng.uniform(-2e-6, 2e-6, 40), angular=rng.uniform(-2e-5, 2e-5, 40))


def _kernel(monkeypatch, name: str) -> None:
    if name == "numba":
        pytest.importorskip("numba")
    monkeypatch.setenv(kernel.ENV_VAR, name)
    assert kernel.kernel_name() == name


@pytest.mark.parametrize("name", ["numpy", "numba"])
@pytest.mark.parametrize("errors", [None, "pins"])
def test_the_opposite_flanks_arm_is_this_meshs_to_round_off(monkeypatch, name, errors):
    _kernel(monkeypatch, name)
    pin_errors = None if errors is None else _errors()
    if pin_errors is None:
        pin_errors = PinErrors()
    fwd, rev = stack_meshes(
        RV40, MOD, pin_errors, PHI, 2, True, True, True, "half_plane", None, False
    )
    stage = StageDesign(HOLES, BEARING)
    prob = eq._problem(fwd, rev, HOLES, stage.hole_errors(2), 412.0)
    n1 = RV40.pins
    A = PHI.size
    arm = fwd.geo.moment_arm.reshape(A, 2, n1)
    bl_o = prob.bl[..., n1:]
    usable = np.isfinite(bl_o)
    with np.errstate(invalid="ignore"):
        reverse = fwd.geo.reverse_rotation.reshape(A, 2, n1) - fwd.rest[:, None, None]
    np.testing.assert_array_equal(usable, np.isfinite(reverse) & (arm > 0))
    assert 0.9 < usable.mean() < 1.0  # some opposite flanks without a law
    arm_o = -prob.arm[..., n1:]  # the signed arm −l'
    assert np.all(np.abs(arm_o - arm)[usable] <= 1e-9 * arm[usable])
    assert np.all(bl_o[usable] < 0.0)  # an opposite flank closes clockwise


@pytest.mark.parametrize("name", ["numpy", "numba"])
@pytest.mark.parametrize(("which", "torque"), [("rigid", 412.0), ("hard", 412.0), ("hard", LIGHT)])
def test_far_opposite_flanks_stay_open_at_the_solution(monkeypatch, name, which, torque):
    _kernel(monkeypatch, name)
    errors, stage = _hard_stage(37)
    if which == "rigid":
        stage = StageDesign(HOLES, BEARING)
    box = {}
    problem, unpack = eq._problem, eq._unpack

    def keep_problem(*args, **kwargs):
        box["prob"] = problem(*args, **kwargs)
        box["mesh"] = args[0]
        return box["prob"]

    def keep_x(x, discs):
        box["x"] = np.array(x)
        return unpack(x, discs)

    monkeypatch.setattr(eq, "_problem", keep_problem)
    monkeypatch.setattr(eq, "_unpack", keep_x)
    result = solve_stage(RV40, stage, MOD, errors, torque, PHI, discs=2)
    prob, mesh = box["prob"], box["mesh"]
    _, theta, ux, uy = unpack(box["x"], 2)
    n1 = RV40.pins
    arm = mesh.geo.moment_arm.reshape(PHI.size, 2, n1)
    bl_o = prob.bl[..., n1:]
    usable = np.isfinite(bl_o)
    gap = np.where(usable, arm * -np.where(usable, bl_o, 0.0), np.inf)  # l·|φ'bl| [m]
    far = gap > 20e-6
    assert 0.4 < far.mean() < 0.6
    shift = np.hypot(ux, uy)[..., None]
    margin = np.where(usable, arm * (theta[..., None] - np.where(usable, bl_o, 0.0)), 0.0)
    margin -= shift
    assert np.all(margin[far & usable] > 5e-6)
    assert np.all(result.opposite_pin_load[0][far] == 0.0)
