"""Dependency graphs of a system: which values must be known before which can be computed.

Variable level: a node per ``Instance.variable``; an edge ``source -> target`` per connection and an edge
``input -> output`` inside an FMU where the output depends directly on the input (the ModelStructure
``dependencies``; an output without the attribute depends on every input, as FMI 2.0 says).  A strongly
connected component with more than one node is an algebraic loop.

Instance level: the evaluation order of a communication point (:func:`evaluation_order`) and the stepping
order of Gauss-Seidel (:func:`stepping_order`).
"""
from __future__ import annotations

import networkx as nx


def direct_dependencies(md) -> dict[str, list[str]]:
    """Output name -> names of the inputs it depends on directly."""
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    out = {v.name: list(inputs) for v in md.modelVariables if v.causality == "output"}
    for u in md.outputs:
        if u.dependencies is not None:
            out[u.variable.name] = [d.name for d in u.dependencies if d.causality == "input"]
    return out


def undeclared_outputs(md) -> list[str]:
    """Outputs whose ModelStructure entry declares no ``dependencies`` (FMI 2.0: they may depend on every
    input).  pythonfmu and many exporters write none."""
    declared = {u.variable.name for u in md.outputs if u.dependencies is not None}
    return [v.name for v in md.modelVariables if v.causality == "output" and v.name not in declared]


class DeclaredOnly:
    """A view of a model description in which an output without declared ``dependencies`` depends on no
    input (what libcosim, Ecos and OMSimulator assume when they sample outputs after the step).  Only the
    attributes the graph functions read are provided."""

    def __init__(self, md):
        self.md = md
        self.modelName = md.modelName
        self.modelVariables = md.modelVariables
        declared = [u for u in md.outputs if u.dependencies is not None]
        names = {u.variable.name for u in declared}
        self.outputs = declared + [_Unknown(v) for v in md.modelVariables
                                   if v.causality == "output" and v.name not in names]


class _Unknown:
    __slots__ = ("variable", "dependencies")

    def __init__(self, variable):
        self.variable, self.dependencies = variable, []


def variable_graph(connections, model_descriptions: dict) -> nx.DiGraph:
    g = nx.DiGraph()
    for inst, md in model_descriptions.items():
        for out, deps in direct_dependencies(md).items():
            g.add_node(f"{inst}.{out}", instance=inst)
            for d in deps:
                g.add_edge(f"{inst}.{d}", f"{inst}.{out}")
    for c in connections:
        g.add_edge(c.source, c.target)
    return g


def algebraic_loops(connections, model_descriptions: dict) -> list[list[str]]:
    """Every algebraic loop as the sorted variable names in it (empty list: none)."""
    g = variable_graph(connections, model_descriptions)
    loops = [sorted(c) for c in nx.strongly_connected_components(g) if len(c) > 1]
    return sorted(loops)


def evaluation_order(connections, model_descriptions: dict) -> list[list[str]]:
    """Groups of instances, in the order in which their outputs at a communication point can be computed
    from their inputs: an instance comes after every instance that feeds one of its direct-feed-through
    inputs.  A group with several members (or one member feeding itself) is an algebraic loop."""
    ft_inputs = {inst: {d for deps in direct_dependencies(md).values() for d in deps}
                 for inst, md in model_descriptions.items()}
    g = nx.DiGraph()
    g.add_nodes_from(model_descriptions)
    for c in connections:
        si, _ = c.source.split(".", 1)
        ti, tv = c.target.split(".", 1)
        if tv in ft_inputs[ti]:
            g.add_edge(si, ti)
    order = list(model_descriptions)
    cond = nx.condensation(g)
    groups = [sorted(cond.nodes[n]["members"], key=order.index)
              for n in nx.lexicographical_topological_sort(
                  cond, key=lambda n: min(order.index(m) for m in cond.nodes[n]["members"]))]
    return groups


def stepping_order(connections, model_descriptions: dict) -> list[str]:
    """Gauss-Seidel order: strongly connected components of the instance graph (edge a -> b when an output
    of a feeds an input of b) in topological order; inside a component, instances whose outputs have no
    direct feed-through come first, then the others in their evaluation order; ties keep the system's order."""
    order = list(model_descriptions)
    g = nx.DiGraph()
    g.add_nodes_from(order)
    for c in connections:
        g.add_edge(c.source.split(".", 1)[0], c.target.split(".", 1)[0])
    rank = {inst: k for k, group in enumerate(evaluation_order(connections, model_descriptions)) for inst in group}
    no_ft = {inst: not any(direct_dependencies(md).values()) for inst, md in model_descriptions.items()}
    cond = nx.condensation(g)
    result = []
    for n in nx.lexicographical_topological_sort(
            cond, key=lambda n: min(order.index(m) for m in cond.nodes[n]["members"])):
        members = cond.nodes[n]["members"]
        result.extend(sorted(members, key=lambda m: (not no_ft[m], rank[m], order.index(m))))
    return result
