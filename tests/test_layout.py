"""The package tree tells the architecture (docs/architecture.md): no import cycles, a
shallow import graph, and layers that import only downward.

Cycles and layers count every import, at module level and inside functions (a
function-level import must not hide a cycle or a layer break).  The depth counts
what loading a module loads: its module-level imports (a function-level import is a
command's own dependency, loaded when the command runs).  Left out everywhere: the
lazy attribute table of ``povh3d/__init__.py`` and ``if TYPE_CHECKING:`` blocks,
which import nothing at run time.
"""

from __future__ import annotations

import ast
from pathlib import Path


PACKAGE = Path(__file__).resolve().parents[1] / "povh3d"

# Which top-level parts may import which (besides errors, _version, system, cache, extras and jsontext,
# which everything may use).  cli -> commands -> renderer -> povray, beside the display and the
# libraries: only the renderer starts POV-Ray (commands/timing.py times a whole povh3d command
# through the same process owner, for ``bench``).
LIBRARIES = {"geometry", "image", "scene", "mesh", "calibration", "volume", "dataset", "hyper"}
ALLOWED = {
    "cli": {"commands", "renderer", "display", *LIBRARIES},
    "commands": {"renderer", "display", "povray", *LIBRARIES},
    "renderer": {"povray", "display", *LIBRARIES},
    "display": {"geometry", "image"},
    "povray": {"image", "scene"},
    "mesh": {"geometry", "image", "scene"},
    "calibration": {"image", "geometry"},
    "volume": {"geometry", "image", "mesh"},
    "image": {"geometry"},
    "dataset": {"image"},
    "hyper": {"image", "scene"},   # sprite sheets encoded by image/png_codec.py; ids as scene/ codes them
    "scene": set(),
    "geometry": set(),
    "cache": {"image"},   # the one cache writes its entries with image/io.py's atomic writer
}
BASE = {"errors", "_version", "system", "cache", "extras", "jsontext"}


def _modules() -> dict[str, Path]:
    found = {}
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        found[".".join(parts)] = path
    return found


def _is_type_checking(node: ast.If) -> bool:
    return isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING"


def _imports(name: str, path: Path, modules: dict[str, Path], *, module_level: bool = False,
             typing: bool = False) -> set[str]:
    """Modules of the package that ``name`` imports anywhere in its body (or at module level; with
    ``typing``, its ``if TYPE_CHECKING:`` imports too)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = {id(n) for top in ast.walk(tree) if isinstance(top, ast.If) and _is_type_checking(top)
            for n in ast.walk(top)} if not typing else set()
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in (tree.body if module_level else ast.walk(tree)):
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            for alias in node.names:
                full = f"{target}.{alias.name}"
                if full in modules:
                    out.add(full)
                elif target in modules:
                    out.add(target)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name in modules)
    out.discard(name)
    return out


def import_graph(*, module_level: bool = False, typing: bool = False) -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(name, path, modules, module_level=module_level, typing=typing)
            for name, path in modules.items()}


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


def test_cycle_finder_finds_a_cycle():  # negative control for the test below
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


def test_no_import_cycles():
    assert _cycle(import_graph()) is None


def test_no_import_cycles_counting_typing_imports():
    # povh3d/__init__.py's TYPE_CHECKING block names the public API (it imports every part): left out
    graph = import_graph(typing=True)
    graph["povh3d"] = set()
    assert _cycle(graph) is None


def test_import_graph_is_at_most_8_levels_deep():
    graph = import_graph(module_level=True)
    depth: dict[str, int] = {}

    def level(node: str) -> int:
        if node not in depth:
            depth[node] = 1 + max((level(n) for n in graph[node]), default=0)
        return depth[node]

    deepest = max(graph, key=level)
    chain = [deepest]
    while graph[chain[-1]]:
        chain.append(max(graph[chain[-1]], key=level))
    assert len(chain) <= 8, " -> ".join(chain)


def _part(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_layers_import_only_downward():
    wrong = []
    for module, targets in import_graph().items():
        part = _part(module)
        if part not in ALLOWED:
            continue
        for target in targets:
            other = _part(target)
            if other != part and other not in BASE and other not in ALLOWED[part]:
                wrong.append(f"{module} -> {target}")
    assert not wrong


def test_only_the_povray_runner_starts_processes():
    starters = [str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
                if "subprocess" in p.read_text(encoding="utf-8")]
    assert starters == ["povray/process.py"]


def test_the_package_is_typed():
    assert (PACKAGE / "py.typed").is_file()


def _long_functions(parts: tuple[str, ...], most: int) -> list[str]:
    """Functions of those parts with more than ``most`` lines of code (the docstring left out)."""
    found = []
    for part in parts:
        for path in sorted((PACKAGE / part).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    continue
                body = node.body[1:] if ast.get_docstring(node) is not None else node.body
                lines = node.end_lineno - (body[0].lineno if body else node.lineno) + 1
                if lines > most:
                    found.append(f"{path.relative_to(PACKAGE)}:{node.name} ({lines} lines)")
    return found


def test_the_render_path_holds_no_function_over_80_lines():
    assert _long_functions(("renderer", "povray"), 80) == []
    assert _long_functions(("renderer",), 40)   # negative control: the finder finds long ones
