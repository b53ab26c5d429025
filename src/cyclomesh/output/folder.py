"""Result folders that cannot be lost or misread: atomic files, a lock, a completion marker.

Every result file of cyclomesh (NetCDF, Parquet, CSV, JSON, TOML, figures, report) is
written through :func:`atomic_write`: to a temporary name in the same folder
(``.<name>.<pid>.tmp``), then renamed into place (``os.replace``, atomic on POSIX). A
reader sees the old file or the new one, never a part of one; a write that fails
(disk full) removes its temporary file and raises :class:`OutputError` naming the path.

A command that writes a folder holds a :class:`ResultFolder` while it runs:

- an exclusive lock on ``<out>/.cyclomesh.lock`` (``fcntl.flock``; the file holds the
  PID of the holder): a second command into the same folder fails at once, naming it;
- it writes every file into the staging folder ``<out>/.cyclomesh.staging`` (its
  :attr:`ResultFolder.path`), never into ``<out>`` itself while it computes;
- ``summary.json``, the **completion marker**, is written last, with ``"status":
  "complete"`` and the list of files it vouches for (path and size in bytes); only then
  are the staged files moved into ``<out>``: the earlier marker removed first, the
  files renamed over those of the same name, the new marker last. A folder without a
  marker is incomplete (a command was killed while it moved its files in);
- a command that fails (or is interrupted) removes its staging folder and leaves
  ``<out>`` exactly as it found it: an earlier complete result stays complete and
  byte-identical, a folder the command created is removed (also on a full disk).

:func:`load_results` is the reader that refuses a folder without a complete marker, or
whose files no longer match it.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
from collections.abc import Iterator, Mapping
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cyclomesh.exceptions import OutputError

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "MARKER",
    "LOCK",
    "STAGING",
    "atomic_write",
    "write_bytes",
    "write_text",
    "ResultFolder",
    "active_folder",
    "abandon_active",
    "Results",
    "load_results",
]

MARKER = "summary.json"
"""File name of the completion marker."""

LOCK = ".cyclomesh.lock"
"""File name of the lock file in an output folder."""

STAGING = ".cyclomesh.staging"
"""Folder (inside the output folder) a command writes into before its result is moved
into place."""

_TMP_SUFFIX = ".tmp"

_ACTIVE: list[ResultFolder] = []


def active_folder() -> ResultFolder | None:
    """The :class:`ResultFolder` this process is writing (None outside one)."""
    return _ACTIVE[-1] if _ACTIVE else None


def abandon_active() -> None:
    """Discard what the folders this process writes have staged (their ``--out`` left as
    found, a folder they created removed): for a process about to end at once (Ctrl-C)."""
    while _ACTIVE:
        _ACTIVE.pop()._discard()


def _reason(exc: BaseException, folder: Path) -> str:
    """A short reason for a failed write (disk full and read-only named as such)."""
    code = getattr(exc, "errno", None)
    if code in (errno.ENOSPC, errno.EDQUOT):
        return "no space left on the device"
    if code == errno.EROFS:
        return "read-only file system"
    if code in (errno.EACCES, errno.EPERM):
        return "permission denied"
    if code is None or code == errno.EIO:  # HDF5 says only "HDF error"
        try:
            if not os.access(folder, os.W_OK):
                return f"no permission to write (or read-only file system) ({exc})"
            if shutil.disk_usage(folder).free < 1 << 20:
                return f"no space left on the device ({exc})"
        except OSError:
            pass
    text = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
    return " ".join(str(text).split())


@contextmanager
def atomic_write(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; rename it to ``path`` when the block
    succeeds, remove it when the block fails.

    Raises
    ------
    OutputError
        The block failed with an operating-system or library error while writing
        (disk full, no permission, a NetCDF/HDF error): ``"cannot write PATH: reason"``.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot write {path}: {_reason(exc, path.parent)}") from None
    tmp = path.with_name(f".{path.name}.{os.getpid()}{_TMP_SUFFIX}")
    try:
        yield tmp
        os.replace(tmp, path)
    except (OSError, RuntimeError) as exc:  # netCDF4 reports HDF errors as RuntimeError
        with suppress(OSError):
            tmp.unlink()
        shown = folder.final(path) if (folder := active_folder()) is not None else path
        raise OutputError(f"cannot write {shown}: {_reason(exc, path.parent)}") from None
    except BaseException:
        with suppress(OSError):
            tmp.unlink()
        raise
    folder = active_folder()
    if folder is not None:
        folder.record(path)


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (:func:`atomic_write`)."""
    path = Path(path)
    with atomic_write(path) as tmp:
        tmp.write_bytes(data)
    return path


