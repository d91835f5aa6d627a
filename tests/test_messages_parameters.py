"""Libraries name parameters, not flags (docs/architecture.md, Errors): a message raised or warned
below ``povh3d/cli/`` marks a parameter with ``errors.param``; ``str(error)`` shows the name
(``lens_rotation``) and the command line the flag (``--lens-rotation``).  No ``--flag`` is written
in a message below the command line."""

from __future__ import annotations

import ast
import re
import warnings
from pathlib import Path

import pytest

from povh3d.cli import flags
from povh3d.cli.main import build_parser
from povh3d.errors import ConfigError, Povh3dWarning, param, plain, raw_message, warn
from povh3d.geometry.lens_array import lens_rotation

PACKAGE = Path(__file__).resolve().parents[1] / "povh3d"
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")
_CALLS = {"warn", "MissingExtra", "PovrayNotFound", "PovrayTimeout", "RenderInterrupted"}
# Strings that are command lines of other programs, not messages: (module, the string).
ARGV = {("povray/process.py", "--version"), ("commands/bench.py", "--method"),
        ("commands/bench.py", "--quality"), ("commands/bench.py", "--no-cache")}


def _called(func: ast.expr) -> str:
    return func.id if isinstance(func, ast.Name) else func.attr if isinstance(func, ast.Attribute) else ""


