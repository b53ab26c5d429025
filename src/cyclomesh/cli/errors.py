"""One-line errors of the ``cyclomesh`` command: every refused input comes out as
``error: <one line>`` on stderr with exit status 2 and no traceback.

A command gets that behaviour from :func:`cli_errors`; usage errors (unknown option, bad
value, missing argument) from the command group :class:`OneLineUsage`.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import typer
import typer.core

from cyclomesh.exceptions import CyclomeshError

__all__ = ["EXIT_INPUT_ERROR", "OneLineUsage", "cli_errors", "fail"]

EXIT_INPUT_ERROR = 2
"""Exit status for an input that cyclomesh refuses (as for a usage error)."""


class OneLineUsage(typer.core.TyperGroup):
    """The command group, with usage errors (unknown option, bad value, missing
    argument) as one line ``error: ...`` and exit status 2, like every refused input."""

    def main(self, *args: Any, standalone_mode: bool = True, **kwargs: Any) -> Any:
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
def cli_errors() -> Iterator[None]:
    """Turn refused inputs into ``error: <one line>`` on stderr and exit status 2.

    Catches :class:`~cyclomesh.exceptions.CyclomeshError` (which includes
    ``StudyError``, ``DesignError`` and ``ConvergenceError``), pydantic validation
    errors, TOML syntax errors and operating-system errors (missing file, no
    permission). Use it as a context manager or as a decorator of a command.
    """
    import os
    import tomllib

    if os.environ.get("CYCLOMESH_TRACEBACK"):
        yield
        return
    try:
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
    except (typer.Exit, typer.Abort, KeyboardInterrupt, SystemExit):
        raise
    except Exception as exc:  # a bug: still one line, never a traceback
        raise fail(_internal(exc)) from None


def _internal(exc: BaseException) -> str:
    return (
        f"internal error ({type(exc).__name__}: {exc}); please report it with the study file "
        "(CYCLOMESH_TRACEBACK=1 shows the traceback)"
    )
