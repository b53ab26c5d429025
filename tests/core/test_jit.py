"""numba's cache kept true to the sources (cyclomesh.core.jit): a module's cache files
are deleted when any compiled module's source changed, and only then."""

import os
import re
from pathlib import Path

import pytest

from cyclomesh.core import jit

PACKAGE = Path(jit.__file__).resolve().parents[1]


def test_the_list_names_every_module_that_compiles():
    """Every module that calls njit is in COMPILED_MODULES (its edits must reach the
    guard), and every module listed compiles something."""
    calling = {
        path.relative_to(PACKAGE).as_posix()
        for path in PACKAGE.rglob("*.py")
        if path.name != "jit.py" and re.search(r"\bnjit\(", path.read_text())
    }
    assert calling == set(jit.COMPILED_MODULES)


def fake_cache(folder: Path, stem: str, names=("_f-12", "_g-40")) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    files = []
    for name in names:
        for suffix in (".py311.nbi", ".py311.1.nbc"):
            path = folder / f"{stem}.{name}{suffix}"
            path.write_bytes(b"stale machine code")
            files.append(path)
    return files


def test_a_stale_cache_is_deleted_once_and_a_fresh_one_kept(tmp_path):
    core, stage = tmp_path / "core" / "__pycache__", tmp_path / "stage" / "__pycache__"
    modules = [(tmp_path / "core/kernel.py", core), (tmp_path / "stage/kernel.py", stage)]
    old = fake_cache(core, "kernel") + fake_cache(stage, "kernel")
    bystander = core / "loadsharing.cpython-311.pyc"  # not numba's: never touched
    bystander.write_bytes(b"bytecode")
    other = fake_cache(core, "kernel_contact")  # a module not in this list: kept

    assert sorted(jit.refresh(modules, "digest-1")) == sorted(old)  # no stamp yet: stale
    assert not any(p.exists() for p in old)
    assert all(p.exists() for p in other) and bystander.exists()
    assert (core / f"kernel{jit.STAMP_SUFFIX}").read_text().strip() == "digest-1"

    new = fake_cache(core, "kernel") + fake_cache(stage, "kernel")  # numba compiles again
    assert jit.refresh(modules, "digest-1") == []  # the same sources: the cache is fresh
    assert all(p.exists() for p in new)
    assert sorted(jit.refresh(modules, "digest-2")) == sorted(new)  # a source edited


def test_the_digest_follows_every_listed_source(tmp_path):
    pytest.importorskip("numba")
    for module in jit.COMPILED_MODULES:
        (tmp_path / module).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / module).write_text(f"# {module}\n")
    before = jit.sources_digest(tmp_path)
    assert jit.sources_digest(tmp_path) == before
    for module in jit.COMPILED_MODULES:  # an edit of any one module changes it
        path = tmp_path / module
        text = path.read_text()
        path.write_text(text + "x = 1\n")
        assert jit.sources_digest(tmp_path) != before, module
        path.write_text(text)
    assert jit.sources_digest(tmp_path) == before


def test_the_package_cache_is_stamped_with_its_sources():
    pytest.importorskip("numba")
    jit.fresh_cache()
    digest = jit.sources_digest(PACKAGE)
    for module in jit.COMPILED_MODULES:
        source = PACKAGE / module
        stamp = jit.cache_folder(source) / f"{source.stem}{jit.STAMP_SUFFIX}"
        if os.access(stamp.parent, os.W_OK):  # (a read-only install's cache: numba's none)
            assert stamp.read_text().strip() == digest, module


def test_the_cache_folder_is_the_one_numba_picks(tmp_path, monkeypatch):
    """NUMBA_CACHE_DIR (numba.config.CACHE_DIR) moves numba's cache, and the guard's."""
    numba = pytest.importorskip("numba")
    source = PACKAGE / "core" / "kernel.py"
    monkeypatch.setattr(numba.config, "CACHE_DIR", "")
    assert jit.cache_folder(source) == source.parent / "__pycache__"
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))
    folder = jit.cache_folder(source)
    assert folder.is_relative_to(tmp_path) and folder.is_dir()
