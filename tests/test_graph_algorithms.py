"""harness.master.graph's own graph algorithms against networkx as the oracle (random digraphs with self-loops and
cycles), the system-level orders against their former networkx formulation, and the run path without
networkx."""
from __future__ import annotations

import subprocess
import sys
from types import SimpleNamespace

import networkx as nx
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from harness.master import coupling, graph

MAX_NODES = 40


@st.composite
def digraphs(draw, acyclic: bool = False):
    """The same random digraph twice, as graph.Digraph and nx.DiGraph, built by the same calls: some nodes
    first, then the edges (which add their new ends in order), then the remaining nodes.  Node labels are a
    shuffled range, so the insertion order differs from the labels' order."""
    n = draw(st.integers(0, MAX_NODES))
    labels = draw(st.permutations(range(n)))
    pairs = draw(st.lists(st.tuples(st.integers(0, max(n - 1, 0)), st.integers(0, max(n - 1, 0))),
                          max_size=3 * n)) if n else []
    if acyclic:  # every edge from a lower to a higher rank of a random ranking: no cycle
        rank = draw(st.permutations(range(n)))
        pairs = [(a, b) for a, b in pairs if rank[a] < rank[b]]
    early = draw(st.integers(0, n))
    ours, theirs = graph.Digraph(), nx.DiGraph()
    for k in labels[:early]:
        ours.add_node(k)
        theirs.add_node(k)
    for a, b in pairs:
        ours.add_edge(labels[a], labels[b])
        theirs.add_edge(labels[a], labels[b])
    for k in labels[early:]:
        ours.add_node(k)
        theirs.add_node(k)
    return ours, theirs


@settings(max_examples=300, deadline=None)
@given(digraphs())
def test_digraph_keeps_networkx_node_order_and_edges(pair):
    ours, theirs = pair
    assert ours.nodes == list(theirs.nodes)
    assert sorted(ours.edges) == sorted(theirs.edges)
    assert ours.in_degrees() == dict(theirs.in_degree())


@settings(max_examples=300, deadline=None)
@given(digraphs())
def test_strongly_connected_components_are_networkx_s_in_reverse_topological_order(pair):
    ours, theirs = pair
    components = graph.strongly_connected_components(ours)
    assert sorted(map(sorted, components)) == sorted(map(sorted, nx.strongly_connected_components(theirs)))
    position = {n: k for k, n in enumerate(theirs.nodes)}
    assert all(c == sorted(c, key=position.__getitem__) for c in components)
    where = {n: k for k, c in enumerate(components) for n in c}
    assert all(where[a] >= where[b] for a, b in theirs.edges)


@settings(max_examples=300, deadline=None)
@given(digraphs())
def test_condensation_order_is_networkx_s_lexicographical_order_of_the_condensation(pair):
    ours, theirs = pair
    got = graph.condensation_order(ours)
    position = {n: k for k, n in enumerate(theirs.nodes)}
    cond = nx.condensation(theirs)
    members = {c: sorted(cond.nodes[c]["members"], key=position.__getitem__) for c in cond}
    want = [members[c] for c in nx.lexicographical_topological_sort(cond, key=lambda c: position[members[c][0]])]
    assert got == want
    where = {n: k for k, c in enumerate(got) for n in c}
    assert all(where[a] <= where[b] for a, b in theirs.edges)


KEYS = {"none": None, "mod3": lambda n: n % 3, "constant": lambda n: 0, "negated": lambda n: -n}


@settings(max_examples=300, deadline=None)
@given(digraphs(acyclic=True), st.sampled_from(sorted(KEYS)))
def test_lexicographical_topological_sort_is_networkx_s_on_acyclic_graphs(pair, key):
    """Keys with many ties (mod3, constant) check the tie-break by insertion order."""
    ours, theirs = pair
    assert graph.lexicographical_topological_sort(ours, key=KEYS[key]) == \
        list(nx.lexicographical_topological_sort(theirs, key=KEYS[key]))


@settings(max_examples=300, deadline=None)
@given(digraphs(), st.sampled_from(sorted(KEYS)))
def test_lexicographical_topological_sort_refuses_a_cycle_as_networkx_does(pair, key):
    ours, theirs = pair
    try:
        want = list(nx.lexicographical_topological_sort(theirs, key=KEYS[key]))
    except nx.NetworkXUnfeasible:
        with pytest.raises(graph.CycleError, match="cycle") as err:
            graph.lexicographical_topological_sort(ours, key=KEYS[key])
        cyclic = {n for c in nx.strongly_connected_components(theirs) if len(c) > 1 for n in c}
        cyclic |= {a for a, b in theirs.edges if a == b}
        assert cyclic <= set(err.value.nodes)
    else:
        assert graph.lexicographical_topological_sort(ours, key=KEYS[key]) == want


def test_a_long_chain_and_a_long_cycle_need_no_recursion():
    n = 3 * sys.getrecursionlimit()
    chain = graph.Digraph(range(n), ((k, k + 1) for k in range(n - 1)))
    assert len(graph.strongly_connected_components(chain)) == n
    assert graph.condensation_order(chain) == [[k] for k in range(n)]
    chain.add_edge(n - 1, 0)
    assert graph.strongly_connected_components(chain) == [list(range(n))]


# -- the system-level functions against their former networkx formulation ---------------------------------

