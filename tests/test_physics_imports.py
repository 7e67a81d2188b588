"""The equations' modules import each other without a circle (issue 30): fmus.physics is the bottom layer, and
a circle inside it (it was laws -> bed_law -> cam_rocker -> laws) makes the import order decide which module
is half-initialised when another reads it.  The graph is the one tests/test_architecture.py parses (imports
inside functions count); the check is tried on a made-up tree, so it can fail."""
from __future__ import annotations

import networkx as nx
from test_architecture import ROOT, _tree, import_graph


def physics_circles(g: nx.DiGraph) -> list[list[str]]:
    sub = g.subgraph([n for n in g if n.startswith("fmus.physics.")])
    return sorted(sorted(c) for c in nx.simple_cycles(sub))


def test_no_import_circle_among_physics_modules():
    assert physics_circles(import_graph(ROOT)) == []


def test_checker_finds_a_circle_through_a_function_level_import(tmp_path):
    root = _tree(tmp_path, {"fmus/__init__.py": "", "fmus/physics/__init__.py": "",
                            "fmus/physics/a.py": "from .b import f\n",
                            "fmus/physics/b.py": "def f():\n    from .c import g\n",
                            "fmus/physics/c.py": "from . import a\n"})
    assert physics_circles(import_graph(root)) == [["fmus.physics.a", "fmus.physics.b", "fmus.physics.c"]]
