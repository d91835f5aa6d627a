"""The command line's ``argparse.Namespace`` stays in ``cli/``: below it, every function
takes values (docs/architecture.md), so the Python API reaches what the CLI reaches."""

from __future__ import annotations

from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "povh3d"


def namespace_mentions(root: Path) -> list[str]:
    """``file:line`` of every mention of ``Namespace`` in the modules under ``root`` outside ``cli/``."""
    found = []
    for path in sorted(root.rglob("*.py")):
        if "cli" in path.relative_to(root).parts[:1]:
            continue
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if "Namespace" in line:
                found.append(f"{path.relative_to(root)}:{n}")
    return found


def test_no_namespace_below_cli():
    assert namespace_mentions(PACKAGE) == []


def test_the_search_finds_a_namespace(tmp_path):
    # Control: a module below cli/ that takes a Namespace is found; one in cli/ is not.
    (tmp_path / "app").mkdir()
    (tmp_path / "cli").mkdir()
    (tmp_path / "app" / "key.py").write_text("import argparse\n\ndef key(args: argparse.Namespace): ...\n")
    (tmp_path / "cli" / "main.py").write_text("import argparse\nargs = argparse.Namespace()\n")
    assert namespace_mentions(tmp_path) == ["app/key.py:3"]
