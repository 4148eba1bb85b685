"""The library does not know the command line: no string outside ``cli/`` names one of its options.

Errors and warnings name config fields (``{rate_hz}``); the command line writes them as its options
(:mod:`chronofuse.cli.flags`). Docstrings may say which command calls a function; messages may not.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import chronofuse
from chronofuse.cli.flags import FLAGS

PACKAGE = Path(chronofuse.__file__).resolve().parent
_FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")


def _docstrings(tree: ast.AST) -> set[int]:
    ids = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
                ids.add(id(first.value))
    return ids


def flags_in_library_strings() -> list[str]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if "cli" in path.relative_to(PACKAGE).parts:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        skip = _docstrings(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
                for flag in _FLAG.findall(node.value):
                    found.append(f"{path.relative_to(PACKAGE)}:{node.lineno}: {flag}")
    return found


def test_no_library_string_names_a_command_line_option():
    assert flags_in_library_strings() == []


def test_the_scan_finds_an_option_in_a_message(tmp_path):
    tree = ast.parse('def f():\n    """Docs may say --rate."""\n    raise ValueError(f"give --rate {x}")\n')
    skip = _docstrings(tree)
    hits = [flag for node in ast.walk(tree) if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and id(node) not in skip for flag in _FLAG.findall(node.value)]
    assert hits == ["--rate"] and "--rate" in FLAGS
