"""Which tests must run on one pytest-xdist worker together: those that share a module- or
session-wide fixture (a render, a cluster, a browser), so that the fixture is made once.

Read from the test files' source (the xdist controller does not collect), so the scheduler in
``tests/conftest.py`` can spread every other test one by one over the workers.
"""

from __future__ import annotations

import ast
from pathlib import Path

SHARED_SCOPES = {"module", "package", "session"}


def _fixture_scope(node: ast.FunctionDef) -> tuple[bool, str | None, bool]:
    """(is a fixture, its scope, autouse) from ``@pytest.fixture(...)`` decorators."""
    for deco in node.decorator_list:
        call = deco if isinstance(deco, ast.Call) else None
        target = call.func if call else deco
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if name != "fixture":
            continue
        keywords = {k.arg: k.value for k in call.keywords} if call else {}
        scope = keywords.get("scope")
        autouse = keywords.get("autouse")
        return (True, scope.value if isinstance(scope, ast.Constant) else None,
                bool(isinstance(autouse, ast.Constant) and autouse.value))
    return False, None, False


def _arguments(node: ast.FunctionDef) -> set[str]:
    return {a.arg for a in node.args.args + node.args.kwonlyargs}


def grouped_tests(source: str) -> set[str] | None:
    """Names of the test functions of a module that use a shared fixture, directly or through
    other fixtures of the module; ``None`` when every test does (a shared autouse fixture)."""
    functions = [n for n in ast.walk(ast.parse(source)) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
    fixtures = {}
    shared: set[str] = set()
    for node in functions:
        is_fixture, scope, autouse = _fixture_scope(node)
        if not is_fixture:
            continue
        fixtures[node.name] = _arguments(node)
        if scope in SHARED_SCOPES:
            if autouse:
                return None
            shared.add(node.name)
    if not shared:
        return set()
    grew = True
    while grew:   # a function fixture built on a shared one is shared too
        grew = False
        for name, args in fixtures.items():
            if name not in shared and args & shared:
                shared.add(name)
                grew = True
    return {n.name for n in functions if n.name.startswith("test") and _arguments(n) & shared}


def group_of(nodeid: str, groups: dict[str, set[str] | None]) -> str:
    """The work unit of a test: its module when it shares a fixture there, else the test itself."""
    module, _, rest = nodeid.partition("::")
    if module not in groups:
        return nodeid
    names = groups[module]
    function = rest.split("::")[-1].split("[")[0]
    return module if names is None or function in names else nodeid


def shared_fixture_groups(root: Path, tests: Path) -> dict[str, set[str] | None]:
    """``{module path relative to root: grouped test names (None: all)}`` for modules that have any."""
    out: dict[str, set[str] | None] = {}
    for path in sorted(tests.rglob("test_*.py")):
        names = grouped_tests(path.read_text(encoding="utf-8"))
        if names is None or names:
            out[str(path.relative_to(root))] = names
    return out
