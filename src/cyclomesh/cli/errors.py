"""One-line errors of the ``cyclomesh`` command: every refused input comes out as
``error: <one line>`` on stderr with exit status 2 and no traceback.

A command gets that behaviour from :func:`cli_errors`; usage errors (unknown option, bad
value, missing argument) from the command group :class:`OneLineUsage`.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from typing import Any

import typer
import typer.core

from cyclomesh.exceptions import CyclomeshError

__all__ = [
    "EXIT_INPUT_ERROR",
    "EXIT_INTERRUPTED",
    "OneLineUsage",
    "cli_errors",
    "fail",
    "quiet_logs",
]

EXIT_INPUT_ERROR = 2
"""Exit status for an input that cyclomesh refuses (as for a usage error)."""

EXIT_INTERRUPTED = 130
"""Exit status after Ctrl-C (128 + SIGINT, as a shell reports it)."""


class OneLineUsage(typer.core.TyperGroup):
    """The command group, with usage errors (unknown option, bad value, missing
    argument) as one line ``error: ...`` and exit status 2, like every refused input."""

    def main(self, *args: Any, standalone_mode: bool = True, **kwargs: Any) -> Any:
        """Run the command line ``args`` (default ``sys.argv[1:]``); the overview's figure
        process is forked first when they ask for it (:func:`cyclomesh.figures.early.fork_early`:
        before the options are converted, which imports pydantic, and before NumPy)."""
        from cyclomesh.figures.early import close_early, fork_early

        argv = args[0] if args else kwargs.get("args")
        fork_early(sys.argv[1:] if argv is None else list(argv))
        try:
            return self._main(*args, standalone_mode=standalone_mode, **kwargs)
        finally:
            close_early()  # a command that did not take the early figure process

    def _main(self, *args: Any, standalone_mode: bool = True, **kwargs: Any) -> Any:
        if not standalone_mode:
            return super().main(*args, standalone_mode=False, **kwargs)
        try:
            rv = super().main(*args, standalone_mode=False, **kwargs)
        except typer.TyperException as exc:  # Click's usage errors (typer vendors Click)
            if type(exc).__name__ == "NoArgsIsHelpError" or not hasattr(exc, "format_message"):
                exc.show()  # type: ignore[attr-defined]
                sys.exit(getattr(exc, "exit_code", EXIT_INPUT_ERROR))
            ctx = getattr(exc, "ctx", None)
            where = ctx.command_path if ctx is not None else "cyclomesh"
            line = " ".join(exc.format_message().split())
            typer.echo(f"error: {where}: {line} (see {where} --help)", err=True)
            sys.exit(EXIT_INPUT_ERROR)
        except typer.Abort:
            typer.echo("Aborted!", err=True)
            sys.exit(1)
        sys.exit(rv if isinstance(rv, int) else 0)


def fail(message: str) -> typer.Exit:
    """Print ``error: <message>`` (one line) on stderr; return the Exit to raise."""
    line = " ".join(part.strip() for part in str(message).splitlines() if part.strip())
    typer.echo(f"error: {line}", err=True)
    return typer.Exit(EXIT_INPUT_ERROR)


def _pydantic_error(exc: BaseException) -> str | None:
    pydantic = sys.modules.get("pydantic")  # not imported: cannot be a pydantic error
    if pydantic is None or not isinstance(exc, pydantic.ValidationError):
        return None
    first = exc.errors(include_url=False)[0]
    key = ".".join(str(part) for part in first["loc"])
    return f"{key}: {first['msg']}" if key else first["msg"]


@contextmanager
def _held_warnings() -> Iterator[None]:
    """Hold the warnings (NumPy's RuntimeWarnings among them) raised by the block: shown
    as usual when it succeeds, dropped when it fails, so that nothing precedes the one
    error line. Filters that turn a warning into an error still do."""
    import warnings

    with warnings.catch_warnings(record=True) as held:
        yield
    for w in held:  # success
        warnings.showwarning(w.message, w.category, w.filename, w.lineno, w.file, w.line)


def quiet_logs() -> None:
    """Silence the log records of Dask ``distributed`` (and of tornado and asyncio under
    it) on the terminal: a scheduler that dies mid-study is reported as one error line
    (:class:`~cyclomesh.execution.backends.ClusterError`), not as logged tracebacks."""
    import logging

    with suppress(ImportError):
        import distributed  # noqa: F401  (sets its logging up on import: silenced after)
    for name in ("distributed", "tornado", "asyncio"):
        logger = logging.getLogger(name)
        logger.setLevel(logging.CRITICAL + 1)
        for handler in logger.handlers:
            handler.setLevel(logging.CRITICAL + 1)
    for name, logger in list(logging.root.manager.loggerDict.items()):
        if isinstance(logger, logging.Logger) and name.startswith(("distributed.", "tornado.")):
            logger.setLevel(logging.CRITICAL + 1)


INTERRUPTED = "error: interrupted (Ctrl-C): --out is left as it was\n"
_HANDLER_PID = [0]
"""The process that installed :func:`_interrupted` (forked workers inherit it)."""


def _interrupted(signum: int, frame: Any) -> None:
    """Ctrl-C: discard the staged files, say so in one line, end with status 130 at once.

    Not a ``KeyboardInterrupt``: raised in the middle of an import that another thread
    waits for (the import preload), that can leave the import lock held and the command
    hung. Worker processes die with this one (``PR_SET_PDEATHSIG``). A worker forked
    before its initializer ignores SIGINT inherits this handler: it leaves quietly, so
    the command's one line is written once, by the command's own process."""
    import os
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C does not cut this short
    if os.getpid() != _HANDLER_PID[0]:  # a forked worker: its parent speaks and cleans up
        os._exit(EXIT_INTERRUPTED)
    from cyclomesh.output.folder import abandon_active

    with suppress(Exception):
        abandon_active()
    with suppress(OSError):
        sys.stderr.flush()
        os.write(2, INTERRUPTED.encode())
    os._exit(EXIT_INTERRUPTED)


@contextmanager
def _one_line_interrupt() -> Iterator[None]:
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    import os

    _HANDLER_PID[0] = os.getpid()
    previous = signal.signal(signal.SIGINT, _interrupted)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@contextmanager
def cli_errors() -> Iterator[None]:
    """Turn refused inputs into ``error: <one line>`` on stderr and exit status 2.

    Catches :class:`~cyclomesh.exceptions.CyclomeshError` (which includes
    ``StudyError``, ``DesignError`` and ``ConvergenceError``), pydantic validation
    errors, TOML syntax errors and operating-system errors (missing file, no
    permission). Use it as a context manager or as a decorator of a command. Warnings
    raised on the way are shown only if the command succeeds; Ctrl-C ends it with one
    line, ``error: interrupted``, and exit status 130.
    """
    import os
    import tomllib

    if os.environ.get("CYCLOMESH_TRACEBACK"):
        yield
        return
    try:
        with _one_line_interrupt(), _held_warnings():
            yield
    except CyclomeshError as exc:
        raise fail(str(exc)) from None
    except tomllib.TOMLDecodeError as exc:
        raise fail(f"invalid TOML: {exc}") from None
    except OSError as exc:
        where = f"{exc.filename}: " if exc.filename else ""
        raise fail(f"{where}{exc.strerror or exc}") from None
    except RecursionError:
        raise fail("input nested too deeply") from None
    except MemoryError:
        raise fail(
            "out of memory: ask for less work (fewer crank angles, rings or points)"
        ) from None
    except ValueError as exc:
        message = _pydantic_error(exc)
        if message is None:
            raise fail(_internal(exc)) from None
        raise fail(message) from None
    except KeyboardInterrupt:
        typer.echo(INTERRUPTED, err=True, nl=False)
        raise typer.Exit(EXIT_INTERRUPTED) from None
    except (typer.Exit, typer.Abort, SystemExit):
        raise
    except Exception as exc:  # a bug: still one line, never a traceback
        raise fail(_internal(exc)) from None


def _internal(exc: BaseException) -> str:
    return (
        f"internal error ({type(exc).__name__}: {exc}); please report it with the study file "
        "(CYCLOMESH_TRACEBACK=1 shows the traceback)"
    )
