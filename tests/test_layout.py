"""The package's layering, read from the sources: the command line is the top layer (no command
imports it), and the independent oracle (scipy reference, analytic limits) reaches none of the
native laws, not even through another module of the package. (The package's own
``__init__``, which every import of a submodule runs, loads the plugin library; it is not the
oracle's code and is left out.)"""
from __future__ import annotations

import ast
from pathlib import Path

import vibrofriction

PACKAGE = Path(vibrofriction.__file__).parent


def _imports(path: Path) -> set[str]:
    """Modules ``path`` imports, as absolute names within the package where relative."""
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    if path.name == "__init__.py":  # a package: its relative imports start from itself
        parts = parts[:-1]
        package = ".".join(parts)
    else:
        package = ".".join(parts[:-1])
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")
            if node.level:
                base = base[:len(base) - node.level + 1]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module or ""
            out.add(name)
            out.update(f"{name}.{alias.name}" for alias in node.names)
    return out


def _module_path(name: str) -> Path | None:
    parts = name.split(".")
    if parts[0] != "vibrofriction":
        return None
    candidate = PACKAGE.joinpath(*parts[1:])
    for path in (candidate.with_suffix(".py"), candidate / "__init__.py"):
        if path.is_file():
            return path
    return None


def _reached(start: str) -> set[str]:
    """Every package module ``start`` imports, directly or through others."""
    seen, todo = set(), [start]
    while todo:
        name = todo.pop()
        path = _module_path(name)
        if path is None or name in seen or name == "vibrofriction":  # (the package root)
            continue
        seen.add(name)
        todo.extend(_imports(path))
    return seen


def test_no_command_imports_the_command_line() -> None:
    commands = sorted((PACKAGE / "commands").glob("*.py"))
    assert len(commands) >= 10  # eight commands, common.py, __init__.py
    for path in commands:
        assert "vibrofriction.cli" not in _imports(path), path.name


def test_the_oracle_reaches_none_of_the_native_laws() -> None:
    native = {"vibrofriction._native", "vibrofriction.laws", "vibrofriction.rig",
              "vibrofriction._mujoco_plugins", "vibrofriction.planar"}
    for oracle in ("vibrofriction.reference", "vibrofriction.analytic",
                   "vibrofriction.synthetic"):
        reached = _reached(oracle)
        assert oracle in reached
        assert not reached & native, (oracle, sorted(reached & native))
