"""The package's shape: tests reach the kernels through the installed name, and no module
of csw imports one that imports it back (at any depth, at module level or in a
function)."""

import ast
from pathlib import Path

import pytest

import csw

ROOTS = {"csw": Path(csw.__file__).parent, "csw.kernels": Path(csw.kernels.__file__).parent}
TESTS = Path(__file__).parents[1]


def module_name(path):
    for package, root in sorted(ROOTS.items(), key=lambda item: -len(item[0])):
        if path.is_relative_to(root):
            parts = [package, *path.relative_to(root).with_suffix("").parts]
            return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
    raise AssertionError(path)


def modules():
    found = {}
    for root in ROOTS.values():
        for path in root.rglob("*.py"):
            found[module_name(path)] = path
    return found


def imports(name, path, known):
    """The csw modules ``name`` imports, anywhere in it."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = package.split(".")
            if node.level:
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            for alias in node.names:  # "from . import x": x may be a module
                full = f"{target}.{alias.name}"
                out.add(full if full in known else target)
        elif isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
    # a module imports its packages' __init__ too, but those only hand names on
    return {m for m in out if m in known and m != name and not name.startswith(m + ".")}


def test_no_import_cycle():
    known = modules()
    graph = {name: imports(name, path, known) for name, path in known.items()}
    state = {}

    def visit(name, trail):
        if state.get(name) == "done":
            return
        if state.get(name) == "open":
            cycle = trail[trail.index(name):] + [name]
            pytest.fail("import cycle: " + " -> ".join(cycle))
        state[name] = "open"
        for other in sorted(graph[name]):
            if other != "csw":  # the package's face: lazy names, no import at load
                visit(other, [*trail, name])
        state[name] = "done"

    for name in sorted(graph):
        visit(name, [])


def test_tests_use_the_installed_kernel_package():
    """``kernels`` as a top-level name would load a second copy of the modules (and
    pass under ``python -m pytest`` only)."""
    wrong = []
    for path in TESTS.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level
                     else [a.name for a in node.names] if isinstance(node, ast.Import) else [])
            wrong += [f"{path.name}:{node.lineno}" for n in names
                      if n == "kernels" or n.startswith("kernels.")]
    assert not wrong
