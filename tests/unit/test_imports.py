"""The modules of ``lfd`` stay in layers: no import cycle, and no import the layer table of
ARCHITECTURE.md ("Layers") does not allow.

The imports are read statically (``ast``) from every module of ``python/lfd``: ``import x``
and ``from x import y`` anywhere in the file, at the top, inside functions (the lazy imports
that defer heavy libraries) and under ``if TYPE_CHECKING:``, with relative imports resolved,
and the modules imported by name, ``importlib.import_module(...)`` (the PEP 562 tables of
``lfd/__init__.py`` and ``lfd/sim/__init__.py``, the subcommands of ``lfd/cli``): a name built
from variables may be any string of the module's top-level tables (assignments), and every
such name that is a module of the package is an edge.
``from pkg import name`` is an edge to the submodule ``pkg.name`` when that is a module, else
to ``pkg``. Importing ``pkg.mod`` also runs ``pkg/__init__.py``; that implicit edge is not
counted (a package's ``__init__`` re-exporting its submodules is the normal layout).

The layer table is read from ARCHITECTURE.md, its only copy.
"""

from __future__ import annotations

import ast
import itertools
from dataclasses import dataclass
from pathlib import Path

import lfd
import pytest

ROOT = Path(lfd.__file__).resolve().parent

Graph = dict[str, dict[str, int]]
"""module -> {imported module: line of its first import in the file}."""


def _module_name(path: Path, root: Path) -> tuple[str, bool]:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    is_package = parts[-1] == "__init__"
    return ".".join(parts[:-1] if is_package else parts), is_package


def read_imports(root: Path) -> tuple[Graph, Graph]:
    """The import edges between the modules of the package at ``root``, and each module's
    imports of other top-level modules (third-party and standard: ``rerun``, ``argparse``)."""
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
    external: Graph = {}
    for name, (path, is_package) in sources.items():
        edges = graph.setdefault(name, {})
        outside = external.setdefault(name, {})
        package = name if is_package else name.rpartition(".")[0]

        def add(
            target: str,
            line: int,
            edges: dict[str, int] = edges,
            outside: dict[str, int] = outside,
            name: str = name,
        ) -> None:
            if target in sources and target != name:
                edges[target] = min(line, edges.get(target, line))
            elif (top := target.split(".")[0]) != root.name:
                outside[top] = min(line, outside.get(top, line))

        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        tables: set[str] | None = None
        for node in ast.walk(tree):
            if _is_import_module(node):
                assert isinstance(node, ast.Call)
                tables = _table_strings(tree) if tables is None else tables
                for target, exact in _imported_by_name(node, name, tables):
                    if exact or target in sources:  # a guess from the tables: lfd's own only
                        add(target, node.lineno)
            elif isinstance(node, ast.Import):
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
    return graph, external


def _is_import_module(node: ast.AST) -> bool:
    """``importlib.import_module(...)`` or ``import_module(...)``."""
    if not isinstance(node, ast.Call):
        return False
    f = node.func
    return (isinstance(f, ast.Attribute) and f.attr == "import_module") or (
        isinstance(f, ast.Name) and f.id == "import_module"
    )


def _table_strings(tree: ast.Module) -> set[str]:
    """Every string constant of a module's top-level assignments: the names and modules of its
    lazy tables (``_HOME = {"load": ".io", ...}``, ``COMMANDS = ("info", ...)``)."""
    out: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.Assign | ast.AnnAssign) and node.value is not None:
            for c in ast.walk(node.value):
                if isinstance(c, ast.Constant) and isinstance(c.value, str):
                    out.add(c.value)
    return out


