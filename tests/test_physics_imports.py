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


# The functions of fmus/physics that import SciPy, each with what calls it: studies, synthesis and references,
# never an FMU (an FMU needs nothing of its host but numpy: docs/howto/export.md).  A new SciPy import fails the
# test below until it is listed here with its caller; one an FMU calls instead gets its numpy twin (as the sector
# synthesis got fmus.physics.hybrid) or is declared in the FMU's requirements.
SCIPY_OUTSIDE_FMUS = {
    ("bed_cam", "_best_distance"): "harness.synthesis.carrier (design_cam)",
    ("bed_law", "equal_peak_runup"): "harness.synthesis.carrier",
    ("fourbar_synthesis", "_peak"): "harness.synthesis.fourbar (analyse)",
    ("fourbar_synthesis", "_best_transmission"): "harness.synthesis.fourbar (synthesise)",
    ("fourbar_synthesis", "synthesise"): "harness.synthesis.fourbar",
    ("gear_sectors", "solve_sectors"): "its least squares only (use='lsq', the synthesis studies); an FMU's "
                                       "four conditions use fmus.physics.hybrid",
    ("knife", "response"): "the knife's design check (knife.design_check, harness.synthesis)",
    ("sector_lift", "closing_braking_delta0"): "the seed's synthesis (tests, docs)",
    ("takeup", "simulate"): "harness.studies.takeup",
}


def scipy_functions(root) -> set[tuple[str, str]]:
    """(module, innermost function) of every SciPy import in fmus/physics."""
    import ast

    out = set()
    for f in sorted((root / "fmus" / "physics").glob("*.py")):
        tree = ast.parse(f.read_text(encoding="utf-8"))

        def visit(node, where):
            for child in ast.iter_child_nodes(node):
                name = child.name if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) else where
                if isinstance(child, (ast.Import, ast.ImportFrom)):
                    mods = [a.name for a in child.names] if isinstance(child, ast.Import) else [child.module or ""]
                    if any(m.split(".")[0] == "scipy" for m in mods):
                        out.add((f.stem, where))
                visit(child, name)

        visit(tree, "<module>")
    return out


def test_scipy_is_imported_only_where_no_fmu_calls():
    assert scipy_functions(ROOT) == set(SCIPY_OUTSIDE_FMUS)


def test_a_new_scipy_import_is_found(tmp_path):
    root = _tree(tmp_path, {"fmus/physics/x.py": "import numpy\n\ndef step(y):\n    from scipy.optimize import brentq\n"})
    assert scipy_functions(root) == {("x", "step")}
