"""What is analysed and with which model: a :class:`Case` and a :class:`Model`.

A :class:`Case` is the gear pair as built and loaded (design, modification, pin ring
errors, torque, crank angles); a :class:`Model` the physics chosen to analyse it (the
tooth term of the contact law, the pin–groove deformation, the disc body, the number of
discs, the RV stage around the mesh, friction at the contacts). Both are frozen. Every solver
(:func:`cyclomesh.core.ltca.solve_ltca`, :func:`cyclomesh.drive.solve.solve_drive`,
:func:`cyclomesh.drive.solve.torsion_curve`, :func:`cyclomesh.stage.solve.solve_stage`,
:func:`cyclomesh.stage.solve.stage_torsion_curve`) checks them once through
:func:`check`, and :func:`cyclomesh.results.chain.run` runs any of them from a case and a
model, so a new model option is one field here, not a parameter threaded through a
dozen signatures.

NumPy only, SI units, no I/O.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cyclomesh.core.discbody import DiscBody, FreeDiscBody
from cyclomesh.core.friction import Friction
from cyclomesh.core.hertz import CONTACT_LAWS
from cyclomesh.core.pair import Modification, PairDesign, PinErrors, check_physical
from cyclomesh.core.profile import check_profile
from cyclomesh.exceptions import DesignError

__all__ = [
    "Case",
    "Model",
    "Checked",
    "check",
    "check_crank_angles",
    "check_pair",
    "check_contact_law",
    "check_disc_body",
    "check_torques",
    "check_discs",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Case:
    """The gear pair as built and loaded, SI units.

    Attributes
    ----------
    design : PairDesign
    modification : Modification or None
        Tooth profile modification (Eq. 3 of [1]).
    errors : PinErrors or None
        Pin ring errors (Eq. 5 of [1]); leading axes are independent rings.
    torque : float or array_like
        Torque on the disc (the stack; the carrier of a stage) [N·m]; negative loads the
        reverse flanks. For a torsion curve: the rated torque T_r.
    crank_angles : array_like
        Crank angles φin [rad] of disc 1, one-dimensional and increasing.
    """

    design: PairDesign
    modification: Modification | None = None
    errors: PinErrors | None = None
    torque: Any = 250.0
    crank_angles: Any = (0.0,)

    def replace(self, **changes: Any) -> Case:
        """A copy with ``changes`` (``dataclasses.replace``)."""
        return replace(self, **changes)


@dataclass(frozen=True)
class Model:
    """The physics that analyses a :class:`Case`.

    Attributes
    ----------
    contact_law : {"half_plane", "paper"}
        Tooth term of the contact law (:mod:`cyclomesh.core.hertz`; Eq. 20 of [1] as
        published is ``"paper"``).
    groove_deformation : bool
        The "improved model" of [1] (pin–groove deformation, Eq. 19) or the "current model".
    disc_body : "rigid", "fe" or DiscBody
        Rigid disc ([1]) or the compliant disc body; ``"fe"`` is resolved to the
        :class:`~cyclomesh.core.discbody.DiscBody` of :func:`cyclomesh.fe.influence.influence`
        by :func:`cyclomesh.results.chain.run` (the fe extra).
    discs : int
        Number N of identical discs on the ring; disc k's eccentric at φ + (k − 1)·2π/N.
    stage : StageDesign or None
        The RV stage around the mesh (crank bearings, carrier,
        :class:`cyclomesh.stage.solve.StageDesign`), or None: the mesh alone.
    friction : Friction or None
        Friction at the pin contacts and the crank bearing, in the equilibrium
        (:class:`cyclomesh.core.friction.Friction`, docs/efficiency.md), or None: the
        paper's frictionless model (assumption 3 of [1]); all coefficients 0 is the same.
    """

    contact_law: str = "half_plane"
    groove_deformation: bool = True
    disc_body: Any = "rigid"
    discs: int = 1
    stage: Any = None
    friction: Any = None

    def replace(self, **changes: Any) -> Model:
        """A copy with ``changes`` (``dataclasses.replace``)."""
        return replace(self, **changes)


@dataclass(frozen=True)
class Checked:
    """A case and a model checked by :func:`check`: the arrays the solvers use (SI)."""

    design: PairDesign
    modification: Modification
    errors: PinErrors
    torques: FloatArray
    phi: FloatArray
    discs: int
    body: DiscBody | FreeDiscBody | None
    ring_shape: tuple
    contact_law: str
    groove_deformation: bool
    friction: Friction | None = None


def check(case: Case, model: Model, *, torque: str = "list") -> Checked:
    """The one validation of a case and a model: a one-line :class:`DesignError` naming the
    key, or the checked arrays.

    ``torque="list"``: one torque or a list of non-zero ones (:func:`check_torques`);
    ``"positive"``: one positive number (the one-disc forward solve); ``"rated"``: the
    rated torque of a torsion curve (checked by the curve).
    """
    design = case.design
    modification = case.modification or Modification()
    errors = case.errors or PinErrors()
    if torque == "positive":
        value = case.torque
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise DesignError(f"torque must be a positive number of N·m, got {value!r}")
        torques = np.array([float(value)])
    elif torque == "list":
        torques = check_torques(case.torque)
    else:
        torques = np.atleast_1d(np.asarray(case.torque, dtype=float))
    discs = check_discs(model.discs)
    phi = check_crank_angles(case.crank_angles)
    check_contact_law(model.contact_law)
    body = check_disc_body(model.disc_body, model.contact_law, design)
    if isinstance(body, FreeDiscBody) and model.stage is None:
        raise DesignError(
            "disc_body: the free disc body (crank-hole centres free) is the RV stage's; "
            "without [stage] pass the DiscBody of cyclomesh.fe.influence.influence"
        )
    ring_shape = check_pair(design, modification, errors)
    friction = model.friction
    if friction is not None and friction.frictionless:
        friction = None  # the paper's model, bit for bit
    if friction is not None and body is not None and model.stage is None:
        raise DesignError(
            "friction: the compliant (FE) disc body is coupled with friction only in the RV "
            'stage ([stage]); set disc_body = "rigid", add [stage] or remove [friction]'
        )
    return Checked(
        design=design,
        modification=modification,
        errors=errors,
        torques=torques,
        phi=phi,
        discs=discs,
        body=body,
        ring_shape=ring_shape,
        contact_law=model.contact_law,
        groove_deformation=model.groove_deformation,
        friction=friction,
    )


def check_torques(torque: ArrayLike) -> FloatArray:
    """Torques [N·m] as a one-dimensional array of finite non-zero numbers.

    Raises
    ------
    DesignError
        For an empty list, a non-finite value, a repeated torque or a torque of exactly 0
        (with no load the disc can sit anywhere in the play; the play itself is a result).
    """
    try:
        values = np.atleast_1d(np.asarray(torque, dtype=float))
    except (TypeError, ValueError):
        raise DesignError(
            f"torque must be a number of N·m or a list of them, got {torque!r}"
        ) from None
    if values.ndim != 1 or values.size == 0 or not np.all(np.isfinite(values)):
        raise DesignError(
            f"torque must be a finite number of N·m or a list of them, got {torque!r}"
        )
    if np.any(values == 0.0):
        raise DesignError(
            "torque 0 N·m: with no load the disc can sit anywhere in the play; give a "
            "positive (forward flanks) or negative (reverse flanks) torque; the play is a result"
        )
    if np.unique(values).size != values.size:
        raise DesignError("torque: the torques of a list must differ from each other")
    return values


def check_discs(discs: int) -> int:
    """The number of discs of a stack as an int ≥ 1, else a one-line DesignError."""
    if isinstance(discs, bool) or not isinstance(discs, int | np.integer) or discs < 1:
        raise DesignError(f"discs must be a whole number of at least 1, got {discs!r}")
    return int(discs)


def check_crank_angles(crank_angles: ArrayLike) -> FloatArray:
    """Crank angles [rad] as a one-dimensional increasing array, or a :class:`DesignError`."""
    phi = np.atleast_1d(np.asarray(crank_angles, float))
    if phi.ndim != 1 or phi.size == 0 or not np.all(np.isfinite(phi)):
        raise DesignError("crank angles must be a non-empty one-dimensional list of numbers")
    if phi.size > 1 and not np.all(np.diff(phi) > 0):
        raise DesignError("crank angles must increase")
    return phi


def check_pair(design: PairDesign, modification: Modification, errors: PinErrors) -> tuple:
    """Check profile and pin radii; return the ring shape of the errors.

    Raises
    ------
    DesignError
        For an undercut profile or a pin that does not fit its groove.
    """
    _check_profile(design, modification)
    ring_shape = errors.ring_shape(design.pins)
    check_physical(design, modification, errors)
    pin_radii = design.pin_radius + np.broadcast_to(errors.pin_radius, (*ring_shape, design.pins))
    if not np.all((pin_radii > 0) & (pin_radii < design.groove_radius)):
        pin = int(np.argmax(~((pin_radii > 0) & (pin_radii < design.groove_radius))) % design.pins)
        raise DesignError(
            f"errors.pin_radius: pin {pin + 1} radius must stay between 0 and the groove "
            f"radius {design.groove_radius * 1e3:.4g} mm"
        )
    return ring_shape


_PROFILES_KEPT = 64
"""How many passing (design, modification) pairs :func:`_check_profile` remembers."""


@functools.lru_cache(maxsize=_PROFILES_KEPT)
def _profile_passed(design: PairDesign, modification: Modification) -> None:
    """:func:`check_profile` of a hashable pair, remembered once it passes (a pair that
    fails raises, and nothing is remembered of it)."""
    check_profile(design, modification)


def _check_profile(design: PairDesign, modification: Modification) -> None:
    """:func:`check_profile`, once per equal (design, modification) that passes: it
    depends on those alone, and a study checks one pair for every ring of pin errors
    (0.1 ms of its 4,001-point curvature sample a solve). A pair that cannot be hashed
    (a profile deviation's arrays) is checked every time."""
    try:
        hash((design, modification))
    except TypeError:
        check_profile(design, modification)
        return
    _profile_passed(design, modification)


def check_contact_law(contact_law: str) -> str:
    """``contact_law`` if it is one of :data:`~cyclomesh.core.hertz.CONTACT_LAWS`, else a
    one-line :class:`DesignError` naming the choices."""
    if contact_law not in CONTACT_LAWS:
        raise DesignError(
            f"contact_law must be one of {', '.join(CONTACT_LAWS)}, got {contact_law!r}"
        )
    return contact_law


def check_disc_body(
    disc_body: str | DiscBody | FreeDiscBody, contact_law: str, design: PairDesign
) -> DiscBody | FreeDiscBody | None:
    """None for the rigid disc, the :class:`DiscBody` for a compliant one, else a
    one-line :class:`DesignError`."""
    if isinstance(disc_body, str) and disc_body == "rigid":
        return None
    if isinstance(disc_body, DiscBody | FreeDiscBody):
        if contact_law != "half_plane":
            raise DesignError(
                "disc_body: the FE disc body leaves the near field to the half-plane law; "
                f'set contact_law = "half_plane" (got {contact_law!r})'
            )
        if disc_body.teeth != design.teeth:
            raise DesignError(
                f"disc_body: coefficients for {disc_body.teeth} teeth, design has {design.teeth}"
            )
        return disc_body
    if disc_body == "fe":
        raise DesignError(
            'disc_body = "fe" is resolved by cyclomesh.analyse (or pass the DiscBody of '
            "cyclomesh.fe.influence.influence)"
        )
    raise DesignError(f'disc_body must be "rigid" or "fe", got {disc_body!r}')