def _imported_by_name(call: ast.Call, module: str, tables: set[str]) -> list[tuple[str, bool]]:
    """The module names ``importlib.import_module(name, package)`` in ``module`` may import:
    ``name`` a string, or an f-string or variable whose parts are ``__name__`` or any string of
    ``tables``; a relative name resolved against ``package`` (``__name__``: ``module``). Each
    with whether it is exact (no part taken from the tables)."""
    if not call.args:
        return []
    arg = call.args[0]
    package = call.args[1] if len(call.args) > 1 else None
    package = next((k.value for k in call.keywords if k.arg == "package"), package)
    anchor = module if isinstance(package, ast.Name) and package.id == "__name__" else None

    def values(node: ast.expr) -> list[str]:
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            return [node.value]
        if isinstance(node, ast.Name) and node.id == "__name__":
            return [module]
        if isinstance(node, ast.FormattedValue):
            return values(node.value)
        if isinstance(node, ast.JoinedStr):
            return ["".join(p) for p in itertools.product(*(values(v) for v in node.values))]
        return sorted(tables)  # a variable: any string of the tables

    exact = all(
        isinstance(n, ast.Constant) or (isinstance(n, ast.Name) and n.id == "__name__")
        for n in ast.walk(arg)
        if isinstance(n, ast.Constant | ast.Name)
    )
    out = []
    for text in values(arg):
        level = len(text) - len(text.lstrip("."))
        if level:
            if anchor is None:
                continue
            base = anchor.split(".")
            if level - 1 >= len(base):
                continue
            base = base[: len(base) - (level - 1)]
            rest = text[level:]
            text = ".".join([*base, rest]) if rest else ".".join(base)
        out.append((text, exact))
    return out


def import_graph(root: Path) -> Graph:
    """The import edges between the modules of the package at ``root``."""
    return read_imports(root)[0]


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
    # importlib.import_module of a name from a table: the subcommands of lfd.cli
    assert {"lfd.cli.segment", "lfd.cli.record", "lfd.cli.info"} <= set(graph["lfd.cli"])


def test_imports_by_name_are_read(tmp_path: Path) -> None:
    """``importlib.import_module`` with a constant, an f-string of a table's names (PEP 562
    ``__getattr__``) or ``__name__``: the modules it may import are edges, at its line, checked
    against the layers and for cycles like any other; a table's strings that are not modules
    (the public names) are not."""
    root = _write(
        tmp_path,
        {
            "pkg/__init__.py": (
                '_HOME = {"load": ".io", "view": ".viz", "Thing": ".nothing"}\n'
                "def __getattr__(name):\n"
                "    import importlib\n"
                "    return getattr(importlib.import_module(_HOME[name], __name__), name)\n"
            ),
            "pkg/errors.py": "",
            "pkg/io/__init__.py": "",
            "pkg/viz/__init__.py": "",
            "pkg/sim/__init__.py": (
                'NAMES = ("tasks",)\n'
                "def __getattr__(name):\n"
                "    from importlib import import_module\n"
                '    return import_module(f"{__name__}.{NAMES[0]}")\n'
            ),
            "pkg/sim/tasks.py": 'import importlib\nimportlib.import_module("pkg.sim")\n',
        },
    )
    graph = import_graph(root)
    assert graph["pkg"] == {"pkg.io": 4, "pkg.viz": 4}
    assert graph["pkg.sim"] == {"pkg.sim.tasks": 4}
    assert find_cycle(graph) == ["pkg.sim", "pkg.sim.tasks", "pkg.sim"]
    assert list(layer_violations(root, LAYERS).values()) == [
        "pkg (line 4) imports pkg.viz: layer api may not use layer viz",
    ]


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


ARCHITECTURE = ROOT.parents[1] / "ARCHITECTURE.md"


@dataclass(frozen=True)
class Layers:
    """ARCHITECTURE.md's layer tables."""

    modules: dict[str, list[str]]
    """layer -> its modules as paths under the package (``io/``: the package and everything
    under it; ``errors.py``: that module; ``__init__.py``: the package's own ``__init__``), in
    the table's order (lowest first)."""
    allowed: dict[str, list[str]]
    """layer -> the layers it may import (besides itself)."""
    only_in: dict[str, list[str]]
    """third-party module -> the only layers that may import it."""


def _table(text: str, header: str) -> list[list[str]]:
    """The rows (cells, stripped) of the Markdown table whose header row starts ``header``."""
    lines = text.splitlines()
    start = next((i for i, line in enumerate(lines) if line.startswith(header)), None)
    assert start is not None, f"ARCHITECTURE.md has no table {header!r}"
    rows = []
    for line in lines[start + 2 :]:  # past the header and the |---| line
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip().strip("|").split("|")])
    return rows


