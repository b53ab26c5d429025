"""Every module, object and source file the documentation names exists (issue 24).

``docs/*.md`` and the README name modules (``cyclomesh.core.contact``), objects in them
(``cyclomesh.results.chain.run``) and files (``core/contact.py``,
``benchmarks/step_convergence.py``): each is imported or found, so a re-layout cannot
leave the docs pointing at modules that are gone.
"""

from __future__ import annotations

import re
from importlib import import_module
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "cyclomesh"
DOCS = sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]
DOTTED = re.compile(r"`(cyclomesh(?:\.\w+)+)")
FILE = re.compile(r"`([\w./-]+\.py)`")
NOT_MODULES = {"cyclomesh.attrs"}  # a key of the Parquet metadata (docs/study-files.md)
HISTORY = ("Where things went", "What changed")
"""README sections that record where old modules went: they name them on purpose."""


def resolve(dotted: str) -> bool:
    """The longest importable prefix of ``dotted`` and the attributes after it exist."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for name in parts[cut:]:
            if not hasattr(obj, name):
                return False
            obj = getattr(obj, name)
        return True
    return False


def exists(name: str) -> bool:
    """A file named relative to the repository or the package, or a bare file name found
    in the package."""
    if (ROOT / name).exists() or (PACKAGE / name).exists():
        return True
    return "/" not in name and any(
        any(folder.rglob(name)) for folder in (PACKAGE, ROOT / "benchmarks", ROOT / "tests")
    )


def current(text: str) -> str:
    """``text`` without its history sections (:data:`HISTORY`)."""
    sections = re.split(r"(?m)^(?=## )", text)
    return "".join(s for s in sections if not s.startswith(tuple(f"## {h}" for h in HISTORY)))


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_module_and_file_the_docs_name_exists(doc):
    text = current(doc.read_text(encoding="utf-8"))
    missing = sorted({m for m in DOTTED.findall(text) if m not in NOT_MODULES and not resolve(m)})
    missing += sorted({f for f in FILE.findall(text) if not exists(f)})
    assert not missing, f"{doc.name} names what does not exist: {missing}"


BARE_PYTHON = re.compile(r"(?<![/\w.])python3? +benchmarks/")


@pytest.mark.parametrize(
    "path",
    DOCS + sorted((ROOT / "benchmarks").glob("*.py")),
    ids=lambda p: str(p.relative_to(ROOT)),
)
def test_benchmark_commands_use_the_venv_python(path):
    """Issue 23: `python benchmarks/x.py` fails as written after the README's set-up (bare
    `python` is not the venv's): every benchmark command says `.venv/bin/python`."""
    bad = [
        line.strip()
        for line in path.read_text(encoding="utf-8").splitlines()
        if BARE_PYTHON.search(line)
    ]
    assert not bad, bad
