"""The modules and functions of ``lfd`` stay within the sizes of ARCHITECTURE.md ("Sizes"):
lines per module and per function (methods and nested functions too) read with ``ast``, and
ruff's statement and complexity limits (pyproject.toml) the same numbers as the table's.

The table is read from ARCHITECTURE.md, its only copy.
"""

from __future__ import annotations

import ast
import tomllib
from pathlib import Path

import lfd

ROOT = Path(lfd.__file__).resolve().parent
REPO = ROOT.parents[1]
ARCHITECTURE = REPO / "ARCHITECTURE.md"


def read_limits(text: str) -> dict[str, int]:
    """The "Sizes" table of ARCHITECTURE.md: ``{"module lines", "function lines",
    "statements", "complexity"}`` -> its number."""
    lines = text.splitlines()
    start = next(
        (i for i, line in enumerate(lines) if line.startswith("| limit | at most |")), None
    )
    assert start is not None, "ARCHITECTURE.md has no Sizes table (| limit | at most |)"
    keys = {
        "lines of a module": "module lines",
        "lines of a function": "function lines",
        "statements of a function": "statements",
        "cyclomatic complexity of a function": "complexity",
    }
    limits: dict[str, int] = {}
    for line in lines[start + 2 :]:  # past the header and the |---| line
        if not line.startswith("|"):
            break
        what, most = (cell.strip() for cell in line.strip().strip("|").split("|"))
        key = next((k for label, k in keys.items() if what.startswith(label)), None)
        assert key is not None, f"unknown row of the Sizes table: {what!r}"
        limits[key] = int(most)
    assert set(limits) == set(keys.values()), limits
    return limits


LIMITS = read_limits(ARCHITECTURE.read_text(encoding="utf-8"))


def function_sizes(tree: ast.Module) -> dict[str, int]:
    """Lines (``def`` line to last line) of every function, method and nested function of a
    module, by qualified name (``Class.method``, ``outer.inner``)."""
    out: dict[str, int] = {}

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                name = f"{prefix}{child.name}"
                if not isinstance(child, ast.ClassDef):
                    assert child.end_lineno is not None
                    out[name] = child.end_lineno - child.lineno + 1
                visit(child, f"{name}.")
            else:
                visit(child, prefix)

    visit(tree, "")
    return out


def oversized(root: Path, limits: dict[str, int]) -> dict[str, str]:
    """Every module and function of the package at ``root`` over the limits: its key
    (``path`` or ``path:function``, the path under ``root``) -> one line saying so."""
    found: dict[str, str] = {}
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        text = path.read_text(encoding="utf-8")
        n = len(text.splitlines())
        if n > limits["module lines"]:
            found[rel] = f"{rel}: {n} lines (at most {limits['module lines']})"
        for name, size in function_sizes(ast.parse(text, str(path))).items():
            if size > limits["function lines"]:
                found[f"{rel}:{name}"] = (
                    f"{rel}:{name}: {size} lines (at most {limits['function lines']})"
                )
    return found


def test_modules_and_functions_are_within_the_sizes() -> None:
    found = oversized(ROOT, LIMITS)
    assert not found, "over the sizes of ARCHITECTURE.md:\n" + "\n".join(found.values())


def test_ruff_checks_the_tables_numbers() -> None:
    """pyproject.toml selects ruff's statement and complexity rules with the table's limits."""
    ruff = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["ruff"]
    lint = ruff["lint"]
    assert {"C901", "PLR0915"} <= set(lint["select"])
    assert lint["pylint"]["max-statements"] == LIMITS["statements"]
    assert lint["mccabe"]["max-complexity"] == LIMITS["complexity"]


def test_sizes_are_measured(tmp_path: Path) -> None:
    """Lines of a module, of functions, methods and nested functions (docstring included),
    on a small package."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    body = "\n".join(f"    x{i} = {i}" for i in range(6))
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text(
        "def short():\n    return 1\n\n\n"
        f'def long():\n    """Doc."""\n{body}\n\n'
        f"    def inner():\n{body.replace('    ', '        ')}\n\n"
        f"class C:\n    def method(self):\n{body.replace('    ', '        ')}\n"
    )
    (pkg / "b.py").write_text("\n".join(f"y{i} = {i}" for i in range(12)) + "\n")
    tree = ast.parse((pkg / "a.py").read_text())
    assert function_sizes(tree) == {"short": 2, "long": 16, "long.inner": 7, "C.method": 7}
    limits = {"module lines": 11, "function lines": 7, "statements": 0, "complexity": 0}
    assert oversized(pkg, limits) == {
        "a.py": "a.py: 29 lines (at most 11)",
        "a.py:long": "a.py:long: 16 lines (at most 7)",
        "b.py": "b.py: 12 lines (at most 11)",
    }
