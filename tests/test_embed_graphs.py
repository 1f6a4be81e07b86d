"""Graph construction for the embedders: structure that the models rely on."""

from __future__ import annotations

import torch
from torch_geometric.data import Batch
from torch_geometric.loader import DataLoader

from tleaf_cli.embed.graphs import (
    AND,
    ATOM,
    EDGE,
    GLOBAL,
    NOT,
    OR,
    STATE,
    SYNTAX_ATOM,
    SYNTAX_OPS,
    cnf_graph,
    cnf_graph_batch,
    dfa_graph,
    letter_cnf,
    syntax_graph,
    trace_graph,
)
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.logic.formulas import parse


def _arcs(data) -> set[tuple[int, int]]:
    return set(map(tuple, data.edge_index.t().tolist()))


def test_cnf_graph_structure() -> None:
    # (a | !b) & c, atoms a, b, c at vocabulary indices 7, 8, 9
    g = cnf_graph([[1, -2], [3]], [7, 8, 9])
    types = g.node_type.tolist()
    assert types.count(GLOBAL) == 1 and types.count(AND) == 1
    assert types.count(OR) == 2 and types.count(NOT) == 1 and types.count(ATOM) == 3
    assert sorted(a for a, t in zip(g.atom.tolist(), types, strict=True) if t == ATOM) == [7, 8, 9]
    assert all(a == -1 for a, t in zip(g.atom.tolist(), types, strict=True) if t != ATOM)
    arcs = _arcs(g)
    root = types.index(AND)
    clauses = [i for i, t in enumerate(types) if t == OR]
    assert all((c, root) in arcs for c in clauses)
    neg = types.index(NOT)
    b = g.atom.tolist().index(8)
    assert (b, neg) in arcs and any((neg, c) in arcs for c in clauses)
    glob = types.index(GLOBAL)
    assert all((glob, n) in arcs and (n, glob) in arcs for n in range(g.num_nodes) if n != glob)


def test_a_batch_of_cnf_graphs_is_the_collated_graphs() -> None:
    items = [([[1, -2], [3]], [7, 8, 9]), ([], [0]), ([[-1]], [4]), ([[2], [-1, 2]], [5, 6])]
    want = Batch.from_data_list([cnf_graph(cnf, ids) for cnf, ids in items])
    got = cnf_graph_batch(items)
    for key in ("node_type", "atom", "edge_index", "batch", "ptr"):
        assert torch.equal(got[key], want[key]), key
    assert got.num_nodes == want.num_nodes and got.num_graphs == len(items)


def test_true_guard_and_letters() -> None:
    assert cnf_graph([], [0]).node_type.tolist() == [GLOBAL, AND]
    assert letter_cnf({"b"}, ["a", "b", "c"]) == [[-1], [2], [-3]]


def test_dfa_graph_matches_the_dfa() -> None:
    dfa = compile_formula("G(a -> F b)")
    g, guards = dfa_graph(dfa)
    edges = dfa.guarded_edges()
    assert g.num_nodes == dfa.num_states + len(edges)
    assert (g.node_kind == STATE).sum() == dfa.num_states and (g.node_kind == EDGE).sum() == len(
        edges
    )
    assert g.flags[dfa.initial, 0] == 1 and g.flags[:, 0].sum() == 1
    assert g.flags[: dfa.num_states, 1].tolist() == dfa.accepting.astype(float).tolist()
    arcs = _arcs(g)
    for k, (src, dst, guard) in enumerate(edges):
        node = dfa.num_states + k
        assert (src, node) in arcs and (node, dst) in arcs
        assert guards[g.guard[node]] == guard.cnf
    assert (g.guard[: dfa.num_states] == -1).all()


def test_trace_graph_is_a_chain() -> None:
    g = trace_graph(3)
    assert g.num_nodes == 7 and g.edge_index.shape[1] == 6
    assert g.flags[0].tolist() == [1.0, 0.0] and g.flags[3].tolist() == [0.0, 1.0]
    assert g.guard.tolist() == [-1, -1, -1, -1, 0, 1, 2]
    assert _arcs(g) == {(0, 4), (4, 1), (1, 5), (5, 2), (2, 6), (6, 3)}


def test_syntax_graph() -> None:
    g = syntax_graph(parse("G(a -> F b)"), {"a": 0, "b": 1})
    names = [SYNTAX_OPS[t].__name__ if t != SYNTAX_ATOM else "atom" for t in g.node_type.tolist()]
    assert names == ["LTLfAlways", "LTLfImplies", "atom", "LTLfEventually", "atom"]
    assert g.atom.tolist() == [-1, -1, 0, -1, 1]
    assert _arcs(g) == {(1, 0), (2, 1), (3, 1), (4, 3)}


def test_graphs_batch_with_pyg() -> None:
    graphs = [dfa_graph(compile_formula(f))[0] for f in ("a U b", "F c", "G(a -> X b)")]
    batch = next(iter(DataLoader(graphs, batch_size=3)))
    assert batch.num_graphs == 3
    assert batch.num_nodes == sum(g.num_nodes for g in graphs)
    # PyG shifts node indices per graph, so `initial` must be read with batch.ptr offsets.
    starts = batch.ptr[:-1] + batch.initial
    assert torch.all(batch.flags[starts, 0] == 1)


def test_one_hot_letters_are_written_like_the_dfa_guards_of_their_alphabet() -> None:
    """A one-hot letter is the guard `logic.guards` gives that single letter: `b` alone, or
    every atom negated for the empty letter (the alphabet itself rules out two atoms at once)."""
    import numpy as np

    from tleaf_cli.logic.alphabet import Alphabet
    from tleaf_cli.logic.guards import cnf_holds, guard_for

    atoms = ("a", "b", "c")
    alphabet = Alphabet(atoms, "one-hot")
    assert letter_cnf({"b"}, atoms, one_hot=True) == [[2]]
    assert letter_cnf(set(), atoms, one_hot=True) == [[-1], [-2], [-3]]
    for k in range(alphabet.size):
        only = np.zeros(alphabet.size, dtype=bool)
        only[k] = True
        cnf = letter_cnf(alphabet.letter(k), atoms, one_hot=True)
        assert [list(c) for c in guard_for(only, alphabet).cnf] == cnf
        assert cnf_holds(cnf, alphabet).tolist() == only.tolist()  # true on that letter only
