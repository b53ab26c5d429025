"""The overview's figure process, forked as early as the command can know it will draw
the overview (issue 27).

:func:`fork_early` is called with the raw command line by the command's entry
(``cyclomesh.__main__.main``, before typer and the command line's modules are
imported) and, for a command line run in a process (``app([...])``), by the command
group (:class:`cyclomesh.cli.errors.OneLineUsage`): before the options are converted
(typer imports pydantic to convert them), right after NumPy is imported (which both
processes need). The figure process then imports matplotlib while this one imports
the rest, loads, solves and writes. :func:`early_figures` hands the process to the command when its
parsed ``--figures`` is the one the process was forked for; any other outcome
(another value, a usage error, ``--help``) closes it (:func:`close_early`, also at
exit), and a process that was not forked early is forked there as before.
"""

from __future__ import annotations

import atexit
from collections.abc import Sequence
from contextlib import nullcontext
from typing import Any

__all__ = ["fork_early", "early_figures", "close_early", "wants_overview"]

_EARLY: tuple[str, str | None, Any, tuple[str, ...]] | None = None
"""(command, raw ``--figures`` value, FigureProcess, command line) of :func:`fork_early`."""


def wants_overview(command: str, figures: str | None) -> bool:
    """Whether ``command`` with the ``--figures`` value ``figures`` (None: not given)
    draws the overview figure by default (``cyclomesh run``: not ``none``, not
    ``all``); a value the command will refuse draws nothing."""
    from cyclomesh.exceptions import StudyError
    from cyclomesh.studyfile.kinds import KINDS

    if not any(spec.command == command and spec.overview for spec in KINDS):
        return False
    if figures is None:
        return True
    from cyclomesh.publish.pipeline import parse_figures

    try:
        formats, figure_set = parse_figures(figures)
    except StudyError:  # refused later, in its turn (after the study's own errors)
        return False
    return bool(formats) and figure_set == "overview"


def _raw_figures(args: Sequence[str]) -> tuple[bool, str | None]:
    """(usable, value) of ``--figures`` in a command's raw arguments: the last one given
    (as the option is parsed), None if absent; not usable with ``--help`` or a
    ``--figures`` without its value."""
    value: str | None = None
    items = list(args)
    for i, arg in enumerate(items):
        if arg == "--":
            break
        if arg in ("--help", "-h"):
            return False, None
        if arg == "--figures":
            if i + 1 >= len(items):
                return False, None
            value = items[i + 1]
        elif arg.startswith("--figures="):
            value = arg.split("=", 1)[1]
    return True, value


def fork_early(argv: Sequence[str]) -> None:
    """Fork the overview's figure process now if the command line ``argv`` (without the
    program's name) will draw the overview: its command (the first word, after no
    option of the group: ``--help`` and ``--version`` run no command) and the raw
    ``--figures`` value (:func:`wants_overview`). NumPy is imported first (after
    :func:`~cyclomesh.execution.runtime.tune_blas`), here, so that the two processes
    do not both import it: 0.04 CPU-s less a run, the figure process's path to the
    drawn overview as long as before (it imported NumPy first itself). Does nothing
    where the process cannot fork (see :class:`~cyclomesh.figures.worker.FigureProcess`)."""
    global _EARLY
    if _EARLY is not None and _EARLY[3] == tuple(argv):  # forked by the entry already
        return
    close_early()
    if not argv or argv[0].startswith("-"):
        return
    command, args = argv[0], argv[1:]
    usable, figures = _raw_figures(args)
    if not usable or not wants_overview(command, figures):
        return
    from cyclomesh.execution.runtime import tune_blas
    from cyclomesh.figures.worker import FigureProcess

    tune_blas()
    import numpy  # noqa: F401  (both processes need it: imported once, before the fork)

    process = FigureProcess()
    if process.active:
        _EARLY = (command, figures, process, tuple(argv))
        atexit.register(close_early)


def close_early() -> None:
    """Stop the process of :func:`fork_early` if no command took it."""
    global _EARLY
    if _EARLY is not None:
        _EARLY[2].close()
        _EARLY = None


def early_figures(command: str, figures: str | None) -> Any:
    """The overview's figure process for ``command`` with its parsed ``--figures``
    value ``figures``: the one :func:`fork_early` forked for the same command and value,
    else one forked now, where the command draws the overview
    (:class:`cyclomesh.figures.worker.FigureProcess`); else an empty context."""
    global _EARLY
    if _EARLY is not None and _EARLY[:2] == (command, figures):
        process, _EARLY = _EARLY[2], None
        return process
    close_early()
    if not wants_overview(command, figures):
        return nullcontext(None)
    from cyclomesh.figures.worker import FigureProcess

    return FigureProcess()
