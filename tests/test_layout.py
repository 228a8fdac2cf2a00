"""The package tree, drawn from the imports (lazy ones inside functions included): no module
imports itself back through others, the folders of src/vplotter/ form layers (no folder imports
one that imports it back), no module passes 500 lines, no function 80 lines and no line 100
characters; and no test file imports another (what they share is in tests/support/)."""

from __future__ import annotations

import ast
from pathlib import Path

from support import REPO

SRC = Path(REPO) / "src"
MAX_LINES = 500


def _modules() -> dict[str, Path]:
    mods = {}
    for p in sorted((SRC / "vplotter").rglob("*.py")):
        parts = p.relative_to(SRC).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        mods[".".join(parts)] = p
    return mods


def import_graph() -> dict[str, set[str]]:
    """module -> the vplotter modules it imports (a name imported from a package that is a
    module of its own counts as that module)."""
    mods = _modules()
    graph: dict[str, set[str]] = {}
    for name, path in mods.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        deps: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[:len(package.split(".")) - node.level + 1]
                    mod = ".".join(base + ([node.module] if node.module else []))
                else:
                    mod = node.module or ""
                for alias in node.names:
                    deps.add(f"{mod}.{alias.name}" if f"{mod}.{alias.name}" in mods else mod)
            elif isinstance(node, ast.Import):
                deps.update(a.name for a in node.names)
        graph[name] = {d for d in deps if d in mods and d != name}
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def room(module: str) -> str | None:
    """The folder a module lives in (inputs, motion, ...), or the module itself at the top."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def room_graph() -> dict[str, set[str]]:
    rooms: dict[str, set[str]] = {}
    for a, deps in import_graph().items():
        ra = room(a)
        if ra is None:
            continue
        rooms.setdefault(ra, set()).update(r for r in map(room, deps) if r and r != ra)
    return rooms


def test_no_module_imports_itself_back():
    assert _cycles(import_graph()) == []


def test_the_folders_form_layers():
    assert _cycles(room_graph()) == []


def test_the_graph_sees_lazy_imports():
    graph = import_graph()
    assert "vplotter.backends.fake" in graph["vplotter.backends"]     # inside create()
    assert "vplotter.drawing.order" in graph["vplotter.prepare"]       # inside functions
    assert "vplotter.motion.segment" in graph["vplotter.pipeline"]


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_module_passes_500_lines():
    long = {name: n for name, p in _modules().items()
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert long == {}


def test_the_stages_have_their_folders():
    rooms = {room(m) for m in _modules()} - {None}
    assert {"inputs", "drawing", "motion", "kinematics", "machine", "backends", "calibration",
            "commands", "config"} <= rooms


MAX_FUNCTION_LINES = 80
MAX_LINE_CHARS = 100
# Functions allowed to be longer, each with its reason: data tables only. Empty.
LONG_TABLES: set[str] = set()


def _functions(tree: ast.AST, prefix: str = ""):
    """(qualified name, lines from `def` to its last line) of every function and method,
    nested ones included."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            name = f"{prefix}{node.name}"
            if not isinstance(node, ast.ClassDef):
                yield name, node.end_lineno - node.lineno + 1
            yield from _functions(node, name + ".")
        else:
            yield from _functions(node, prefix)


def test_no_function_passes_80_lines():
    long = {}
    for p in _modules().values():
        where = p.relative_to(SRC).as_posix()
        for name, n in _functions(ast.parse(p.read_text(), str(p))):
            key = f"{where}:{name}"
            if n > MAX_FUNCTION_LINES and key not in LONG_TABLES:
                long[key] = n
    assert long == {}


def test_no_line_passes_100_characters():
    long = {}
    for p in _modules().values():
        where = p.relative_to(SRC).as_posix()
        lines = [i for i, line in enumerate(p.read_text().splitlines(), 1)
                 if len(line) > MAX_LINE_CHARS]
        if lines:
            long[where] = lines
    assert long == {}


def test_no_test_file_imports_another():
    """What test files share is in tests/support/, not in another test file."""
    found = {}
    for p in sorted((Path(REPO) / "tests").glob("test_*.py")):
        for node in ast.walk(ast.parse(p.read_text(), str(p))):
            names = ([node.module or ""] if isinstance(node, ast.ImportFrom)
                     else [a.name for a in node.names] if isinstance(node, ast.Import) else [])
            bad = [n for n in names if n.split(".")[0].startswith("test_")]
            if bad:
                found.setdefault(p.name, []).extend(bad)
    assert found == {}
