"""What each command refuses before it computes, in one place (``cyclomesh check``).

:func:`preflight` raises the refusal a command (``run``, ``stiffness``, ``tolerance``,
``allocate``, ``design``, ``fe``, ``export``) would give a loaded study before it
computes anything: the keys the command cannot honour (the key-usage table,
:mod:`cyclomesh.studyfile.usage`), a missing section, the work limit, the FE model's and
the export's own limits. The commands run the same checks at their start, so ``check
--kind KIND`` accepts a file exactly when ``KIND`` starts computing it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cyclomesh.exceptions import StudyError

if TYPE_CHECKING:
    from cyclomesh.studyfile.schema import Study

__all__ = ["COMMANDS", "preflight", "kinds_of", "check_kinds"]

COMMANDS = ("run", "stiffness", "tolerance", "allocate", "design", "fe", "export", "efficiency")
"""The commands a study file can be given to."""


def kinds_of(study: Study) -> list[str]:
    """The commands ``study`` is written for: ``run`` always, and each command whose own
    section the file has (``[stiffness]``, ``[tolerance]`` for tolerance and allocate,
    ``[design_space]``, ``[fe]``). ``export`` is checked only when asked for."""
    kinds = ["run"]
    if any(case.stiffness is not None for case in study.cases):
        kinds.append("stiffness")
    if study.tolerance is not None:
        kinds += ["tolerance", "allocate"]
    if study.file.design_space is not None:
        kinds.append("design")
    if study.file.fe is not None:
        kinds.append("fe")
    if study.file.efficiency is not None:
        kinds.append("efficiency")
    return kinds


def preflight(study: Study, kind: str, *, allow_work: bool = False, work: bool = True) -> None:
    """Raise the :class:`StudyError` that ``cyclomesh KIND`` would raise for ``study``
    before computing (nothing when it would start computing).

    ``allow_work`` is ``--no-work-limit``; ``work=False`` leaves the work limit to the
    caller (a command that knows its ``--rings``).
    """
    from cyclomesh.studyfile.limits import check_study_work
    from cyclomesh.studyfile.usage import KINDS, check_keys

    if kind not in COMMANDS:
        raise StudyError(f"--kind: expected one of {', '.join(COMMANDS)}, got {kind!r}")
    if kind in ("tolerance", "allocate") and study.tolerance is None:
        raise StudyError(f"{study.path.name}: no [tolerance] section (see examples/tolerance.toml)")
    if kind == "design" and study.file.design_space is None:
        raise StudyError(
            f"{study.path.name}: no [design_space] section "
            "(see docs/design-map.md, examples/design.toml)"
        )
    if kind == "efficiency":  # the section and the friction first, as the command
        from cyclomesh.studies.efficiency import check_efficiency

        check_efficiency(study)
    if kind in KINDS:
        check_keys(study.raw, kind)
    if kind in ("run", "stiffness"):
        from cyclomesh.studies.run import refuse_friction_with_stage

        refuse_friction_with_stage(study)
    if kind == "stiffness":
        from cyclomesh.studies.stiffness import check_stiffness

        check_stiffness(study)
    elif kind in ("tolerance", "allocate"):
        from cyclomesh.studies.tolerance import ring_model

        ring_model(study, study.tolerance)
    elif kind == "fe":
        from cyclomesh.studies.fe import check_fe
        from cyclomesh.studyfile.schema import refuse_stage

        refuse_stage(study, "fe")
        check_fe(study)
    elif kind == "export":
        from cyclomesh.core.outline import check_exportable
        from cyclomesh.exceptions import DesignError

        for case, inputs in zip(study.cases, study.inputs, strict=True):
            try:
                check_exportable(inputs.design, inputs.modification)
            except DesignError as exc:
                raise StudyError(f"{case.label}: {exc}") from None
    if work and kind in ("run", "stiffness", "tolerance", "allocate", "design"):
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
