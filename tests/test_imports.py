"""No import cycle between the modules of ``lfd``: the layers stay layers.

The imports are read statically (``ast``) from every module of ``python/lfd``: ``import x``
and ``from x import y`` anywhere in the file, at the top, inside functions (the lazy imports
that defer heavy libraries) and under ``if TYPE_CHECKING:``, with relative imports resolved.
``from pkg import name`` is an edge to the submodule ``pkg.name`` when that is a module, else
to ``pkg``. Importing ``pkg.mod`` also runs ``pkg/__init__.py``; that implicit edge is not
counted (a package's ``__init__`` re-exporting its submodules is the normal layout).
"""

from __future__ import annotations

import ast
import itertools
from pathlib import Path

import lfd
import pytest

ROOT = Path(lfd.__file__).resolve().parent

Graph = dict[str, dict[str, int]]
"""module -> {imported module: line of the first import}."""


def _module_name(path: Path, root: Path) -> tuple[str, bool]:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    is_package = parts[-1] == "__init__"
    return ".".join(parts[:-1] if is_package else parts), is_package


def import_graph(root: Path) -> Graph:
    """The import edges between the modules of the package at ``root``."""
    sources = {}
    for path in sorted(root.rglob("*.py")):
        name, is_package = _module_name(path, root)
        sources[name] = (path, is_package)
    # compiled modules and stubs (lfd._hmmseg) are modules too, without edges of their own
    known = set(sources)
    for path in [*root.rglob("*.pyi"), *root.rglob("*.so"), *root.rglob("*.pyd")]:
        rel = path.relative_to(root.parent)
        known.add(".".join((*rel.parts[:-1], path.name.split(".")[0])))

    graph: Graph = {}
    for name, (path, is_package) in sources.items():
        edges = graph.setdefault(name, {})
        package = name if is_package else name.rpartition(".")[0]

        def add(target: str, line: int, edges: dict[str, int] = edges, name: str = name) -> None:
            if target in sources and target != name:
                edges.setdefault(target, line)

        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    add(alias.name, node.lineno)
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")
                    base = base[: len(base) - (node.level - 1)]
                    target = ".".join([*base, *([node.module] if node.module else [])])
                else:
                    target = node.module or ""
                for alias in node.names:
                    sub = f"{target}.{alias.name}"
                    add(sub if sub in known else target, node.lineno)
    return graph


def find_cycle(graph: Graph) -> list[str] | None:
    """One import cycle ``[a, b, ..., a]`` of ``graph``, or None."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, {})):
            if state.get(nxt) == 1:
                return [*path[path.index(nxt) :], nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        path.pop()
        state[node] = 2
        return None

    for start in sorted(graph):
        if start not in state and (found := visit(start)):
            return found
    return None


def describe(graph: Graph, cycle: list[str]) -> str:
    return (
        " -> ".join(f"{a} (line {graph[a][b]})" for a, b in itertools.pairwise(cycle))
        + f" -> {cycle[-1]}"
    )


def test_no_import_cycle_in_lfd() -> None:
    graph = import_graph(ROOT)
    assert len(graph) > 90  # every module was read
    cycle = find_cycle(graph)
    assert cycle is None, f"import cycle: {describe(graph, cycle)}"


def test_graph_reads_every_kind_of_import() -> None:
    graph = import_graph(ROOT)
    # a function-local import (lazy, deferring preprocessing) is an edge
    assert "lfd.preprocessing" in graph["lfd.segmentation.templates"]
    # `from .. import _hmmseg` is an edge to the compiled module, not to the package
    assert "lfd" not in graph["lfd.segmentation.pipeline"]
    # a submodule imported by name from its package
    assert "lfd.viz.recording" in graph["lfd.viz.blueprint"]


def _write(root: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return root / "pkg"


@pytest.mark.parametrize(
    ("files", "cycle"),
    [
        (  # a lazy import inside a function closes the cycle
            {
                "pkg/__init__.py": "",
                "pkg/sub/__init__.py": "",
                "pkg/sub/a.py": "from .b import f\n",
                "pkg/sub/b.py": "def f():\n    from .a import g\n    return g\n",
            },
            ["pkg.sub.a", "pkg.sub.b", "pkg.sub.a"],
        ),
        (  # `from .. import mod`, three modules, and a type-only import
            {
                "pkg/__init__.py": "",
                "pkg/x.py": "from . import y\n",
                "pkg/y.py": "import pkg.sub.z\n",
                "pkg/sub/__init__.py": "",
                "pkg/sub/z.py": (
                    "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..x import T\n"
                ),
            },
            ["pkg.sub.z", "pkg.x", "pkg.y", "pkg.sub.z"],
        ),
        (  # a package re-exporting its modules is no cycle
            {
                "pkg/__init__.py": "from .a import f\nfrom .b import g\n",
                "pkg/a.py": "from .b import g\n",
                "pkg/b.py": "import os\ng = 1\n",
            },
            None,
        ),
    ],
)
def test_cycles_are_found(tmp_path: Path, files: dict[str, str], cycle: list[str] | None) -> None:
    graph = import_graph(_write(tmp_path, files))
    assert find_cycle(graph) == cycle


HEAVY = (
    "mujoco",
    "mink",
    "torch",
    "cv2",
    "rerun",
    "ai_edge_litert",
    "movement_primitives",
    "rosbags",
    "lerobot",
    "datasets",
    "ray",
)
"""The extras' big modules (ARCHITECTURE.md, "Heavy imports")."""


def test_plain_install_segments_without_heavy_modules(tmp_path: Path) -> None:
    """With the extras' modules blocked, lfd imports, builds its command line and segments a
    shipped recording (also through ``lfd segment``), and none of them was loaded."""
    import subprocess
    import sys

    rec = ROOT.parents[1] / "recordings" / "exp1.mcap"
    code = (
        "import sys\n"
        "class Block:  # an import of the extras' modules fails, as if not installed\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        f"        if name.split('.')[0] in {HEAVY!r}:\n"
        "            raise ModuleNotFoundError(f'blocked: {name}', name=name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "import lfd, lfd.viz\n"
        "from lfd.cli import build_parser, main\n"
        "build_parser()\n"
        f"result = lfd.segment(lfd.load({str(rec)!r}))\n"
        "assert len(result.segments) > 3, result\n"
        f"assert main(['segment', {str(rec)!r}, '--json', {str(tmp_path / 's.json')!r}]) == 0\n"
        f"loaded = [m for m in {HEAVY!r} if m in sys.modules]\n"
        "assert not loaded, loaded\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert (tmp_path / "s.json").stat().st_size > 0