def write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`atomic_write`)."""
    return write_bytes(path, text.encode("utf-8"))


def _holder(lock: Path) -> str:
    try:
        pid = lock.read_text(encoding="ascii").strip()
    except OSError:
        pid = ""
    return f"PID {pid}" if pid.isdigit() else "another process"


class ResultFolder:
    """The output folder of one command: locked, marker removed on entry, marker written
    last on success (see the module docstring).

    Parameters
    ----------
    out : Path
        Output folder (created if needed).
    command : str
        Name of the command, stored in the marker.
    """

    def __init__(self, out: str | Path, command: str) -> None:
        self.out = Path(out)
        self.command = command
        self.path = self.out / STAGING
        self.marker = self.path / MARKER
        self._fd: int | None = None
        self._created: Path | None = None  # the topmost folder this command created
        self._files: dict[Path, None] = {}
        self._pending: dict[str, Any] | None = None
        self._nested = False

    def final(self, path: str | Path) -> Path:
        """Where ``path``, written in the staging folder, lies once the result is in place."""
        path = Path(path)
        return self.out / path.relative_to(self.path) if path.is_relative_to(self.path) else path

    # --- lock -----------------------------------------------------------------------

    def __enter__(self) -> ResultFolder:
        out = self.out
        for held in _ACTIVE:
            if held.out.resolve() == out.resolve():  # already held here
                self._nested = True
                self.path, self.marker = held.path, held.marker
                return self
        if out.exists() and not out.is_dir():
            raise OutputError(f"--out {out}: exists and is not a folder")
        self._created = next((p for p in (out, *out.parents) if p.parent.exists()), None)
        if self._created is not None and self._created.exists():
            self._created = None
        try:
            out.mkdir(parents=True, exist_ok=True)
            fd = os.open(out / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            self._remove_created()
            raise OutputError(f"--out {out}: {_reason(exc, out.parent)}") from None
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not POSIX: no lock
            fcntl = None  # type: ignore[assignment]
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                os.close(fd)
                raise OutputError(
                    f"--out {out} is in use by another cyclomesh command "
                    f"({_holder(out / LOCK)}): wait for it to finish or choose another --out"
                ) from None
        self._fd = fd
        try:
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode("ascii"))
            if self.path.exists():  # left by a killed command
                shutil.rmtree(self.path)
            for stale in out.rglob(f".*{_TMP_SUFFIX}"):  # left by a killed command
                stale.unlink(missing_ok=True)
            self.path.mkdir()
        except OSError as exc:
            self._release()
            self._remove_created()
            raise OutputError(f"--out {out}: {_reason(exc, out)}") from None
        _ACTIVE.append(self)
        return self

    def __exit__(self, kind: type[BaseException] | None, *exc: object) -> None:
        if self._nested:
            return
        try:
            if self in _ACTIVE:
                _ACTIVE.remove(self)
            if kind is None:
                self._write_marker()
                self._swap()
        except BaseException:
            self._discard()
            raise
        else:
            if kind is not None:
                self._discard()
        finally:
            self._release()

    def _release(self) -> None:
        if self._fd is None:
            return
        with suppress(ImportError, OSError):
            import fcntl

            fcntl.flock(self._fd, fcntl.LOCK_UN)
        os.close(self._fd)
        self._fd = None

    def _discard(self) -> None:
        """After a failure: remove the staging folder, and the folder itself if this
        command created it; an earlier result in ``out`` is left as it was."""
        shutil.rmtree(self.path, ignore_errors=True)
        self._remove_created()

    def _remove_created(self) -> None:
        if self._created is not None:
            shutil.rmtree(self._created, ignore_errors=True)

    def _swap(self) -> None:
        """Move the staged files into ``out`` (replacing those of the same name), the
        marker last. The earlier marker is removed first: a command killed in between
        leaves an incomplete folder, never a marker vouching for a mix."""
        staged = sorted(p for p in self.path.rglob("*") if p.is_file() and p != self.marker)
        try:
            (self.out / MARKER).unlink(missing_ok=True)
            for path in staged:
                target = self.final(path)
                if target.is_dir() and not target.is_symlink():
                    shutil.rmtree(target)
                target.parent.mkdir(parents=True, exist_ok=True)
                os.replace(path, target)
            os.replace(self.marker, self.out / MARKER)
        except OSError as exc:
            raise OutputError(f"--out {self.out}: {_reason(exc, self.out)}") from None
        shutil.rmtree(self.path, ignore_errors=True)

    # --- files and marker -----------------------------------------------------------

    def record(self, path: Path) -> None:
        """Note a file written in the folder (by :func:`atomic_write`)."""
        path = Path(path)
        if path != self.marker and path.is_relative_to(self.path):
            self._files[path] = None

    def defer_marker(self, document: Mapping[str, Any]) -> None:
        """Keep ``document`` (the kind of study's ``summary.json``) to be written last,
        with the status and the file list."""
        self._pending = dict(document)

    def _write_marker(self) -> None:
        files = [
            {"path": p.relative_to(self.path).as_posix(), "bytes": p.stat().st_size}
            for p in self._files
            if p.exists()
        ]
        document = {"status": "complete", "command": self.command, **(self._pending or {})}
        document["files"] = files
        text = json.dumps(document, indent=2, allow_nan=False, ensure_ascii=False)
        write_text(self.marker, text + "\n")


# --- the reader ---------------------------------------------------------------------


@dataclass(frozen=True)
class Results:
    """A complete result folder (:func:`load_results`).

    Attributes
    ----------
    folder : Path
    summary : dict
        The marker (``summary.json``): status, command, the study's summary, files.
    files : tuple of Path
        The files the marker vouches for (absolute paths).
    """

    folder: Path
    summary: dict[str, Any]
    files: tuple[Path, ...]

    def dataset(self, name: str) -> xr.Dataset:
        """Load the NetCDF file ``name`` (relative to the folder, e.g.
        ``"Case_1/results.nc"``) into memory."""
        import xarray as xr

        path = self.folder / name
        if path not in self.files or path.suffix != ".nc":
            listed = ", ".join(p.relative_to(self.folder).as_posix() for p in self.netcdf)
            raise OutputError(f"{self.folder}: no result file {name!r}; NetCDF files: {listed}")
        return xr.load_dataset(path)

    @property
    def netcdf(self) -> tuple[Path, ...]:
        """The NetCDF files of the folder."""
        return tuple(p for p in self.files if p.suffix == ".nc")


def load_results(folder: str | Path) -> Results:
    """Open a result folder written by a cyclomesh command, refusing an incomplete one.

    Raises
    ------
    OutputError
        No ``summary.json`` (the command failed, was killed or is still running), a
        marker without ``"status": "complete"``, or a listed file that is missing or has
        changed size since the command finished.
    """
    folder = Path(folder)
    marker = folder / MARKER
    if not folder.is_dir():
        raise OutputError(f"{folder}: not a folder")
    try:
        text = marker.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise OutputError(
            f"{folder}: no {MARKER}: the command that wrote it did not finish (failed, "
            "killed or still running); run it again"
        ) from None
    try:
        summary = json.loads(text)
    except json.JSONDecodeError as exc:
        raise OutputError(f"{marker}: not a completion marker ({exc})") from None
    if not isinstance(summary, dict) or summary.get("status") != "complete":
        raise OutputError(f'{marker}: no "status": "complete": the folder is incomplete')
    files = []
    for entry in summary.get("files", []):
        path = folder / entry["path"]
        if not path.is_file() or path.stat().st_size != entry["bytes"]:
            raise OutputError(
                f"{path}: missing or changed since {MARKER} was written; run the command again"
            )
        files.append(path)
    return Results(folder, summary, tuple(files))