def _old_algebraic_loops(connections, mds):
    g = nx.DiGraph()
    for inst, md in mds.items():
        for out, deps in graph.direct_dependencies(md).items():
            g.add_node(f"{inst}.{out}")
            for d in deps:
                g.add_edge(f"{inst}.{d}", f"{inst}.{out}")
    for c in connections:
        g.add_edge(c.source, c.target)
    return sorted(sorted(c) for c in nx.strongly_connected_components(g) if len(c) > 1)


def _old_evaluation_order(connections, mds):
    ft_inputs = {inst: {d for deps in graph.direct_dependencies(md).values() for d in deps}
                 for inst, md in mds.items()}
    g = nx.DiGraph()
    g.add_nodes_from(mds)
    for c in connections:
        si, _ = c.source.split(".", 1)
        ti, tv = c.target.split(".", 1)
        if tv in ft_inputs[ti]:
            g.add_edge(si, ti)
    order = list(mds)
    cond = nx.condensation(g)
    return [sorted(cond.nodes[n]["members"], key=order.index)
            for n in nx.lexicographical_topological_sort(
                cond, key=lambda n: min(order.index(m) for m in cond.nodes[n]["members"]))]


def _old_stepping_order(connections, mds):
    order = list(mds)
    g = nx.DiGraph()
    g.add_nodes_from(order)
    for c in connections:
        g.add_edge(c.source.split(".", 1)[0], c.target.split(".", 1)[0])
    rank = {inst: k for k, group in enumerate(_old_evaluation_order(connections, mds)) for inst in group}
    no_ft = {inst: not any(graph.direct_dependencies(md).values()) for inst, md in mds.items()}
    cond = nx.condensation(g)
    result = []
    for n in nx.lexicographical_topological_sort(
            cond, key=lambda n: min(order.index(m) for m in cond.nodes[n]["members"])):
        result.extend(sorted(cond.nodes[n]["members"], key=lambda m: (not no_ft[m], rank[m], order.index(m))))
    return result


def _model(name, n_in, n_out, deps):
    """A stand-in model description: inputs u0.., outputs y0..; ``deps[k]`` None (undeclared) or the
    indices of the inputs output k depends on."""
    inputs = [SimpleNamespace(name=f"u{k}", causality="input") for k in range(n_in)]
    outputs = [SimpleNamespace(name=f"y{k}", causality="output") for k in range(n_out)]
    unknowns = [SimpleNamespace(variable=v, dependencies=None if d is None else [inputs[i] for i in d])
                for v, d in zip(outputs, deps)]
    return SimpleNamespace(modelName=name, modelVariables=inputs + outputs, outputs=unknowns)


@st.composite
def systems(draw):
    n = draw(st.integers(1, 7))
    names = draw(st.permutations([f"i{k}" for k in range(n)]))
    mds = {}
    for name in names:
        n_in, n_out = draw(st.integers(0, 3)), draw(st.integers(1, 3))
        deps = [draw(st.one_of(st.none(), st.sets(st.integers(0, n_in - 1)) if n_in else st.just(set())))
                for _ in range(n_out)]
        mds[name] = _model(name, n_in, n_out, [None if d is None else sorted(d) for d in deps])
    inputs = [f"{i}.{v.name}" for i, md in mds.items() for v in md.modelVariables if v.causality == "input"]
    outputs = [f"{i}.{v.name}" for i, md in mds.items() for v in md.modelVariables if v.causality == "output"]
    fed = draw(st.lists(st.sampled_from(inputs), unique=True)) if inputs else []
    connections = [SimpleNamespace(source=draw(st.sampled_from(outputs)), target=t) for t in fed]
    return connections, mds


@settings(max_examples=300, deadline=None)
@given(systems(), st.booleans())
def test_system_orders_are_those_of_the_former_networkx_code(system, declared_only):
    connections, mds = system
    if declared_only:
        mds = {n: graph.DeclaredOnly(md) for n, md in mds.items()}
    assert graph.algebraic_loops(connections, mds) == _old_algebraic_loops(connections, mds)
    assert graph.evaluation_order(connections, mds) == _old_evaluation_order(connections, mds)
    assert graph.stepping_order(connections, mds) == _old_stepping_order(connections, mds)


def _fmu(name, deps):
    """A stand-in FMU for coupling.discrete_refresh: output name -> the names of the inputs it declares."""
    outputs = [SimpleNamespace(variable=SimpleNamespace(name=o), dependencies=[SimpleNamespace(name=d) for d in ds])
               for o, ds in deps.items()]
    return SimpleNamespace(name=name, md=SimpleNamespace(outputs=outputs))


def test_discrete_refresh_chains_in_order_and_samples_cycles_and_self_feeding_links():
    stair, a, b = _fmu("stair", {"y": []}), _fmu("a", {"y": ["u"]}), _fmu("b", {"y": ["u"]})
    loop = _fmu("loop", {"y": ["u"]})
    links = [(a, "y", b, "u", None),        # chained after the next one
             (stair, "y", a, "u", None),
             (loop, "y", loop, "u", None)]  # feeds itself: no refresh can order it
    sampled, chained = coupling.discrete_refresh(links)
    assert chained == [links[0]]
    assert sampled == [links[1], links[2]]


def test_the_run_path_does_not_import_networkx():
    """Importing harness.run and running a drive leave networkx unimported (its import alone is about a
    quarter of a second of CPU)."""
    code = ("import sys\nimport harness.run as r\nprint('networkx' in sys.modules)\n"
            "r.simulate(r.load('bed_drive'), stop_time=0.05)\nprint('networkx' in sys.modules)")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.stdout.split()[-2:] == ["False", "False"], p.stdout[-300:] + p.stderr[-300:]
