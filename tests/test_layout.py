"""The package's layering, read from the sources (docs/DEVELOPING.md has the layout): the
command line is the top layer (no command imports it, and nothing below imports a command);
the laws' binding (``vibrofriction.laws``) reaches nothing but itself and the shared
parameters; and the independent oracle (``vibrofriction.oracle``: scipy reference, analytic
limits, the feeder's exact reference) and the synthetic records made from it reach none of the
native laws nor a MuJoCo model of them, not even through another module of the package or a
subpackage's ``__init__``. (The package's own ``__init__``, which every import of a submodule
runs, loads the plugin library; it is not the oracle's code and is left out.) Within
identification (``vibrofriction.identify``) no module imports, directly or through others,
lazily or not, one that imports it: a general module (the rig's replay) does not reach its
specialisation (a machine's), and its package map names every module. The same holds for the
whole package: no module reaches itself through its imports. And no module uses another's
private name (``_name``), nor a private module (``laws._native``) from outside its package:
what one part offers another is public, named and documented."""
from __future__ import annotations

import ast
import re
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
        todo.append(name.rpartition(".")[0])  # importing a.b.c runs a.b's __init__ first
    return seen


def _modules(subpackage: str) -> list[str]:
    """Every module of a subpackage of vibrofriction, the package's __init__ included."""
    folder = PACKAGE / subpackage
    names = [f"vibrofriction.{subpackage}.{p.stem}" for p in sorted(folder.glob("*.py"))
             if p.name != "__init__.py"]
    return [f"vibrofriction.{subpackage}"] + names


# what runs the friction laws natively, or a MuJoCo model with the native elements
NATIVE = ("vibrofriction.laws", "vibrofriction.rigs", "vibrofriction.robots")
# the shared ground every layer may use
FOUNDATION = {"vibrofriction.params", "vibrofriction.vocabulary", "vibrofriction.errors",
              "vibrofriction.build_info"}


def _is_native(name: str) -> bool:
    return any(name == n or name.startswith(n + ".") for n in NATIVE)


def test_no_command_imports_the_command_line() -> None:
    commands = sorted((PACKAGE / "commands").glob("*.py"))
    assert len(commands) >= 10  # eight commands, common.py, __init__.py
    for path in commands:
        assert "vibrofriction.cli" not in _imports(path), path.name


def test_nothing_below_the_command_line_imports_it() -> None:
    for path in sorted(PACKAGE.rglob("*.py")):
        relative = path.relative_to(PACKAGE)
        if relative.parts[0] in ("commands", "cli.py", "__main__.py"):
            continue
        top = {n for n in _imports(path)
               if n.startswith(("vibrofriction.cli", "vibrofriction.commands"))}
        assert not top, (str(relative), sorted(top))


def test_the_laws_reach_only_themselves_and_the_parameters() -> None:
    for module in _modules("laws"):
        reached = _reached(module)
        assert module in reached
        outside = {n for n in reached if not n.startswith("vibrofriction.laws")} - FOUNDATION
        assert not outside, (module, sorted(outside))


def test_the_oracle_reaches_none_of_the_native_laws() -> None:
    oracle = _modules("oracle")
    assert len(oracle) >= 4  # reference, analytic, feeder_reference and the __init__
    for module in oracle + ["vibrofriction.data.synthetic"]:
        reached = _reached(module)
        assert module in reached
        native = sorted(n for n in reached if _is_native(n))
        assert not native, (module, native)


def _cycle(graph: dict[str, set[str]]) -> list[str]:
    """A cycle of ``graph`` (module -> the modules it imports) as its path, [] when none."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(name: str) -> list[str]:
        state[name] = 1
        path.append(name)
        for other in sorted(graph[name]):
            if state.get(other) == 1:
                return path[path.index(other):] + [other]
            if other not in state:
                found = visit(other)
                if found:
                    return found
        path.pop()
        state[name] = 2
        return []

    for name in sorted(graph):
        if name not in state:
            found = visit(name)
            if found:
                return found
    return []


def test_the_cycle_finder_finds_a_cycle() -> None:
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) == []


def test_identification_has_no_import_cycle() -> None:
    """Imports inside functions count too: a lazy import only hides a cycle. (The
    subpackage's ``__init__`` is left out: importing any module runs it, and it imports the
    modules it exports.)"""
    modules = _modules("identify")[1:]
    assert len(modules) >= 18
    graph = {m: {n for n in _imports(_module_path(m)) if n in modules and n != m}
             for m in modules}
    assert _cycle(graph) == []


def test_the_identification_package_map_lists_every_module() -> None:
    doc = ast.get_docstring(ast.parse((PACKAGE / "identify" / "__init__.py").read_text()))
    listed = re.findall(r"^  (\w+) \.{2,} ", doc, re.M)
    stems = [m.rpartition(".")[2] for m in _modules("identify")[1:]]
    assert sorted(listed) == sorted(stems)


def _package_modules() -> dict[str, Path]:
    """Every module of the package by its absolute name (a package by its own name)."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def test_the_package_has_no_import_cycle() -> None:
    """Across subpackages too (the rig and its steady state, the replays); lazy imports count.
    A package's ``__init__`` is left out as above: it imports what it exports."""
    modules = {m: p for m, p in _package_modules().items() if p.name != "__init__.py"}
    assert len(modules) >= 70
    graph = {m: {n for n in _imports(p) if n in modules and n != m} for m, p in modules.items()}
    assert _cycle(graph) == []


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _package_of(module: str, path: Path) -> str:
    return module if path.name == "__init__.py" else module.rpartition(".")[0]