def _message_parts(tree: ast.AST):
    """The expressions that make a message: a ``raise``'s, the arguments of ``warn`` and of an
    error or warning class, and strings appended to a record's warnings."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Raise) and node.exc is not None:
            yield node.exc
        elif isinstance(node, ast.Call):
            name = _called(node.func)
            if name in _CALLS or name.endswith(("Error", "Warning")):
                yield from node.args
                yield from (k.value for k in node.keywords)
            elif name in ("append", "extend", "insert") and isinstance(node.func, ast.Attribute):
                target = node.func.value
                if (isinstance(target, ast.Subscript) and isinstance(target.slice, ast.Constant)
                        and target.slice.value == "warnings") or \
                        (isinstance(target, ast.Name) and "warning" in target.id):
                    yield from node.args


def flags_in_messages(source: str) -> list[tuple[int, str]]:
    """``(line, flag)`` of each ``--flag`` in a string constant (f-string parts too) of a message."""
    found = []
    for part in _message_parts(ast.parse(source)):
        for node in ast.walk(part):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                found += [(node.lineno, flag) for flag in FLAG.findall(node.value)]
    return sorted(set(found))   # a raise's error class is also a call: each once


def flags_in_strings(source: str, module: str) -> list[tuple[int, str]]:
    """``(line, flag)`` of each ``--flag`` in any string constant but a docstring (a message built
    in a variable or a table, then raised) and the command lines of other programs (``ARGV``)."""
    tree = ast.parse(source)
    docstrings = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body \
                and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant):
            docstrings.add(id(node.body[0].value))
    return sorted({(node.lineno, flag) for node in ast.walk(tree)
                   if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings
                   and (module, node.value) not in ARGV for flag in FLAG.findall(node.value)})


def _library_modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        module = path.relative_to(PACKAGE).as_posix()
        if not module.startswith("cli/"):
            yield module, path.read_text(encoding="utf-8")


PLANTED = '''
def check(lenses):
    """Docstrings document the command line: --lenses 6x4 is fine here."""
    if lenses is None:
        raise ConfigError("give the lens count, e.g. use --lenses 6x4")
    if lenses == 0:
        warn(f"{lenses} lenses; give --lens-rotation 0")
    record["warnings"].append("a note naming --ppl")
    return "--not-a-message-but-a-string"
'''


def test_the_scanner_finds_flags_in_messages():   # negative control for the tests below
    assert [flag for _, flag in flags_in_messages(PLANTED)] == ["--lenses", "--lens-rotation", "--ppl"]
    assert [flag for _, flag in flags_in_strings(PLANTED, "x.py")] == \
        ["--lenses", "--lens-rotation", "--ppl", "--not-a-message-but-a-string"]
    assert flags_in_messages("raise ConfigError(f\"use {param('lenses')} 6x4\")") == []
    assert flags_in_strings('"--version"', "povray/process.py") == []


def test_no_message_below_the_command_line_names_a_flag():
    found = [f"{module}:{line}: {flag}" for module, source in _library_modules()
             for line, flag in flags_in_messages(source)]
    assert not found, "name the parameter with errors.param, not the flag:\n" + "\n".join(found)


def test_no_string_below_the_command_line_names_a_flag():
    found = [f"{module}:{line}: {flag}" for module, source in _library_modules()
             for line, flag in flags_in_strings(source, module)]
    assert not found, "name the parameter with errors.param, not the flag:\n" + "\n".join(found)


def test_python_reads_the_parameter_name():
    with pytest.raises(ConfigError) as caught:
        lens_rotation(100)
    assert str(caught.value).endswith("(lens_rotation)") and "--" not in str(caught.value)
    assert param("lens_rotation") in caught.value.args[0] == raw_message(caught.value)   # the mark kept
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        warn(f"give {param('ppl')} 8")
    assert said[0].category is Povh3dWarning and str(said[0].message) == "give ppl 8"
    assert plain({"warnings": [f"use {param('crop')} off"], "n": 1}) == {"warnings": ["use crop off"], "n": 1}


def test_the_flag_of_a_parameter():
    flags.learn(build_parser(), "render")
    assert flags.as_flag("lens_rotation") == "--lens-rotation"     # the option spelled like the name
    assert flags.as_flag("shading") == "--flat"                    # a dest with another option
    assert flags.as_flag("lenses_x") == flags.as_flag("lenses_y") == "--lenses"   # the table
    assert flags.as_flag("placement.center") == "--display-center"
    assert flags.as_flag("no_such_name") == "--no-such-name"       # unknown: the name with dashes
    assert flags.flags(ConfigError(f"bad {param('ppl_out')}")) == "bad --ppl-out"


def test_the_command_line_shows_the_flag(cli):
    result = cli("info", "--preset", "demo", "--lens-rotation", "100")
    assert result.code == 2
    assert result.err.strip() == ("povh3d: error: the lens rotation must be a number of degrees within "
                                  "(-45, 45], got 100.0; a lattice turned further is the same lattice "
                                  "turned less (--lens-rotation)")
    assert "\ue000" not in result.err and "\ue001" not in result.err


def test_the_command_line_shows_a_warnings_flag(capsys):
    from povh3d.cli.options import warn as print_warnings

    flags.learn(build_parser(), "render")
    print_warnings([f"the scene moved; give {param('placement.up')} 0,1,0"])
    assert capsys.readouterr().err.strip() == "povh3d: warning: the scene moved; give --display-up 0,1,0"


def test_a_sidecar_holds_names_not_marks(tmp_path):
    import json

    from povh3d.image.io import write_sidecar

    record = {"warnings": [f"give {param('ppl')} 8"], "crop": {"reason": f"{param('crop')} off"}}
    assert param("ppl") in record["warnings"][0]   # negative control: the record itself holds the marks
    side = write_sidecar(tmp_path / "a.png", record)
    assert json.loads(side.read_text()) == {"warnings": ["give ppl 8"], "crop": {"reason": "crop off"}}


def _marked_names() -> dict[str, list[str]]:
    """Each name a library message marks with ``param("...")`` -> where (``module:line``)."""
    found: dict[str, list[str]] = {}
    for module, source in _library_modules():
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.Call) and _called(node.func) == "param" and node.args \
                    and isinstance(node.args[0], ast.Constant):
                found.setdefault(node.args[0].value, []).append(f"{module}:{node.lineno}")
    return found


def _python_names() -> set[str]:
    """The names a Python caller passes: the parameters of povh3d's functions and classes, the fields
    of the options it takes (``RenderRequest``, ``RenderSettings``, ``placement.*``, a preset's fields,
    ``mapping_options``, ``method_options``) and the parameters of the file commands (``povh3d.commands``)."""
    import dataclasses
    import importlib
    import inspect
    import pkgutil

    import povh3d
    from povh3d.display import presets
    from povh3d.display.mappings import MappingOptions
    from povh3d.renderer.methods.registry import METHODS
    from povh3d.renderer.placement.pose import PlacementOptions

    def parameters(obj) -> set[str]:
        try:
            return set(inspect.signature(obj).parameters)
        except (TypeError, ValueError):
            return set()

    names: set[str] = set(presets.FIELDS) | {f.name for f in dataclasses.fields(MappingOptions)}
    names |= {f"placement.{f.name}" for f in dataclasses.fields(PlacementOptions)}
    names |= {key for method in METHODS.values() for key in method.options}
    from povh3d.renderer.content.convert_mesh import convert_mesh   # povh3d.convert_mesh(**options)

    objects = [convert_mesh, *(getattr(povh3d, name) for name in povh3d.__dir__())]
    import povh3d.commands as commands
    for info in pkgutil.iter_modules(commands.__path__):
        module = importlib.import_module(f"povh3d.commands.{info.name}")
        objects += [v for v in vars(module).values() if inspect.isfunction(v) and v.__module__ == module.__name__]
    for obj in objects:
        if callable(obj):
            names |= parameters(obj)
        if dataclasses.is_dataclass(obj):
            names |= {f.name for f in dataclasses.fields(obj)}
    return names


#: Marked names no Python call takes, each with why: text a file command parses, a setting of the
#: process, or a name a flag table cannot tell apart.
NOT_PYTHON = {
    "panel_size": "map_file's panel; 'panel' is the preset field (--panel), so the flag table keeps --panel-size",
    "slant_range": "the text of --slant-range that commands.moire parses (Python passes slants_deg)",
    "max_memory": "POVH3D_MAX_MEMORY / --max-memory: the process's memory budget, no function's parameter",
    "sweep": "the text of --sweep that the replay command parses into eyes",
}


def test_the_names_in_messages_are_the_python_names():
    marked, python = _marked_names(), _python_names()
    assert "lens_rotation" in marked and "lens_rotation" in python and "no_such_name" not in python   # control
    wrong = {name: where[:3] for name, where in marked.items() if name not in python and name not in NOT_PYTHON}
    assert not wrong, f"a message names a parameter no Python call takes (use the Python name): {wrong}"
    assert set(NOT_PYTHON) <= set(marked), "NOT_PYTHON lists a name no message marks any more"
