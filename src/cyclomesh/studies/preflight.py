"""What each command refuses before it computes, in one place (``cyclomesh check``).

:func:`preflight` raises the refusal a command (every kind of study of the registry,
:data:`cyclomesh.studyfile.kinds.KINDS`) would give a loaded study before it computes
anything: the kind's first refusals (a missing section), the keys the command cannot
honour (the key-usage table, :mod:`cyclomesh.studyfile.usage`), the kind's own
pre-flight (``StudyKind.preflight``: the FE model's and the export's own limits, ...)
and the work limit. The commands run the same checks at their start, so ``check
--kind KIND`` accepts a file exactly when ``KIND`` starts computing it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cyclomesh.exceptions import StudyError
from cyclomesh.studyfile.kinds import KINDS

if TYPE_CHECKING:
    from cyclomesh.studyfile.schema import Study

__all__ = ["COMMANDS", "preflight", "kinds_of", "check_kinds", "refuse_friction_with_stage"]

COMMANDS = tuple(spec.command for spec in KINDS)
"""The commands a study file can be given to."""


def kinds_of(study: Study) -> list[str]:
    """The commands ``study`` is written for: ``run`` always, and each command whose own
    section the file has (``[stiffness]``, ``[tolerance]`` for tolerance and allocate,
    ``[design_space]``, ``[fe]``, ``[efficiency]``; each entry's ``written_for``).
    ``export`` is checked only when asked for."""
    return [spec.command for spec in KINDS if spec.written_for and spec.written_for(study)]


def preflight(study: Study, kind: str, *, allow_work: bool = False, work: bool = True) -> None:
    """Raise the :class:`StudyError` that ``cyclomesh KIND`` would raise for ``study``
    before computing (nothing when it would start computing).

    ``allow_work`` is ``--no-work-limit``; ``work=False`` leaves the work limit to the
    caller (a command that knows its ``--rings``).
    """
    from cyclomesh.studies.execute import load_kind
    from cyclomesh.studyfile.kinds import check_study_work, kind_spec
    from cyclomesh.studyfile.usage import USED, check_keys

    if kind not in COMMANDS:
        raise StudyError(f"--kind: expected one of {', '.join(COMMANDS)}, got {kind!r}")
    steps = load_kind(kind)
    if steps.keys_first is not None:  # the section first (and what it needs), as the command
        steps.keys_first(study)
    if kind in USED:
        check_keys(study.raw, kind)
    if steps.preflight is not None:
        steps.preflight(study)
    if work and kind_spec(kind).work is not None:
        check_study_work(study, kind, allow=allow_work)


def check_kinds(study: Study, kind: str | None, *, allow_work: bool = False) -> list[str]:
    """``cyclomesh check [--kind KIND]``: :func:`preflight` for ``kind``, or for every
    command of :func:`kinds_of`; returns the commands checked.

    Raises
    ------
    StudyError
        ``kind``'s refusal as the command gives it; without ``kind``, the first
        command's that refuses (``cyclomesh run would refuse it: ...``), naming the
        others that would refuse it too.
    """
    kinds = [kind] if kind else kinds_of(study)
    refused: list[tuple[str, str]] = []
    for name in kinds:
        try:
            preflight(study, name, allow_work=allow_work)
        except StudyError as exc:
            if kind:
                raise
            refused.append((name, str(exc)))
    if refused:
        first, why = refused[0]
        also = [name for name, _ in refused[1:]]
        more = f" (also refused by: {', '.join(also)}; see check --kind)" if also else ""
        raise StudyError(f"cyclomesh {first} would refuse it: {why}{more}")
    return kinds


def refuse_friction_with_stage(study: Study) -> None:
    """One-line :class:`StudyError` for a case whose ``[friction]`` the ``[stage]``
    equilibrium does not take (a crank-bearing coefficient without
    ``[stage.crank_bearing]``: :func:`cyclomesh.stage.friction.check_stage_friction`)."""
    from cyclomesh.exceptions import DesignError

    for case, inputs in zip(study.cases, study.inputs, strict=True):
        if inputs.friction is not None and inputs.stage is not None:
            from cyclomesh.stage.friction import check_stage_friction

            try:
                check_stage_friction(inputs.friction, inputs.stage.bearing)
            except DesignError as exc:
                raise StudyError(f"{case.label}: {exc}") from None
