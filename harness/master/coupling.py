"""The coupling layout of a system, computed once when a master is built.

Two vectors carry every Real value the master passes on:

``y``  the signal vector: every Real output of every instance, instance after instance (``Inst.output_slice`` is an
       instance's slice, ``signal_index`` maps ``Instance.variable`` to its position);
``u``  the held-input vector: every connected Real input, instance after instance, ``u = factor * y[src] + offset``
       (``Inst.input_slice`` is an instance's slice; ``Inst.src``/``factor``/``offset``/``held`` are views over it).

Connections of Integer, Boolean, String and Enumeration variables have no place in either vector: they are
listed in ``discrete`` as (source instance, variable, target instance, variable, value table or None) and
passed on as values (:func:`passed_value`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harness.master import graph
from harness.errors import SimulationError


class Inst:
    """Prepared coupling data of one instance (built once).  ``input_slice`` is its slice of the held-input
    vector ``u`` (``held``, ``src``, ``factor``, ``offset`` are views of the layout's arrays over it);
    ``output_slice`` its slice of the signal vector ``y``; ``links`` the same ``(src, factor, offset)`` per input
    as plain numbers (for the exchange at a communication point, where a drive's few inputs are cheaper in floats
    than in numpy);
    ``pos_idx`` the positions (in its inputs) of bond positions it advances itself; ``feedthrough`` whether
    any connected input reaches an output directly."""
    __slots__ = ("name", "fmu", "output_slice", "input_slice", "out", "inp", "src", "factor", "offset", "held", "links",
                 "feedthrough", "interp", "input_pos", "pos_idx")

    def __init__(self, name, fmu):
        self.name, self.fmu = name, fmu


@dataclass
class Layout:
    insts: list[Inst]
    index: dict[str, int]            # instance name -> position in insts
    signal_names: list[str]          # 'Instance.output' of every entry of y
    signal_index: dict[str, int]
    src: np.ndarray                  # per entry of u: index into y
    factor: np.ndarray
    offset: np.ndarray
    u: np.ndarray
    discrete: list[tuple]            # (source FMU, variable, target FMU, variable, mapping) of non-Real connections


def layout(fmus: dict, connections, mds: dict, interpolate: bool) -> Layout:
    """The layout of ``fmus`` (name -> instance) coupled by ``connections``; ``mds`` the dependency view of each
    instance's model description (:func:`harness.master.graph.direct_dependencies`); ``interpolate``: whether the
    master hands input derivatives to the FMUs that can take them."""
    insts: list[Inst] = []
    index: dict[str, int] = {}
    names: list[str] = []
    for name, fmu in fmus.items():
        it = Inst(name, fmu)
        outs = [v.name for v in fmu.md.modelVariables if v.causality == "output" and v.type == "Real"]
        it.output_slice = slice(len(names), len(names) + len(outs))
        it.out = fmu.reals(outs)
        names.extend(f"{name}.{o}" for o in outs)
        index[name] = len(insts)
        insts.append(it)
    signal_index = {n: k for k, n in enumerate(names)}
    by_target: dict[str, list] = {n: [] for n in fmus}
    discrete: list[tuple] = []
    for c in connections:
        si, sv = c.source.split(".", 1)
        if fmus[si].var(sv).type != "Real":
            ti, tv = c.target.split(".", 1)
            discrete.append((fmus[si], sv, fmus[ti], tv, c.mapping))
            continue
        by_target[c.target.split(".", 1)[0]].append(c)
    ordered = [c for it in insts for c in by_target[it.name]]
    src = np.array([signal_index[c.source] for c in ordered], dtype=np.intp)
    factor = np.array([float(c.factor) for c in ordered])
    offset = np.array([float(c.offset) for c in ordered])
    u = np.zeros(len(ordered))
    start = 0
    for it in insts:
        cs = by_target[it.name]
        it.input_slice = slice(start, start + len(cs))
        start += len(cs)
        it.inp = it.fmu.reals([c.target.split(".", 1)[1] for c in cs])
        it.input_pos = {c.target.split(".", 1)[1]: k for k, c in enumerate(cs)}
        part = it.input_slice
        it.src, it.factor, it.offset, it.held = src[part], factor[part], offset[part], u[part]
        it.links = list(zip(it.src.tolist(), it.factor.tolist(), it.offset.tolist()))
        deps = graph.direct_dependencies(mds[it.name])
        ft = {d for ds in deps.values() for d in ds}
        it.feedthrough = any(c.target.split(".", 1)[1] in ft for c in cs)
        it.interp = it.fmu.can_interpolate_inputs and interpolate
        it.pos_idx = np.zeros(0, dtype=np.intp)
    return Layout(insts, index, names, signal_index, src, factor, offset, u, discrete)


def discrete_refresh(discrete: list[tuple]) -> tuple[list[tuple], list[tuple]]:
    """Split the non-Real connections of ``discrete`` for a master that refreshes feed-through at a
    communication point (``jacobi``, ``iterative``): ``(sampled, chained)``.

    A connection whose source output DECLARES a direct dependency on a non-Real input that another connection
    sets is ``chained``: it is passed after that connection, so a value travels through a chain of
    feed-through FMUs (e.g. Stair -> Feedthrough -> Feedthrough) within one communication point, as Real
    feed-through does.  The others (and any cycle among the chained, which no refresh can order) are
    ``sampled``: every source is read before any target is set, as libcosim and Ecos pass such values.
    Outputs without declared dependencies are taken as sampled (FMI 2.0's "may depend on every input" is
    an assumption, :meth:`harness.master.Master._assume_sampled`)."""
    def declared(fmu, output: str) -> set[str]:
        for u in fmu.md.outputs:
            if u.variable.name == output and u.dependencies is not None:
                return {d.name for d in u.dependencies}
        return set()

    set_by = {(id(dst), dv): k for k, (_, _, dst, dv, _) in enumerate(discrete)}
    g = graph.Digraph()
    for k, (src, sv, *_) in enumerate(discrete):
        for d in declared(src, sv):
            j = set_by.get((id(src), d))
            if j is not None:
                g.add_edge(j, k)
    g.remove_nodes([k for comp in graph.strongly_connected_components(g)
                    if len(comp) > 1 or comp[0] in g.succ[comp[0]] for k in comp])
    chained = {k for k, d in g.in_degrees().items() if d}
    order = [k for k in graph.lexicographical_topological_sort(g) if k in chained]
    return [c for k, c in enumerate(discrete) if k not in chained], [discrete[k] for k in order]


def passed_value(link: tuple, value, t: float):
    """What the non-Real connection ``link`` (an entry of ``Layout.discrete``) hands its target when its source
    holds ``value`` at time ``t``: the value itself, or through the connection's value table
    (:class:`harness.model.Connection` ``mapping``).  A value the table has no entry for stops the run
    (:class:`SimulationError` naming the connection, the value, the time and the entries)."""
    table = link[4]
    if table is None:
        return value
    try:
        return table[value]
    except KeyError:
        src, sv, dst, dv, _ = link
        raise SimulationError(f"connection {src.name}.{sv} -> {dst.name}.{dv} at t = {t:.9g} s: its value mapping "
                              f"has no entry for the value {value!r} (entries for {sorted(table)})",
                              time=t, instance=dst.name, variable=dv) from None


def exchange_plan(groups: list[list[int]], insts: list[Inst], connections, mds: dict,
                  loop_groups: set[int]) -> list[tuple]:
    """The operations that make every output consistent at a communication point, computed once.

    ``("read", i)`` reads instance i; ``("visit", i)`` sets its point inputs from the current outputs, then
    reads it; ``("loop", members)`` solves an algebraic loop.  Groups come in evaluation order (every source
    of a feed-through input before its target).  Inside a group whose instances feed each other without an
    algebraic loop at the variable level (e.g. a four-bar and the load on its rocker), the outputs are taken
    in topological order of the variable graph and an instance is visited again only when one of its outputs
    depends on a value that became final after its last visit; so each output is read last with final
    inputs, and no instance is visited more often than that needs."""
    plan: list[tuple] = []
    for k, group in enumerate(groups):
        if k in loop_groups:
            plan.append(("loop", group))
            continue
        if len(group) == 1:
            plan.append(("visit" if insts[group[0]].feedthrough else "read", group[0]))
            continue
        names = {insts[i].name: i for i in group}
        g = graph.Digraph()
        deps: dict[str, list[str]] = {}
        for i in group:
            it = insts[i]
            for out, ds in graph.direct_dependencies(mds[it.name]).items():
                node = f"{it.name}.{out}"
                g.add_node(node)
                deps[node] = []
                for d in ds:
                    for c in connections:
                        if c.target == f"{it.name}.{d}" and c.source.split(".", 1)[0] in names:
                            g.add_edge(c.source, node)
                            deps[node].append(c.source)
        final: dict[str, int] = {}       # output -> position of the op after which it is final
        last: dict[int, int] = {}        # instance -> position of its last op
        first: dict[int, int] = {}
        order = {n: j for j, n in enumerate(sorted(g.nodes))}
        system_order = {insts[i].name: r for r, i in enumerate(group)}
        for node in graph.lexicographical_topological_sort(
                g, key=lambda n: (system_order[n.split(".", 1)[0]], order[n])):
            i = names[node.split(".", 1)[0]]
            ready = max((final[s] for s in deps.get(node, ())), default=-1)
            if i in last and last[i] > ready:
                final[node] = last[i] if deps.get(node) else first[i]
                continue
            plan.append(("visit" if insts[i].feedthrough else "read", i))
            last[i] = len(plan) - 1
            first.setdefault(i, last[i])
            final[node] = last[i]
    return plan


def relink(master, k: int, factor: float, offset: float) -> None:
    """Entry ``k`` of the held-input vector passes ``factor * source + offset`` from now on (a scenario's action on
    a connected input, :mod:`harness.osp.scenario`): the master's arrays (and each instance's views of them) and
    the plain-float copies of the links both change."""
    master.factor[k], master.offset[k] = factor, offset
    src = int(master.src[k])
    master._links[k] = (src, factor, offset)
    for it in master.insts:
        if it.input_slice.start <= k < it.input_slice.stop:
            it.links[k - it.input_slice.start] = (src, factor, offset)
