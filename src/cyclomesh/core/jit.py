"""numba's compiler options for every compiled kernel, and its on-disk cache kept true to
the sources.

Every compiled function of cyclomesh is made by :func:`njit`: cached on disk
(``cache=True``), without the GIL, and with NumPy's floating-point error model (a
division by zero gives inf or NaN, as in the NumPy reference path, instead of raising).

numba's cache checks only the source file that defines a function. The kernels call
(and inline) compiled functions of other modules: a kernel of ``stage/kernel_compliant.py``
inlines the pin law of ``stage/kernel_newton.py``, so after an edit of
``kernel_newton.py`` alone numba would load ``kernel_compliant``'s stale machine code,
which still computes the old pin law. :func:`fresh_cache` closes that gap: before the
first compiled function of a process is made, it hashes the sources of every module in
:data:`COMPILED_MODULES` and, where a module's cache was written for other sources,
deletes that module's cache files (numba compiles them again on first use). A release
installed afresh has new sources and so no stale cache; the guard is for a source tree
edited in place (an editable install, a ``git checkout``).
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable, Iterable
from functools import cache
from pathlib import Path
from typing import Any

__all__ = ["COMPILED_MODULES", "fresh_cache", "njit", "refresh"]

COMPILED_MODULES = (
    "core/kernel.py",
    "core/kernel_contact.py",
    "core/kernel_discbody.py",
    "stage/coupling.py",
    "stage/kernel.py",
    "stage/kernel_body.py",
    "stage/kernel_compliant.py",
    "stage/kernel_newton.py",
    "stage/kernel_outputs.py",
)
"""The modules (paths in the package) that define compiled functions; any of them may
call another's, so an edit of one makes every one's cache stale
(``tests/core/test_jit.py`` checks that the list names every module that calls
:func:`njit`)."""

STAMP_SUFFIX = ".cyclomesh-sources"
"""A module's stamp file in its numba cache folder: the hash of the sources its cache
was compiled from."""


def njit(inline: bool = False) -> Callable[[Callable[..., Any]], Any]:
    """numba's ``njit`` with cyclomesh's options (module doc): ``cache=True``,
    ``nogil=True``, ``error_model="numpy"``, and ``inline="always"`` for a small function
    its callers should inline. Imports numba (an ``ImportError`` without it) and runs
    :func:`fresh_cache` first, once a process."""
    import numba

    fresh_cache()
    options: dict[str, Any] = {"cache": True, "nogil": True, "error_model": "numpy"}
    if inline:
        options["inline"] = "always"
    return numba.njit(**options)


def sources_digest(root: Path, modules: Iterable[str] = COMPILED_MODULES) -> str:
    """SHA-256 of the modules' sources (in order) and of numba's version."""
    import numba

    digest = hashlib.sha256(numba.__version__.encode())
    for module in modules:
        digest.update(module.encode() + b"\0" + (root / module).read_bytes() + b"\0")
    return digest.hexdigest()


def refresh(modules: Iterable[tuple[Path, Path]], digest: str) -> list[Path]:
    """Delete the numba cache files of each (source file, cache folder) pair whose stamp
    is not ``digest``, then stamp it; return the files deleted. A folder that cannot be
    written is left as it is (numba then does not cache there either). Safe beside other
    processes: numba recompiles a function whose index or data file is gone."""
    deleted: list[Path] = []
    for source, folder in modules:
        stem = source.stem
        stamp = folder / f"{stem}{STAMP_SUFFIX}"
        try:
            if stamp.read_text().strip() == digest:
                continue
        except OSError:  # no stamp yet: a cache from before the guard, or none
            pass
        try:
            for path in folder.glob(f"{stem}.*.nb[ic]"):
                path.unlink(missing_ok=True)
                deleted.append(path)
            folder.mkdir(parents=True, exist_ok=True)
            temporary = stamp.with_name(f"{stamp.name}.{os.getpid()}")
            temporary.write_text(digest + "\n")
            os.replace(temporary, stamp)
        except OSError:
            continue
    return deleted


def cache_folder(source: Path) -> Path:
    """The folder numba caches ``source``'s functions in: its own choice of locator
    (``NUMBA_CACHE_DIR``, the module's ``__pycache__``, or the user-wide cache), or the
    module's ``__pycache__`` where that cannot be asked."""

    def probe() -> None:  # pragma: no cover (never called: a locator reads its line)
        pass

    try:
        from numba.core import caching

        impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl  # (before 0.61)
        for locator in impl._locator_classes:
            found = locator.from_function(probe, str(source))
            if found is not None:
                return Path(found.get_cache_path())
    except Exception:  # another numba: its cache layout is not known here
        pass
    return source.parent / "__pycache__"


@cache
def fresh_cache() -> list[Path]:
    """Make numba's cache of :data:`COMPILED_MODULES` true to their sources (module doc);
    once a process. Returns the cache files deleted."""
    root = Path(__file__).resolve().parents[1]
    try:
        digest = sources_digest(root)
    except OSError:  # sources not readable (a frozen application): nothing to compare
        return []
    return refresh(((root / m, cache_folder(root / m)) for m in COMPILED_MODULES), digest)
