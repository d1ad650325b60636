"""urc's import graph, every import counted: at module level, inside functions, and in
``if TYPE_CHECKING:`` blocks (the type checker follows those, and they show what a
module depends on even where it avoids importing it at run time).

It prints the module-level cycles (strongly connected components of the module graph,
each with one shortest round trip) and the package-level edges that point up, against
the layer order below (lowest first). There are no cycles (issue 34), and
tests/test_import_graph_script.py keeps it so, with imports for the type checker and
inside functions counted, and keeps urc.config below every package it holds keys for;
.importlinter says the same to lint-imports. The upward edges still printed are issue
34's open ones (pointing's imports of cli, hardware and tracking ...).

Usage: python scripts/import_graph.py [--json]
"""

from __future__ import annotations

import ast
import collections
import json
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"

#: urc's packages (and top-level modules) from the bottom up: a package may import the
#: ones before it. One row holds peers that may not import each other's internals
#: freely but sit at the same height. (From docs/ARCHITECTURE.md, "Layers", and issue 34.)
LAYERS: list[tuple[str, ...]] = [
    ("urc", "urc.errors", "urc.angles", "urc.geodesy", "urc.clock", "urc.caps", "urc.profiles"),  # (urc: __version__)
    # the wire formats both ends speak: the protocol sessions and the bridge's dialects
    ("urc.wire",),
    ("urc.persistence",),
    # axis control is pure (law, profile, geometry: .importlinter's control-pure), so the
    # configuration may name its shapes (a keep-out zone is geometry's KeepOut)
    ("urc.control",),
    # the configuration's owners register their checks with it (urc.config.owners)
    ("urc.config",),
    # the data both processes share (Status, settings, messages, a pass program, the
    # request effects): all that the protocols and the front panel import of the rotator
    ("urc.model",),
    ("urc.pointing",),
    ("urc.hardware",),
    # calibration procedures: the one-shot steps the control process's query handlers
    # run, the long state machines the web hub runs (issue 34 item 4's split of service/)
    ("urc.procedures",),
    # the control process: the rotator, its parts and its loop
    ("urc.rotator",),
    # the two processes' link: codec, status record, client, server and supervisor
    ("urc.link",),
    ("urc.protocols",),
    # the commands the web API and MQTT share (bodies, dispatch over the link): below both
    ("urc.dispatch",),
    ("urc.status_text", "urc.api_client"),
    ("urc.tracking", "urc.frontpanel", "urc.mqtt"),
    # peaking on a signal: its sources are tracking targets, its prediction an orbit
    ("urc.peaking",),
    ("urc.servers", "urc.web", "urc.api"),
    ("urc.registrations", "urc.assembly", "urc.app", "urc.systemd_unit", "urc.control_entry"),
    ("urc.cli", "urc.cli_pointing", "urc.entry", "urc.__main__"),
    ("urc.testing",),
]

KINDS = ("module", "function", "type-checking")


def module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or \
        (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(tree: ast.AST, kind: str = "module"):
    """(node, kind) for every import statement under ``tree``: "function" once inside a
    def (it runs when called), "type-checking" inside ``if TYPE_CHECKING:`` (never runs)."""
    for child in ast.iter_child_nodes(tree):
        if isinstance(child, (ast.Import, ast.ImportFrom)):
            yield child, kind
        elif isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            yield from _imports(child, "function" if kind == "module" else kind)
        elif isinstance(child, ast.If) and _is_type_checking(child.test):
            for node in child.body:
                yield from _imports(ast.Module(body=[node], type_ignores=[]), "type-checking")
            for node in child.orelse:
                yield from _imports(ast.Module(body=[node], type_ignores=[]), kind)
        else:
            yield from _imports(child, kind)


def graph() -> dict[str, dict[str, set[str]]]:
    """{module: {imported module: kinds}}, urc's modules only. ``from p import m`` names
    the submodule p.m where there is one; an import of a.b.c counts as a.b.c alone (not
    the package __init__s it also runs)."""
    paths = {module_name(p): p for p in sorted(SRC.joinpath("urc").rglob("*.py"))}
    out: dict[str, dict[str, set[str]]] = {}
    for name, path in paths.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        deps: dict[str, set[str]] = collections.defaultdict(set)
        for node, kind in _imports(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                if node.level:
                    base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                subs = [f"{target}.{a.name}" for a in node.names if f"{target}.{a.name}" in paths]
                targets = subs + ([target] if len(subs) < len(node.names) else [])
            for t in targets:
                while t and t not in paths:  # `import urc.x.y` of a name inside a module
                    t = t.rpartition(".")[0]
                if t and t != name:
                    deps[t].add(kind)
        out[name] = dict(deps)
    return out


def cycles(edges: dict[str, set[str]] | dict[str, dict[str, set[str]]]) -> list[list[str]]:
    """Strongly connected components of more than one node (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in edges:
                    continue
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(edges[w]))))
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
                    out.append(sorted(comp))
    return out


def shortest_loop(edges: dict[str, dict[str, set[str]]], members: list[str]) -> list[str]:
    """One shortest round trip through the component's first member (breadth first)."""
    start, inside = members[0], set(members)
    prev: dict[str, str] = {}
    queue = collections.deque([start])
    while queue:
        v = queue.popleft()
        for w in sorted(edges[v]):
            if w not in inside:
                continue
            if w == start:
                path = [v]
                while path[-1] != start:
                    path.append(prev[path[-1]])
                return path[::-1] + [start]
            if w not in prev:
                prev[w] = v
                queue.append(w)
    return members


def package_of(module: str) -> str:
    parts = module.split(".")
    return ".".join(parts[:2]) if len(parts) > 1 else module


def layer_of(package: str) -> int:
    for i, row in enumerate(LAYERS):
        if package in row:
            return i
    raise KeyError(f"{package}: not in LAYERS (add it to scripts/import_graph.py)")


def upward_edges(edges: dict[str, dict[str, set[str]]]) -> list[tuple[str, str, str, list[str]]]:
    """(package, imported package, kinds, the imports) for each package-level edge whose
    target sits higher in LAYERS than its source."""
    found: dict[tuple[str, str], list[str]] = collections.defaultdict(list)
    kinds: dict[tuple[str, str], set[str]] = collections.defaultdict(set)
    for src, deps in edges.items():
        for dst, k in deps.items():
            a, b = package_of(src), package_of(dst)
            if a != b and layer_of(b) > layer_of(a):
                found[a, b].append(f"{src} -> {dst}")
                kinds[a, b] |= k
    return [(a, b, ",".join(sorted(kinds[a, b])), sorted(v)) for (a, b), v in sorted(found.items())]


def main() -> int:
    edges = graph()
    comps = cycles(edges)
    up = upward_edges(edges)
    if "--json" in sys.argv:
        print(json.dumps({"cycles": [shortest_loop(edges, c) for c in comps],
                          "upward": [{"from": a, "to": b, "kinds": k, "imports": i} for a, b, k, i in up]},
                         indent=1))
        return 0
    print(f"{len(edges)} modules, {sum(len(d) for d in edges.values())} imports between them")
    print(f"\nmodule cycles (every import counted): {len(comps)}")
    for c in comps:
        loop = shortest_loop(edges, c)
        steps = [f"{a} -> {b} ({','.join(sorted(edges[a][b]))})" for a, b in zip(loop, loop[1:])]
        print(f"  {len(c)} modules: " + "; ".join(steps))
    print(f"\npackage edges pointing up: {len(up)}")
    for a, b, k, imports in up:
        print(f"  {a} -> {b} [{k}]")
        for i in imports:
            print(f"      {i}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