def _names(cell: str) -> list[str]:
    return [n.strip().strip("`") for n in cell.split(",") if n.strip()]


def read_layers(text: str) -> Layers:
    """The tables of ARCHITECTURE.md's "Layers" section."""
    layers = Layers({}, {}, {})
    for layer, modules, allowed in _table(text, "| layer | modules | may import |"):
        layers.modules[layer] = _names(modules)
        layers.allowed[layer] = [n for n in _names(allowed) if n != layer]
    for module, layer_names in _table(text, "| module | only in |"):
        layers.only_in[module.strip("`")] = _names(layer_names)
    return layers


LAYERS = read_layers(ARCHITECTURE.read_text(encoding="utf-8"))

KNOWN_VIOLATIONS: dict[tuple[str, str], str] = {}
"""Imports against the layer table, tolerated until the change that removes them lands:
(module, imported module) -> why. One that no longer occurs fails the test (delete it here)."""


def layer_of(module: str, layers: Layers) -> str | None:
    """The layer of ``module`` (a dotted name in the checked package), None if no row has it."""
    parts = module.split(".")[1:]  # below the package
    best, best_len = None, -1
    for layer, paths in layers.modules.items():
        for path in paths:
            if path.endswith("/"):
                prefix = path.rstrip("/").split("/")
                hit = parts[: len(prefix)] == prefix
            else:
                prefix = [] if path == "__init__.py" else path.removesuffix(".py").split("/")
                hit = parts == prefix
            if hit and len(prefix) > best_len:
                best, best_len = layer, len(prefix)
    return best


def layer_violations(root: Path, layers: Layers) -> dict[tuple[str, str], str]:
    """Every import of the package at ``root`` the layer tables do not allow, and every module
    in no layer: (module, imported module) -> one line saying so."""
    graph, external = read_imports(root)
    found: dict[tuple[str, str], str] = {}
    for module in sorted(graph):
        layer = layer_of(module, layers)
        if layer is None:
            found[(module, "")] = f"{module} is in no layer (ARCHITECTURE.md, Layers)"
            continue
        edges = [(line, target, layer_of(target, layers)) for target, line in graph[module].items()]
        for line, target, other in sorted(edges):
            if other is not None and other != layer and other not in layers.allowed[layer]:
                found[(module, target)] = (
                    f"{module} (line {line}) imports {target}: "
                    f"layer {layer} may not use layer {other}"
                )
        for top, line in sorted(external[module].items(), key=lambda kv: kv[1]):
            if top in layers.only_in and layer not in layers.only_in[top]:
                found[(module, top)] = (
                    f"{module} (line {line}) imports {top}: layer {layer} may not use {top} "
                    f"(only {', '.join(layers.only_in[top])})"
                )
    return found


def test_layers_are_kept() -> None:
    found = layer_violations(ROOT, LAYERS)
    new = [msg for key, msg in found.items() if key not in KNOWN_VIOLATIONS]
    assert not new, "imports against the layers of ARCHITECTURE.md:\n" + "\n".join(new)
    gone = [f"{a} -> {b}" for a, b in KNOWN_VIOLATIONS if (a, b) not in found]
    assert not gone, f"no longer violated, delete from KNOWN_VIOLATIONS: {gone}"


def test_layer_table_is_an_order() -> None:
    """Every row names known layers, all above it: the table is the order of the layers."""
    order = list(LAYERS.modules)
    assert len(order) > 10 and "cli" in order  # the table was read
    for k, layer in enumerate(order):
        assert LAYERS.modules[layer], f"layer {layer} has no modules"
        for other in LAYERS.allowed[layer]:
            assert other in order[:k], f"layer {layer} may import {other}, not a layer above it"
    for module, layer_names in LAYERS.only_in.items():
        assert layer_names and set(layer_names) <= set(order), module


