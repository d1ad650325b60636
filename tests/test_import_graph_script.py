"""scripts/import_graph.py: every import is counted, and labelled by when it runs."""

import ast
import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "import_graph.py"
spec = importlib.util.spec_from_file_location("import_graph", SCRIPT)
graph_script = importlib.util.module_from_spec(spec)
spec.loader.exec_module(graph_script)

SOURCE = """
import a
from typing import TYPE_CHECKING
if TYPE_CHECKING:
    import b
else:
    import c
def f():
    import d
    if TYPE_CHECKING:
        import e
"""


def test_imports_are_labelled_by_when_they_run():
    found = {getattr(n, "module", None) or n.names[0].name: kind
             for n, kind in graph_script._imports(ast.parse(SOURCE))}
    assert found == {"a": "module", "typing": "module", "b": "type-checking", "c": "module",
                     "d": "function", "e": "type-checking"}


def test_a_cycle_and_its_shortest_round_trip():
    edges = {"a": {"b": {"module"}}, "b": {"c": {"module"}, "a": {"function"}}, "c": {"a": {"module"}},
             "d": {"a": {"module"}}}
    assert graph_script.cycles(edges) == [["a", "b", "c"]]
    assert graph_script.shortest_loop(edges, ["a", "b", "c"]) == ["a", "b", "a"]


def test_every_urc_package_has_a_layer():
    for module in graph_script.graph():
        graph_script.layer_of(graph_script.package_of(module))
