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


def test_no_module_cycle_counting_every_import():
    """Issue 34: not even an import for the type checker or inside a function closes a
    cycle (there were three: sim drives <-> world, hardware.interfaces <-> the backends,
    urc.config -> its checks -> the backends' and the panel's checks -> urc.config)."""
    edges = graph_script.graph()
    found = [graph_script.shortest_loop(edges, c) for c in graph_script.cycles(edges)]
    assert not found, found


def test_config_imports_nothing_above_it():
    """urc.config's owners (hardware, front panel, MQTT, protocols, pointing) register
    their checks with it; it names none of them, at any depth of its code."""
    edges = graph_script.graph()
    config_row = graph_script.layer_of("urc.config")
    up = sorted(f"{m} -> {d}" for m, deps in edges.items() if graph_script.package_of(m) == "urc.config"
                for d in deps if graph_script.layer_of(graph_script.package_of(d)) > config_row)
    assert not up, up