@pytest.mark.parametrize(
    ("module", "forbidden"),
    [
        ("lfd.perception.record", ["lfd.segmentation", "lfd.viz"]),
        (
            "lfd.segmentation.pipeline",
            ["lfd.perception", "lfd.viz", "lfd.sim", "lfd.reproduce", "lfd.export", "lfd.cli"],
        ),
        (
            "lfd.preprocessing.pipeline",
            ["lfd.features", "lfd.segmentation", "lfd.viz", "lfd.perception", "lfd.cli"],
        ),
        ("lfd.io.reader", ["lfd.preprocessing", "lfd.segmentation", "lfd.viz", "lfd.cli"]),
        ("lfd.viz.live", ["lfd.cli", "lfd.perception"]),
        ("lfd.live", ["lfd.cli"]),
    ],
)
def test_layer_table_keeps_the_pipeline_order(module: str, forbidden: list[str]) -> None:
    """The rules of issue 28 the table must keep (a change to the table that breaks one fails
    here): record -> io -> preprocessing -> segmentation -> reproduce, viz beside."""
    layer = layer_of(module, LAYERS)
    assert layer is not None
    for target in forbidden:
        other = layer_of(target, LAYERS)
        assert other != layer and other not in LAYERS.allowed[layer], (module, target)
    assert LAYERS.only_in["rerun"] == ["viz", "cli"] and LAYERS.only_in["argparse"] == ["cli"]


def test_layer_check_finds_violations(tmp_path: Path) -> None:
    """The check on a small package: lazy, type-only and third-party imports across layers are
    reported, allowed ones are not, and a module in no layer is."""
    root = _write(
        tmp_path,
        {
            "pkg/__init__.py": "",
            "pkg/errors.py": "",
            "pkg/io/__init__.py": "from ..errors import LfdError\n",
            "pkg/segmentation/__init__.py": "",
            "pkg/segmentation/live.py": "from .. import io\n",
            "pkg/segmentation/files.py": "import argparse\nfrom ..cli import main\n",
            "pkg/viz/__init__.py": "",
            "pkg/viz/live.py": "import rerun\nfrom ..segmentation import live\n",
            "pkg/perception/__init__.py": "",
            "pkg/perception/record.py": (
                "from typing import TYPE_CHECKING\n"
                "from .. import io\n"
                "if TYPE_CHECKING:\n"
                "    from ..viz.live import LiveTimeline\n"
                "\n"
                "def record():\n"
                "    import rerun.blueprint\n"
                "    from ..segmentation.live import label_of\n"
            ),
            "pkg/cli/__init__.py": "import argparse\nfrom ..perception import record\n",
            "pkg/stray.py": "",
        },
    )
    assert list(layer_violations(root, LAYERS).values()) == [
        "pkg.perception.record (line 4) imports pkg.viz.live: layer perception may not use "
        "layer viz",
        "pkg.perception.record (line 8) imports pkg.segmentation.live: layer perception may "
        "not use layer segmentation",
        "pkg.perception.record (line 7) imports rerun: layer perception may not use rerun "
        "(only viz, cli)",
        "pkg.segmentation.files (line 2) imports pkg.cli: layer segmentation may not use layer cli",
        "pkg.segmentation.files (line 1) imports argparse: layer segmentation may not use "
        "argparse (only cli)",
        "pkg.stray is in no layer (ARCHITECTURE.md, Layers)",
    ]


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


def test_segment_command_imports_no_scipy(tmp_path: Path) -> None:
    """``lfd segment REC --json OUT`` reads, preprocesses and segments without importing scipy
    (whose submodules took 0.3-1.1 s each to import, more than the whole command now takes):
    the filters, splines and rotations are the engine's (ARCHITECTURE.md, "Heavy imports")."""
    import subprocess
    import sys

    rec = ROOT.parents[1] / "recordings" / "exp1.mcap"
    code = (
        "import sys\n"
        "from lfd.cli import main\n"
        f"assert main(['segment', {str(rec)!r}, '--json', {str(tmp_path / 's.json')!r}]) == 0\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'scipy'))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == "[]", out.stdout[-2000:]