def _private_uses(module: str, path: Path, modules: dict[str, Path]) -> list[str]:
    """The private names of other modules that ``module`` uses: imported (``from m import
    _x``), a private module imported from outside its package, or read as ``alias._x`` off an
    imported module."""
    home = _package_of(module, path)
    tree = ast.parse(path.read_text())
    found, module_aliases = [], {}

    def private_module_outside(name: str) -> bool:
        parts = name.split(".")
        for i, part in enumerate(parts[1:], start=1):
            if _private(part):
                owner = ".".join(parts[:i])  # the package the private module belongs to
                return not (home == owner or home.startswith(owner + "."))
        return False

    base = home.split(".")
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("vibrofriction") and private_module_outside(alias.name):
                    found.append(f"import {alias.name}")
                if alias.asname and alias.name in modules:
                    module_aliases[alias.asname] = alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                source = ".".join(base[:len(base) - node.level + 1] +
                                  ([node.module] if node.module else []))
            else:
                source = node.module or ""
            if not source.startswith("vibrofriction"):
                continue
            if private_module_outside(source):
                found.append(f"from {source}")
            for alias in node.names:
                full = f"{source}.{alias.name}"
                if full in modules:  # a module imported by name
                    if private_module_outside(full):
                        found.append(f"from {source} import {alias.name}")
                    module_aliases[alias.asname or alias.name] = full
                elif _private(alias.name) and source != module:
                    found.append(f"from {source} import {alias.name}")
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and \
                node.value.id in module_aliases and _private(node.attr):
            found.append(f"{module_aliases[node.value.id]}.{node.attr}")
    return found


def test_the_private_name_finder_finds_them(tmp_path) -> None:
    modules = {"vibrofriction.laws._native": Path("x"), "vibrofriction.rigs.rig": Path("y")}
    code = ("from ..laws._native import load\n"
            "from ..rigs import rig as rig_module\n"
            "from ..params import _plain\n"
            "n = rig_module._cpu_count()\n")
    path = tmp_path / "replay.py"
    path.write_text(code)
    found = _private_uses("vibrofriction.identify.replay", path, modules)
    assert found == ["from vibrofriction.laws._native", "from vibrofriction.params import _plain",
                     "vibrofriction.rigs.rig._cpu_count"]
    path.write_text("from ._native import load\n")  # within its own package: allowed
    assert _private_uses("vibrofriction.laws.run", path, modules) == []


def test_no_module_uses_another_modules_private_name() -> None:
    modules = _package_modules()
    used = {m: _private_uses(m, p, modules) for m, p in modules.items()}
    assert {m: u for m, u in used.items() if u} == {}


def test_every_module_and_public_name_says_what_it_is() -> None:
    """A module's head says what it holds; every public function and class has a docstring
    (its parameters' units in the text, or numpydoc sections where a user calls it)."""
    missing = []
    for module, path in _package_modules().items():
        tree = ast.parse(path.read_text())
        if not ast.get_docstring(tree):
            missing.append(module)
        missing += [f"{module}.{node.name}" for node in tree.body
                    if isinstance(node, (ast.FunctionDef, ast.ClassDef))
                    and not node.name.startswith("_") and not ast.get_docstring(node)]
    assert missing == []


def test_each_package_map_names_its_modules() -> None:
    """A package's ``__init__`` says what each of its modules holds (docs/DEVELOPING.md)."""
    for init in sorted(PACKAGE.glob("*/__init__.py")):
        doc = ast.get_docstring(ast.parse(init.read_text())) or ""
        named = set(re.findall(r"\b(\w+)(?:\.py)?\b", doc))
        modules = {p.stem for p in init.parent.glob("*.py") if p.name != "__init__.py"}
        assert modules <= named, (init.parent.name, sorted(modules - named))


def test_plugin_configs_are_written_through_the_table() -> None:
    """No scene builder writes a plugin's ``<config key=...>`` itself: configs go through
    ``vibrofriction.sim`` (MjSpec, or ``instance_xml`` for MJCF text), whose keys are checked
    against the vocabulary."""
    writers = sorted(str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
                     if "<config key=" in p.read_text())
    assert writers == ["sim/models.py"]
