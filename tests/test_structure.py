"""The package's structure: no import cycle among the modules of cosim/ and controllers/ (imports inside
functions count, since they hide a cycle rather than remove it), no function over 120 lines, and an install
that holds every package of the checkout."""

import ast
import graphlib
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = {"cosim": "cosim", "cosim_controllers": "controllers"}  # import name -> folder of the checkout


def _modules():
    """Dotted name -> file of every module of the packages (a package is its ``__init__.py``)."""
    modules = {}
    for package, folder in PACKAGES.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            parts = (package, *path.relative_to(ROOT / folder).with_suffix("").parts)
            modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def _imports(name, path, modules):
    """The modules of the packages that ``name`` imports anywhere in its file: ``from a.b import c`` names
    ``a.b.c`` when that is a module, else ``a.b``; relative imports are resolved."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            for alias in node.names:
                found.add(f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base)
    return {m for m in found if m in modules and m != name}


def test_no_import_cycle():
    modules = _modules()
    graph = {name: _imports(name, path, modules) for name, path in modules.items()}
    try:
        graphlib.TopologicalSorter(graph).prepare()
    except graphlib.CycleError as err:
        raise AssertionError(f"import cycle (imports inside functions count): {' -> '.join(err.args[1])}") from None


def test_no_function_longer_than_120_lines():
    """A function past 120 lines does several jobs; the issue's limit for cosim/ and controllers/."""
    long = []
    for path in _modules().values():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = node.end_lineno - node.lineno + 1
                if length > 120:
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({length} lines)")
    assert not long, "functions longer than 120 lines: " + "; ".join(long)


def test_pyproject_installs_every_package_of_the_checkout():
    """pyproject.toml lists its packages by hand (the shipped controllers' folder is installed under another
    name): a package folder added to cosim/ and not listed there would be missing from every non-editable install."""
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]
    folders = {package: (ROOT / folder) for package, folder in setuptools["package-dir"].items()}
    on_disk = {".".join(("cosim", *init.parent.relative_to(ROOT / "cosim").parts))
               for init in (ROOT / "cosim").rglob("__init__.py")}
    assert set(setuptools["packages"]) == on_disk | set(folders)
    assert all((folder / "__init__.py").is_file() for folder in folders.values())
