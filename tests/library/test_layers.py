"""The import layers of csw/ (docs/development.md, "Layout"): a module imports from its
own layer or those below, never above, and never another module's private names."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
# From the bottom; the package's __init__ (its lazy table of public names) is above all.
LAYERS = {"kernels": 0, "config": 1, "io": 2, "camera": 3, "data": 3, "matching": 4,
          "robot": 4, "scale": 5, "eval": 5}
TOP = max(LAYERS.values()) + 1


def module_name(path):
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer(module):
    """csw.<package>...'s layer; csw itself (its __init__) is the top."""
    parts = module.split(".")
    return LAYERS.get(parts[1], TOP) if len(parts) > 1 else TOP


def imports(path):
    """(line, imported module, names) of every import in the file, relative ones made
    absolute."""
    package = module_name(path).split(".")
    if path.name != "__init__.py":
        package = package[:-1]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name, ()
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            names = tuple(alias.name for alias in node.names)
            if module == "csw":  # from csw import x: each name is a module or a public name
                for name in names:
                    yield node.lineno, f"csw.{name}", ()
            else:
                yield node.lineno, module, names


def library_files():
    return sorted((ROOT / "csw").rglob("*.py"))


def test_the_layers_cover_every_package_of_csw():
    packages = {p.name for p in (ROOT / "csw").iterdir()
                if p.is_dir() and (p / "__init__.py").exists()}
    assert packages - {"kernels"} <= set(LAYERS), packages - set(LAYERS)


@pytest.mark.parametrize("path", library_files(), ids=lambda p: module_name(p))
def test_imports_go_down_the_layers(path):
    me = module_name(path)
    upward = [f"line {line}: {module}" for line, module, _ in imports(path)
              if module.startswith("csw.") and layer(module) > layer(me)]
    assert not upward, f"{me} imports from a higher layer: {upward}"


@pytest.mark.parametrize("path", library_files(), ids=lambda p: module_name(p))
def test_no_module_imports_another_modules_private_names(path):
    private = [f"line {line}: {module}.{name}" for line, module, names in imports(path)
               if module.startswith("csw") for name in names
               if name.startswith("_") and not name.startswith("__")]
    assert not private, f"{module_name(path)} imports private names: {private}"
