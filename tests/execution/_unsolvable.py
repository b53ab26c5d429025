"""Rings a solver cannot solve, on purpose (importable by worker processes).

The real rings that fail to converge get fixed as the solvers improve, so the tests of
"an unsolved ring is an outcome of the study" make chosen rings fail deterministically:

* :func:`fail_rings` (in this process, serial backend and ``cyclomesh run``): wraps the
  one validation every mesh solve passes (``cyclomesh.drive.solve.check``), and the RV
  stage's solve (``cyclomesh.stage.solve.solve``), to raise a
  :class:`~cyclomesh.exceptions.ConvergenceError` for a case whose pin errors are those of
  a chosen ring (its radial errors, bit for bit, as the study loader and the ring model
  give them);
* :class:`UnsolvableRings` (worker processes, local pool and Dask): a
  :class:`~cyclomesh.tolerance.tasks.RingModel` whose mesh solve raises the same error
  for chosen rings; it travels to the workers with the task and is imported there from
  this module.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from cyclomesh.exceptions import ConvergenceError
from cyclomesh.tolerance.tasks import RingModel

MESSAGE = (
    "torque 250 N·m: crank angle 330°: the load sharing (Eq. 21) did not converge "
    "(a ring made unsolvable by the test)"
)
STAGE_MESSAGE = (
    "torque 12.36 N·m: stage equilibrium did not converge at crank angle 332°: residual "
    "above 1e-12·T/r_c after 200 Newton steps (made so by the test)"
)
"""The stage solver's message as a study reports it; the solver itself names the ring's
index in its batch in front ("ring 0, " for a ring solved alone), as this fake does."""


def ring_radial_m(model: RingModel, rings: Any) -> list[np.ndarray]:
    """The radial pin errors [m] of the given rings, as their solves see them."""
    return [np.asarray(model.pin_errors(model.draw([k])).radial, float)[0] for k in rings]


def _hit(errors: Any, targets: list[np.ndarray]) -> bool:
    radial = None if errors is None else np.asarray(errors.radial, float)
    if radial is None or radial.ndim == 0:
        return False
    rows = radial.reshape(-1, radial.shape[-1])
    return any(np.array_equal(row, t) for row in rows for t in targets)


def fail_rings(monkeypatch: Any, model: RingModel, rings: Any, stage: bool = False) -> None:
    """Make the mesh solve (or, ``stage``, the stage solve) of ``rings`` raise."""
    targets = ring_radial_m(model, rings)
    if stage:
        import cyclomesh.stage.solve as where

        original = where.solve

        def solve(case: Any, *args: Any, **kwargs: Any) -> Any:
            if _hit(case.errors, targets):
                raise ConvergenceError(f"ring 0, {STAGE_MESSAGE}")
            return original(case, *args, **kwargs)

        monkeypatch.setattr(where, "solve", solve)
        return
    import cyclomesh.drive.solve as where

    original_check = where.check

    def check(case: Any, *args: Any, **kwargs: Any) -> Any:
        if _hit(case.errors, targets):
            raise ConvergenceError(MESSAGE)
        return original_check(case, *args, **kwargs)

    monkeypatch.setattr(where, "check", check)


@dataclasses.dataclass(frozen=True)
class UnsolvableRings(RingModel):
    """A ring model whose mesh solve does not converge for the rings in ``fail`` (at every
    scale factor but 0)."""

    fail: tuple[int, ...] = ()

    @classmethod
    def of(cls, model: RingModel, fail: Any) -> UnsolvableRings:
        fields = {f.name: getattr(model, f.name) for f in dataclasses.fields(RingModel)}
        return cls(**fields, fail=tuple(int(k) for k in fail))

    def _solve(self, block: Any) -> dict[str, Any]:
        # the ring as drawn (or scaled by an allocation), not the base case that the
        # study solves with a ring's index and no drawn errors
        for k, radial in zip(block.rings, block.radial_um, strict=True):
            if int(k) in self.fail and np.any(radial):
                raise ConvergenceError(MESSAGE)
        return super()._solve(block)
