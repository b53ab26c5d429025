"""The package's layers: imports point down only, no import cycle, no private name borrowed.

Every module of ``src/cyclomesh`` is read with :mod:`ast` (nothing is imported), so the
check covers imports inside functions and under ``TYPE_CHECKING`` as well.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "cyclomesh"

# Rank of each layer, bottom (0) to top; a module may import its own layer or lower ones.
LAYERS = {
    "exceptions": 0,
    "units": 0,
    "quantities": 0,  # the registry of result quantities (names, units, labels)
    "execution": 0,  # generic: chunks of work on this process, local processes or Dask
    "core": 1,  # the paper's model, NumPy/SciPy only
    "drive": 2,
    "fe": 3,
    "stage": 3,
    "designspace": 3,
    "results": 4,  # labelled results (xarray, imported where a Dataset is built); the chain
    "tolerance": 4,  # beside results: its chunk functions reduce rings to the metrics table
    "studyfile": 5,
    "output": 6,
    "figures": 6,
    "publish": 6,
    "studies": 7,
    "cli": 8,
    "explore": 8,  # the explorer in the browser: a front end beside the command line
    "__main__": 8,
    "__init__": 8,
}
CORE_THIRD_PARTY = {"numpy", "scipy"}


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE).with_suffix("").parts
        if parts[-1] == "__init__" and len(parts) > 1:
            parts = parts[:-1]
        out["cyclomesh." + ".".join(parts) if parts != ("__init__",) else "cyclomesh"] = path
    return out


MODULES = _modules()


def _layer(module: str) -> str:
    parts = module.split(".")
    return "__init__" if len(parts) == 1 else parts[1]


def _imports(module: str, path: Path) -> list[tuple[str, list[str], int]]:
    """(imported module, imported names, line) of every import statement."""
    tree = ast.parse(path.read_text(), str(path))
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(alias.name, [], node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join([*base, node.module] if node.module else base)
            else:
                target = node.module or ""
            names = [alias.name for alias in node.names]
            # "from cyclomesh.figures import run" imports the module cyclomesh.figures.run
            subs = [f"{target}.{n}" for n in names if f"{target}.{n}" in MODULES]
            if subs:
                found += [(s, [], node.lineno) for s in subs]
                names = [n for n in names if f"{target}.{n}" not in MODULES]
            if names or not subs:
                found.append((target, names, node.lineno))
    return found


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_point_down_the_layers(module):
    layer = _layer(module)
    assert layer in LAYERS, f"{module}: a new top-level module or package needs a layer here"
    wrong = [
        f"line {line}: {target} ({_layer(target)})"
        for target, _, line in _imports(module, MODULES[module])
        if target.startswith("cyclomesh.") and LAYERS[_layer(target)] > LAYERS[layer]
    ]
    assert not wrong, f"{module} ({layer}) imports from a higher layer: {wrong}"


@pytest.mark.parametrize("module", sorted(m for m in MODULES if _layer(m) == "core"))
def test_the_core_imports_only_numpy_scipy_and_itself(module):
    third = {
        target.split(".")[0]
        for target, _, _ in _imports(module, MODULES[module])
        if not target.startswith("cyclomesh")
    }
    stdlib = {"__future__", "dataclasses", "math", "typing", "functools", "collections"}
    if module == "cyclomesh.core.kernel":  # the kernel switch (CYCLOMESH_KERNEL) and the
        stdlib |= {"os", "numba"}  # optional compiled kernel, imported on first use
    if module in ("cyclomesh.core.kernel_contact", "cyclomesh.core.kernel_discbody"):
        stdlib |= {"numba"}  # their compiled passes, on first use
    if module == "cyclomesh.core.jit":  # numba's options and its on-disk cache kept true to
        stdlib |= {"os", "hashlib", "pathlib", "numba"}  # the sources: no numerics, no results
    assert third <= CORE_THIRD_PARTY | stdlib, f"{module} imports {third - stdlib}"


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_private_name_is_borrowed(module):
    borrowed = [
        f"line {line}: {name} from {target}"
        for target, names, line in _imports(module, MODULES[module])
        if target.startswith("cyclomesh") and target != module
        for name in names
        if name.startswith("_") and not name.startswith("__")
    ]
    assert not borrowed, f"{module} imports private names: {borrowed}"


def test_no_import_cycle():
    graph = {
        m: {t for t, _, _ in _imports(m, p) if t in MODULES and t != m} for m, p in MODULES.items()
    }
    graph.pop("cyclomesh")  # the lazy public API names modules as strings only
    state: dict[str, int] = {}
    cycles = []

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                cycles.append(" -> ".join([*stack[stack.index(nxt) :], nxt]))
            elif nxt not in state:
                visit(nxt, [*stack, nxt])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    assert not cycles, cycles


ALLOCATOR_CALLERS = {"cyclomesh.cli", "cyclomesh.execution.runtime", "cyclomesh.execution.backends"}
"""Where the process-wide allocator may be tuned: the command's entry and the worker
initializers (local processes, Dask workers); never inside a library call."""

SYS_MODULES_WRITERS = {"cyclomesh.figures.worker"}
"""Where ``sys.modules`` may be changed: the start of the overview's figure process, a
process of its own that only draws (it leaves out matplotlib's 3D toolkit)."""


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_library_call_changes_the_process(module):
    """No ``sys.modules`` assignment, no write into another library's private state (a
    private attribute of an imported module or object, or of an object the module does not
    define), and ``tune_allocator()`` called only at process entry (issue 24)."""
    source = MODULES[module].read_text()
    tree = ast.parse(source, str(MODULES[module]))
    imported = {
        (alias.asname or alias.name).split(".")[0]
        for node in ast.walk(tree)
        if isinstance(node, ast.Import | ast.ImportFrom)
        for alias in node.names
    }
    wrong = []
    for node in ast.walk(tree):
        targets = []
        if isinstance(node, ast.Assign | ast.Delete):
            targets = node.targets
        elif isinstance(node, ast.AugAssign | ast.AnnAssign):
            targets = [node.target]
        for target in targets:
            if not isinstance(target, ast.Attribute | ast.Subscript):
                continue
            root = target
            while isinstance(root, ast.Attribute | ast.Subscript):
                root = root.value
            text = ast.unparse(target)
            name = root.id if isinstance(root, ast.Name) else ""
            entry = module.startswith("cyclomesh.cli")  # the process entry may set os.environ
            private = any(part.startswith("_") for part in text.split(".")[1:])
            if text.startswith("sys.modules") or (name in imported and private and not entry):
                wrong.append(f"line {node.lineno}: {text} written")
            elif (
                isinstance(target, ast.Attribute)
                and target.attr.startswith("_")
                and name not in ("self", "cls")
                and f"{target.attr}:" not in source
            ):
                wrong.append(f"line {node.lineno}: private state {text} written")
        if (
            isinstance(node, ast.Call)
            and ast.unparse(node.func).startswith("sys.modules.")
            and ast.unparse(node.func) != "sys.modules.get"
            and module not in SYS_MODULES_WRITERS
        ):
            wrong.append(f"line {node.lineno}: {ast.unparse(node.func)}() changes sys.modules")
        if (
            isinstance(node, ast.Call)
            and ast.unparse(node.func).endswith("tune_allocator")
            and module not in ALLOCATOR_CALLERS
        ):
            wrong.append(f"line {node.lineno}: tune_allocator() in a library call")
    assert not wrong, f"{module}: {wrong}"
