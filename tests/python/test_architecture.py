"""The house's import rules (issue 33 item 3): one table in ``docs/architecture.md`` ("Layers: who may import whom")
states the packages, their floors and what each may import; this test reads that table, builds the import graph of
``python/tendyn`` from the sources with ``ast`` (module-level and function-level imports alike) and fails on any
import the table forbids and on any circle between two modules.

Nothing of tendyn is imported or run: the graph is read from the text of the sources, so a lazy import inside a
function counts as much as one at the top of a file."""

from __future__ import annotations

import ast
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PACKAGE = REPO / "python" / "tendyn"
TABLE_TITLE = "## Layers: who may import whom"


# ---- the table ------------------------------------------------------------------------------------------------

def read_layers(text: str) -> dict[str, tuple[int, frozenset[str]]]:
    """``{package: (floor, packages it may import)}`` from the markdown table under :data:`TABLE_TITLE`."""
    section = text.split(TABLE_TITLE, 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 3 or not cells[0].isdigit():
            continue
        name = re.fullmatch(r"`([\w.]+)`", cells[1])
        assert name, f"the package cell {cells[1]!r} is not one `name`"
        assert name.group(1) not in rows, f"{name.group(1)} has two rows"
        rows[name.group(1)] = (int(cells[0]), frozenset(re.findall(r"`([\w.]+)`", cells[2])))
    assert rows, f"no table under {TABLE_TITLE!r} in docs/architecture.md"
    return rows


def layers() -> dict[str, tuple[int, frozenset[str]]]:
    return read_layers((REPO / "docs" / "architecture.md").read_text(encoding="utf-8"))


# ---- the graph --------------------------------------------------------------------------------------------------

def modules(root: Path = PACKAGE) -> dict[str, Path]:
    """Every module of the package by dotted name (``tendyn.device.compiled``; a face is ``tendyn.device``)."""
    out = {}
    for f in sorted(root.rglob("*.py")):
        parts = list(f.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = f
    return out


def _resolve(target: str, known) -> str | None:
    """The longest known module that ``target`` names (``tendyn.io.logs.make_log`` → ``tendyn.io.logs``); a name
    of the package that is no source file (the compiled ``tendyn._core``) stands for itself."""
    parts = target.split(".")
    if parts[0] != "tendyn":
        return None
    while parts:
        if ".".join(parts) in known:
            return ".".join(parts)
        if len(parts) == 2:             # tendyn.<name> without a source: the compiled core
            return ".".join(parts)
        parts = parts[:-1]
    return None


def imports_of(name: str, path: Path, known) -> list[tuple[str, int]]:
    """``[(module imported, line)]`` of one module: every ``import`` / ``from … import`` anywhere in the file.

    ``from P import m`` where ``P.m`` is a module is an edge to ``P.m`` only (Python runs the face ``P`` first for
    every module of ``P``, so that edge would be everyone's); ``from P import x`` of any other name is an edge to
    ``P``'s face."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = ".".join(package[: len(package) - node.level + 1] + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            subs = [f"{base}.{a.name}" for a in node.names]
            targets = [s for s in subs if s in known]
            if len(targets) < len(subs):
                targets.append(base)
        else:
            continue
        for t in targets:
            r = _resolve(t, known)
            if r is not None and r != name:
                out.append((r, node.lineno))
    return out


def import_graph(root: Path = PACKAGE) -> dict[str, dict[str, int]]:
    """``{module: {module it imports: first line}}``."""
    known = modules(root)
    graph = {}
    for name, path in known.items():
        edges: dict[str, int] = {}
        for target, line in imports_of(name, path, known):
            edges.setdefault(target, line)
        graph[name] = edges
    return graph


def circles(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in graph:
                    continue
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    found.append(sorted(comp))
    return sorted(found)


def package_of(module: str) -> str:
    """The row of the table a module belongs to: ``tendyn.device.load`` → ``device``; the face → ``tendyn``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "tendyn"


def forbidden(graph: dict[str, dict[str, int]], table) -> list[str]:
    """Every import the table does not allow, as ``module:line -> module``."""
    leaves = {p for p, (floor, _) in table.items() if floor == 0}
    bad = []
    for src, edges in sorted(graph.items()):
        here = package_of(src)
        if here not in table:
            bad.append(f"{src}: package {here!r} has no row in the table")
            continue
        for dst, line in sorted(edges.items()):
            there = package_of(dst)
            if there == here or there in leaves or there in table[here][1]:
                continue
            bad.append(f"{src}:{line} -> {dst} ({here} may not import {there})")
    return bad


# ---- the tests ----------------------------------------------------------------------------------------------------

def climbs(table) -> list[str]:
    """Every import the table allows towards a package without a row or not on a lower floor."""
    bad = []
    for pkg, (floor, allowed) in sorted(table.items()):
        for other in sorted(allowed):
            if other not in table:
                bad.append(f"{pkg} may import {other}, which has no row")
            elif table[other][0] >= floor:
                bad.append(f"{pkg} (floor {floor}) may import {other} (floor {table[other][0]})")
    return bad


def test_the_table_flows_one_way():
    """Every package the table lets a package import has a row and stands on a lower floor: the table itself
    has no circle and no climb back up."""
    assert not climbs(layers())


def test_every_package_has_a_row():
    table = layers()
    missing = sorted({package_of(m) for m in modules()} - set(table))
    assert not missing, f"packages of python/tendyn without a row in docs/architecture.md: {missing}"


def test_no_forbidden_import():
    bad = forbidden(import_graph(), layers())
    assert not bad, "imports the table of docs/architecture.md forbids:\n" + "\n".join(bad)


def test_no_import_circle():
    found = circles(import_graph())
    assert not found, "import circles between modules:\n" + "\n".join(" <-> ".join(c) for c in found)


# ---- the test can fail ----------------------------------------------------------------------------------------------

def _plant(tmp_path: Path, files: dict[str, str]) -> Path:
    root = tmp_path / "tendyn"
    for rel, text in files.items():
        f = root / rel
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_text(text, encoding="utf-8")
    return root


def test_a_planted_circle_is_found(tmp_path):
    """Two modules that import each other (one of them inside a function) are a circle; a module importing a
    sibling through the package face is one too; the same tree without the back edge is not."""
    root = _plant(tmp_path, {
        "__init__.py": "",
        "a/__init__.py": "from .x import X\n",
        "a/x.py": "X = 1\ndef f():\n    from tendyn.a.y import Y\n    return Y\n",
        "a/y.py": "from tendyn.a import x\nY = 2\n",
        "b/__init__.py": "from .p import P\n",
        "b/p.py": "from tendyn.b import Q\nP = 1\n",
        "b/q.py": "Q = 2\n",
    })
    graph = import_graph(root)
    assert ["tendyn.a.x", "tendyn.a.y"] in circles(graph)
    assert ["tendyn.b", "tendyn.b.p"] in circles(graph)
    (root / "a" / "x.py").write_text("X = 1\n", encoding="utf-8")
    assert ["tendyn.a.x", "tendyn.a.y"] not in circles(import_graph(root))


def test_a_planted_forbidden_import_is_found(tmp_path):
    """A lower floor importing a higher one (here a function-level import of the CLI) is refused by the table;
    the table's own rows refuse a climb."""
    root = _plant(tmp_path, {"__init__.py": "", "sim/__init__.py": "",
                             "sim/run.py": "def f():\n    from tendyn.cli import _load\n",
                             "cli.py": "from tendyn.sim import run\n"})
    bad = forbidden(import_graph(root), layers())
    assert any("tendyn.sim.run:2 -> tendyn.cli" in b for b in bad), bad
    assert not any(b.startswith("tendyn.cli") for b in bad), bad
    table = read_layers(f"{TABLE_TITLE}\n\n| floor | package | may import |\n|---|---|---|\n"
                        "| 1 | `io` | `sim` |\n| 2 | `sim` | `io` |\n")
    assert table["io"] == (1, frozenset({"sim"}))
    assert climbs(table) == ["io (floor 1) may import sim (floor 2)"]
