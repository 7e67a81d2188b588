"""The layer rule of ARCHITECTURE.md, checked on the sources: imports (also those inside functions) are parsed
with ``ast``; a module may import only its own layer or layers below, and the harness's modules import each
other without a circle.  The checker itself is tested on small made-up trees, so it can fail."""
from __future__ import annotations

import ast
from pathlib import Path

import networkx as nx
import pytest

ROOT = Path(__file__).resolve().parents[1]

# (layer rank, module-name prefixes); the longest matching prefix decides.  See ARCHITECTURE.md.
LAYERS = [
    (0, ("fmus.physics",)),                                       # the equations, once
    (1, ("fmus",)),                                               # FMU slaves, catalog, build, references
    (2, ("harness.errors", "harness.fmi")),                       # the FMI layer and the errors
    (3, ("harness.specs", "harness.model", "harness.results",     # the system as data, the result type
         "harness.master")),                                      # the masters and their parts
    (4, ("harness.run", "harness.ssp", "harness.osp", "harness.reporting", "harness.export",   # run, SSP, OSP,
                                                                                               # answers, export
         "harness.signals", "harness.scenarios", "harness.describe",
         "systems")),                                             # the drives as data, loaded by run.load
    (5, ("harness", "harness.studies", "harness.synthesis", "harness.__main__")),  # the facade, studies, CLI
]
OUTSIDE = ("benchmarks", "tests")        # may import anything; nothing in the layers may import them
PACKAGES = ("fmus", "harness", "systems", "benchmarks")


def layer(module: str) -> int | None:
    best = None
    for rank, prefixes in LAYERS:
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and (best is None or len(p) > len(best[1])):
                best = (rank, p)
    return None if best is None else best[0]


def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports(path: Path, root: Path, known: set[str]) -> set[str]:
    """The project modules ``path`` imports (``from pkg import name`` counts as ``pkg.name`` if that is a
    module, else as ``pkg``); relative imports are resolved."""
    me = module_name(path, root)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            names = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
        else:
            continue
        for n in names:
            while n and n not in known:
                n = n.rpartition(".")[0]
            if n and n != me:
                out.add(n)
    return out


def import_graph(root: Path) -> nx.DiGraph:
    files = [p for pkg in PACKAGES if (root / pkg).is_dir() for p in (root / pkg).rglob("*.py")
             if "docs" not in p.relative_to(root).parts]
    known = {module_name(p, root) for p in files}
    g = nx.DiGraph()
    for p in files:
        me = module_name(p, root)
        g.add_node(me)
        for other in imports(p, root, known):
            g.add_edge(me, other)
    return g


def upward_imports(g: nx.DiGraph) -> list[str]:
    bad = []
    for a, b in g.edges:
        if a.split(".")[0] in OUTSIDE:
            continue
        la, lb = layer(a), layer(b)
        if b.split(".")[0] in OUTSIDE:
            bad.append(f"{a} imports {b} (benchmarks and tests are outside the layers)")
        elif la is not None and lb is not None and lb > la:
            bad.append(f"{a} (layer {la}) imports {b} (layer {lb})")
    return sorted(bad)


def harness_circles(g: nx.DiGraph, package: str = "harness") -> list[list[str]]:
    h = g.subgraph([n for n in g if n == package or n.startswith(package + ".")])
    # a package importing its own submodules is how packages re-export; it is not a circle of concerns
    h = nx.DiGraph([(a, b) for a, b in h.edges if not b.startswith(a + ".")])
    return sorted(sorted(c) for c in nx.simple_cycles(h))


@pytest.fixture(scope="module")
def graph():
    return import_graph(ROOT)


def test_every_project_module_has_a_layer(graph):
    missing = sorted(n for n in graph if n.split(".")[0] not in OUTSIDE and layer(n) is None)
    assert missing == []


def test_no_upward_import(graph):
    assert upward_imports(graph) == []


def test_no_import_circle_among_harness_modules(graph):
    assert harness_circles(graph) == []


def test_no_import_circle_among_benchmarks(graph):
    """The driver and the coupling goals it runs both launch workers through benchmarks.launch."""
    assert harness_circles(graph, "benchmarks") == []


def _own_modules():
    """The project's own Python modules (third-party copies under tests/ are not ours to shape)."""
    return [p for pkg in PACKAGES + ("docs_tools",) for p in (ROOT / pkg).rglob("*.py")]


def test_no_module_is_over_700_lines():
    long = {str(p.relative_to(ROOT)): n for p in _own_modules()
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > 700}
    assert long == {}


def test_harness_reads_as_its_architecture():
    """Packages by concern; at most ten modules loose at harness/'s root besides __init__ and __main__."""
    loose = sorted(p.name for p in (ROOT / "harness").glob("*.py") if p.name not in ("__init__.py", "__main__.py"))
    assert len(loose) <= 10, loose
    packages = {p.name for p in (ROOT / "harness").iterdir() if (p / "__init__.py").is_file()}
    assert {"fmi", "master", "run", "ssp", "reporting", "export", "studies", "synthesis"} <= packages


def test_physics_imports_no_fmi(graph):
    """The equations live once in fmus.physics, numpy/scipy only."""
    for path in (ROOT / "fmus" / "physics").glob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        mods = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        mods |= {n.module.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module
                 and not n.level}
        assert not mods & {"fmpy", "pythonfmu", "harness"}, path.name


# -- the checker on made-up trees: it must see an upward import and a circle ------------------------------------
def _tree(tmp_path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        p = tmp_path / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return tmp_path


def test_checker_finds_an_upward_import(tmp_path):
    root = _tree(tmp_path, {"harness/__init__.py": "", "harness/model.py": "def f():\n    from harness import run\n",
                            "harness/run.py": "from harness.model import f\n", "fmus/__init__.py": "",
                            "fmus/physics/__init__.py": "", "fmus/physics/x.py": "import harness.model\n"})
    assert upward_imports(import_graph(root)) == ["fmus.physics.x (layer 0) imports harness.model (layer 3)",
                                                  "harness.model (layer 3) imports harness.run (layer 4)"]


def test_checker_finds_a_circle_and_relative_imports(tmp_path):
    root = _tree(tmp_path, {"harness/__init__.py": "", "harness/fmi/__init__.py": "",
                            "harness/fmi/fmu.py": "from .inprocess import g\n",
                            "harness/fmi/inprocess.py": "def g():\n    from harness.fmi.fmu import h\n"})
    assert harness_circles(import_graph(root)) == [["harness.fmi.fmu", "harness.fmi.inprocess"]]


def test_the_runtime_package_bundled_into_fmus_imports_itself_only_relatively():
    """Every FMU bundles fmus/{__init__,slave,units}.py and fmus/physics under its build's name (fmus_<hash>,
    fmus/build.py): an absolute ``fmus.`` import there would load the developer's package (or nothing, in a
    host without it) instead of the FMU's own copy."""
    from fmus.build import RUNTIME

    bad = []
    for name in RUNTIME:
        src = ROOT / "fmus" / name
        for f in (sorted(src.rglob("*.py")) if src.is_dir() else [src]):
            for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
                names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                         else [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level else [])
                bad += [f"{f.relative_to(ROOT)}:{node.lineno} imports {n}" for n in names
                        if n == "fmus" or n.startswith("fmus.")]
    assert not bad, bad
