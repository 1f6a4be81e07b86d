"""Graphs the embedders read, built as torch_geometric `Data` (no layers here).

Four kinds, after the paper (Sec. III) and LENSR for propositional formulas:

* **Propositional graph** (input of the edge embedder q_e) for a CNF — a DFA edge's guard, or a
  letter written as a conjunction of literals. Nodes: one per atom occurrence kind (an atom
  node per distinct atom), a NOT node per negative literal, an OR node per clause, one AND root,
  and a GLOBAL node joined to every other node. Arcs point from operands to their operator
  (atom -> NOT -> OR -> AND); the GLOBAL node links both ways. `true` (no clause) is a lone AND.
* **Automaton graph** (input of the meta embedder q_m) for a DFA: one node per state (flags
  initial / accepting) and one node per DFA edge, with arcs s -> e -> t. Edge nodes carry the
  index of their guard in `guards`, so q_e can embed each distinct guard once per batch.
* **Trace graph**: a trace w_1..w_T as the same kind of graph, a chain s_0 -> e_1 -> s_1 -> ... ->
  e_T -> s_T with s_0 initial and s_T accepting; e_i carries the letter w_i as a guard.
* **Syntax-tree graph** (the paper's baseline): one node per node of the parse tree, typed by
  operator, atoms by their index; arcs from child to parent.

Node features are left to the models: graphs store integer node types and atom indices (into a
vocabulary the caller fixes), so atom features (one-hot, random, text) stay pluggable.
"""

from __future__ import annotations

import warnings
from collections.abc import Collection, Sequence
from typing import NamedTuple

import torch
from torch_geometric.data import Batch, Data
from torch_geometric.utils import to_undirected

from tleaf_cli.errors import InputError
from tleaf_cli.logic import ltlf_nodes as ltlf
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.formulas import check_depth
from tleaf_cli.logic.guards import guard_for

# Propositional graph node types.
GLOBAL, AND, OR, NOT, ATOM = range(5)
PROP_TYPES = 5

# Automaton / trace graph node kinds.
STATE, EDGE = range(2)

# Syntax-tree node types: operators in a fixed order, then atoms.
SYNTAX_OPS: tuple[type, ...] = (
    ltlf.LTLfNot,
    ltlf.LTLfAnd,
    ltlf.LTLfOr,
    ltlf.LTLfImplies,
    ltlf.LTLfEquivalence,
    ltlf.LTLfNext,
    ltlf.LTLfWeakNext,
    ltlf.LTLfEventually,
    ltlf.LTLfAlways,
    ltlf.LTLfUntil,
    ltlf.LTLfRelease,
    ltlf.LTLfTrue,
    ltlf.LTLfFalse,
    ltlf.LTLfLast,
)
SYNTAX_ATOM = len(SYNTAX_OPS)
SYNTAX_TYPES = SYNTAX_ATOM + 1

Clauses = Sequence[Sequence[int]]


def _edge_index(arcs: list[tuple[int, int]]) -> torch.Tensor:
    if not arcs:
        return torch.zeros((2, 0), dtype=torch.long)
    return torch.tensor(arcs, dtype=torch.long).t().contiguous()


def cnf_graph(cnf: Clauses, atom_ids: Sequence[int]) -> Data:
    """The propositional graph of a CNF whose literals index (1-based) into `atom_ids`.

    `atom_ids[k]` is the vocabulary index of the CNF's k-th atom. Fields: `node_type` [N],
    `atom` [N] (vocabulary index, -1 for operator nodes), `edge_index` [2, E].
    """
    types, atoms, arcs = _cnf_parts(cnf, atom_ids)
    return Data(
        node_type=torch.tensor(types, dtype=torch.long),
        atom=torch.tensor(atoms, dtype=torch.long),
        edge_index=_edge_index(arcs),
        num_nodes=len(types),
    )


def cnf_graph_batch(items: Sequence[tuple[Clauses, Sequence[int]]]) -> Batch:
    """The graphs of many (cnf, atom_ids) pairs (`cnf_graph`) as one batch, what
    `Batch.from_data_list` of them gives, built from plain lists: q_e embeds thousands of
    guards at a time, and a `Data` object per guard cost more than the encoder."""
    types: list[int] = []
    atoms: list[int] = []
    arcs: list[tuple[int, int]] = []
    sizes: list[int] = []
    for cnf, atom_ids in items:
        offset = len(types)
        t, a, e = _cnf_parts(cnf, atom_ids)
        types += t
        atoms += a
        arcs += [(u + offset, v + offset) for u, v in e]
        sizes.append(len(t))
    sizes_t = torch.tensor(sizes, dtype=torch.long)
    batch = Batch(
        node_type=torch.tensor(types, dtype=torch.long),
        atom=torch.tensor(atoms, dtype=torch.long),
        edge_index=_edge_index(arcs),
        batch=torch.repeat_interleave(torch.arange(len(sizes)), sizes_t),
        ptr=torch.cat([torch.zeros(1, dtype=torch.long), sizes_t.cumsum(0)]),
    )
    batch.num_nodes = len(types)
    return batch


def _cnf_parts(
    cnf: Clauses, atom_ids: Sequence[int]
) -> tuple[list[int], list[int], list[tuple[int, int]]]:
    """`cnf_graph`'s node types, node atoms and arcs, as lists."""
    types, atoms, arcs = [GLOBAL, AND], [-1, -1], []
    atom_node: dict[int, int] = {}
    for clause in cnf:
        clause_node = len(types)
        types.append(OR)
        atoms.append(-1)
        arcs.append((clause_node, 1))
        for lit in clause:
            k = abs(lit) - 1
            if not 0 <= k < len(atom_ids):
                raise InputError(f"literal {lit} out of range for {len(atom_ids)} atoms")
            if k not in atom_node:
                atom_node[k] = len(types)
                types.append(ATOM)
                atoms.append(int(atom_ids[k]))
            source = atom_node[k]
            if lit < 0:
                source_not = len(types)
                types.append(NOT)
                atoms.append(-1)
                arcs.append((source, source_not))
                source = source_not
            arcs.append((source, clause_node))
    for node in range(1, len(types)):
        arcs += [(0, node), (node, 0)]
    return types, atoms, arcs


def letter_cnf(
    true_atoms: Collection[str], atoms: Sequence[str], one_hot: bool = False
) -> list[list[int]]:
    """A letter over `atoms` as a CNF, in the form of the DFA guards of its alphabet.

    Powerset: a conjunction of every atom's literal, positive if true, else negated. One-hot (the
    alphabet itself says at most one atom holds): the true atom alone, `a`, or every atom negated
    for the empty letter — exactly the guard `logic.guards` writes for that single letter. Written
    as `a & !b & !c & ...` instead, the letters of a one-hot formula with many atoms differ in one
    literal among many and q_e maps them almost onto each other (measured: distances 0.01–0.2
    against norms of 2.3 on a 6-atom rule set), so q could not tell which action happened.
    """
    if one_hot and true_atoms:
        return [[k + 1] for k, a in enumerate(atoms) if a in true_atoms]
    return [[k + 1] if a in true_atoms else [-(k + 1)] for k, a in enumerate(atoms)]


def dfa_graph(dfa: DFA) -> tuple[Data, list[tuple[tuple[int, ...], ...]]]:
    """The automaton graph of a DFA, and the guards (CNF over `dfa.atoms`) its edge nodes index.

    Fields: `node_kind` [N] (STATE/EDGE), `flags` [N, 2] float (initial, accepting; 0 on edge
    nodes), `guard` [N] (index into the returned guards, -1 on states), `share` [N] float (the
    share of the alphabet's letters an edge node's guard reads, 0 on states: the probability that
    a uniformly random letter takes that edge), `rejecting` [N] float (1 on the states that are
    not accepting), `horizon` (0: readouts count runs up to the encoder's max_length),
    `edge_index` [2, E], `initial` (the initial state's node index).
    """
    n = dfa.num_states
    kinds, guard_ids, arcs, share = [STATE] * n, [-1] * n, [], [0.0] * n
    flags = [[float(s == dfa.initial), float(dfa.accepting[s])] for s in range(n)]
    guards: list[tuple[tuple[int, ...], ...]] = []
    for src, dst, letters in dfa.edges():  # the order of dfa.guarded_edges()
        node = len(kinds)
        kinds.append(EDGE)
        flags.append([0.0, 0.0])
        guard_ids.append(len(guards))
        guards.append(guard_for(letters, dfa.alphabet).cnf)
        share.append(float(letters.mean()))
        arcs += [(src, node), (node, dst)]
    data = Data(
        node_kind=torch.tensor(kinds, dtype=torch.long),
        flags=torch.tensor(flags, dtype=torch.float32),
        guard=torch.tensor(guard_ids, dtype=torch.long),
        share=torch.tensor(share, dtype=torch.float32),
        rejecting=torch.tensor([float(not a) for a in dfa.accepting] + [0.0] * (len(kinds) - n)),
        horizon=torch.tensor([0]),
        edge_index=_edge_index(arcs),
        initial=torch.tensor([dfa.initial], dtype=torch.long),
        num_nodes=len(kinds),
    )
    return data, guards


def trace_graph(length: int) -> Data:
    """The chain graph of a trace of `length` steps; edge node of step i has `guard` = i.

    `share` is 1 on edge nodes (each state has one way on), 0 on states; `rejecting` is 0
    everywhere (the chain stands for the one word it reads, and says nothing of others);
    `horizon` is the length (readouts read the chain to its end). Which
    letter each step carries is left to the caller (the guards list, or soft letters for
    a differentiable trace), so one graph shape serves every trace of that length.
    """
    if length < 1:
        raise InputError("traces are non-empty")
    states = list(range(length + 1))
    edges = list(range(length + 1, 2 * length + 1))
    kinds = [STATE] * (length + 1) + [EDGE] * length
    flags = [[0.0, 0.0] for _ in kinds]
    flags[0][0] = 1.0
    flags[length][1] = 1.0
    arcs = []
    for i, e in enumerate(edges):
        arcs += [(states[i], e), (e, states[i + 1])]
    return Data(
        node_kind=torch.tensor(kinds, dtype=torch.long),
        flags=torch.tensor(flags, dtype=torch.float32),
        guard=torch.tensor([-1] * (length + 1) + list(range(length)), dtype=torch.long),
        share=torch.tensor([0.0] * (length + 1) + [1.0] * length),
        rejecting=torch.zeros(2 * length + 1),
        horizon=torch.tensor([length]),
        edge_index=_edge_index(arcs),
        initial=torch.tensor([0], dtype=torch.long),
        num_nodes=len(kinds),
    )


def read_limits(batch, max_length: int) -> torch.Tensor:
    """[graphs]: how many letters the run readouts read of each graph of a batch: a trace chain
    to its end (`horizon`, its length), a DFA (horizon 0, or no horizon field) up to
    `max_length` letters."""
    horizon = getattr(batch, "horizon", None)
    if horizon is None:
        return torch.full((int(batch.ptr.numel() - 1),), max_length, device=batch.ptr.device)
    return torch.where(horizon > 0, horizon, max_length)


def trace_graph_batch(lengths: Sequence[int]) -> tuple[Batch, torch.Tensor]:
    """The batch of trace chain graphs (`trace_graph`) of these lengths, built with
    tensor ops, and the node index of every edge node (graph by graph, step by step)."""
    lengths_t = torch.tensor(lengths, dtype=torch.long)
    sizes = 2 * lengths_t + 1
    ptr = torch.cat([torch.zeros(1, dtype=torch.long), sizes.cumsum(0)])
    total = int(ptr[-1])
    graph = torch.repeat_interleave(torch.arange(len(lengths)), sizes)
    local = torch.arange(total) - ptr[graph]  # node index within its graph
    length = lengths_t[graph]
    kind = torch.where(local <= length, STATE, EDGE)
    flags = torch.zeros((total, 2))
    flags[ptr[:-1], 0] = 1.0  # the initial state
    flags[ptr[:-1] + lengths_t, 1] = 1.0  # the last state
    edge_nodes = torch.nonzero(kind == EDGE).flatten()
    # edge node of step i is ptr + T + 1 + i; state i is ptr + i
    before = edge_nodes - length[edge_nodes] - 1
    # per graph, arcs (state i, edge i), (edge i, state i + 1) in step order, as trace_graph
    arcs = torch.stack(
        [torch.stack([before, edge_nodes]), torch.stack([edge_nodes, before + 1])], dim=2
    ).reshape(2, -1)
    guard = torch.where(kind == EDGE, local - length - 1, -1)
    batch = Batch(
        node_kind=kind,
        flags=flags,
        guard=guard,
        share=(kind == EDGE).float(),
        rejecting=torch.zeros(total),
        horizon=lengths_t,
        edge_index=arcs,
        initial=torch.zeros(len(lengths), dtype=torch.long),
        batch=graph,
        ptr=ptr,
    )
    batch.num_nodes = total
    return batch, edge_nodes


class Adjacency(NamedTuple):
    """A normalised adjacency Â as sparse CSR matrices, and its transpose (what the backward
    pass of Â·X multiplies by: stored, so no step transposes Â again)."""

    matrix: torch.Tensor
    transposed: torch.Tensor


def gcn_adjacency(edge_index: torch.Tensor, num_nodes: int, dtype=torch.float32) -> Adjacency:
    """Â = D^-1/2 (A + I) D^-1/2 of the arcs `edge_index` (source -> target), row v holding v's
    incoming messages: what `GCNConv` computes from `edge_index` at every call (`gcn_norm`),
    computed once per batch and read by every layer (`layers.NormalisedGCNConv`)."""
    (src, dst), weight = _gcn_arcs(edge_index, num_nodes, dtype)
    size = (num_nodes, num_nodes)
    return Adjacency(_csr(dst, src, weight, size), _csr(src, dst, weight, size))


def _gcn_arcs(
    edge_index: torch.Tensor, num_nodes: int, dtype: torch.dtype
) -> tuple[torch.Tensor, torch.Tensor]:
    """`gcn_norm(edge_index, None, num_nodes, add_self_loops=True)`'s arcs and weights, the
    same values in the same order (the arcs but self-loops, then one self-loop per node; weight
    d_u^-1/2 d_v^-1/2, d a node's incoming arcs and its loop), in a dozen operators where
    torch-geometric's general path (edge weights, other flows) launches about ninety."""
    src, dst = edge_index
    if bool((src == dst).any()):  # gcn_norm replaces a graph's own self-loops by its loops
        src, dst = edge_index[:, src != dst]
    loops = torch.arange(num_nodes, device=edge_index.device)
    src, dst = torch.cat([src, loops]), torch.cat([dst, loops])
    degree = torch.bincount(dst, minlength=num_nodes).to(dtype)
    scale = degree.pow(-0.5)  # every node has its loop: no zero degree
    return torch.stack([src, dst]), scale.index_select(0, src) * scale.index_select(0, dst)


def _quiet_csr_warning() -> None:
    """Torch warns once per process that sparse CSR support is beta. A CSR tensor made through
    `torch.ops` (`_csr`, `batches.JointStore`) would print that warning to stderr past Python's
    warning filters; one made here, through the Python binding under a filter, uses it up."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        index = torch.zeros(1, dtype=torch.int32)
        torch.sparse_csr_tensor(index, index[:0], torch.zeros(0), (0, 0))


_quiet_csr_warning()


def _csr(
    row: torch.Tensor, col: torch.Tensor, values: torch.Tensor, size: tuple[int, int]
) -> torch.Tensor:
    """The sparse CSR matrix with `values` at (row, col) (no two entries at one place), entries
    sorted by row, then column, as `to_torch_csr_tensor` sorts them, with int32 indices: the
    CSR product reads int32 indices as they are, and converts int64 ones at every call."""
    order = torch.argsort(row * size[1] + col, stable=True)
    crow = torch._convert_indices_from_coo_to_csr(
        row.index_select(0, order), size[0], out_int32=True
    )
    col = col.index_select(0, order).int()
    # valid by construction (sorted, in range): no checks, no conversions
    return torch.ops.aten._sparse_compressed_tensor_unsafe(
        crow, col, values.index_select(0, order), list(size), layout=torch.sparse_csr
    )


def joint_adjacency(
    edge_index: torch.Tensor, num_nodes: int, directed: bool, dtype=torch.float32
) -> Adjacency:
    """Every direction's Â in one matrix [n, ways · n], so that a GCN layer reads all of them
    with one sparse product: undirected (ways 1), `gcn_adjacency` of the arcs taken both ways;
    `directed` (ways 2), Â of the arcs at column 2u and Â of the reversed arcs at column 2u + 1.
    A layer's node states for both directions, x·[W→ ; W←]ᵀ [n, 2 h] read as [2 n, h] (row 2u:
    u's state through W→, row 2u + 1 through W←), then give Â→ x W→ᵀ + Â← x W←ᵀ in one
    product: what two `GCNConv` layers and their sum give, to float rounding."""
    if not directed:
        return gcn_adjacency(to_undirected(edge_index, num_nodes=num_nodes), num_nodes, dtype)
    rows, cols, weights = [], [], []
    for way, arcs in enumerate((edge_index, edge_index.flip(0))):
        (src, dst), weight = _gcn_arcs(arcs, num_nodes, dtype)
        rows.append(dst)
        cols.append(2 * src + way)
        weights.append(weight)
    row, col, weight = torch.cat(rows), torch.cat(cols), torch.cat(weights)
    return Adjacency(
        _csr(row, col, weight, (num_nodes, 2 * num_nodes)),
        _csr(col, row, weight, (2 * num_nodes, num_nodes)),
    )


def readout_pool(weights: torch.Tensor, graph_of: torch.Tensor, graphs: int) -> Adjacency:
    """The pooling matrix S [graphs · parts, n] (and its transpose) of node weights `weights`
    [n, parts]: w_k(v) at row (graph of v) · parts + k, column v, so that S · x [n, h] read as
    [graphs, parts · h] is Σ_v w_k(v) x_v per graph and part, the parts side by side."""
    n, parts = weights.shape
    rows = (graph_of.unsqueeze(1) * parts + torch.arange(parts, device=weights.device)).reshape(-1)
    cols = torch.arange(n, device=weights.device).repeat_interleave(parts)
    size = (graphs * parts, n)
    values = weights.reshape(-1)
    return Adjacency(_csr(rows, cols, values, size), _csr(cols, rows, values, size[::-1]))


def syntax_graph(formula: ltlf.LTLfFormula, vocabulary: dict[str, int]) -> Data:
    """The parse tree as a graph: `node_type` [N] (SYNTAX_OPS index, or SYNTAX_ATOM), `atom` [N]
    (vocabulary index, -1 for operators), arcs child -> parent; node 0 is the root.
    FormulaSyntaxError for a formula nested too deeply to walk (the walk recurses)."""
    check_depth(formula)
    types: list[int] = []
    atoms: list[int] = []
    arcs: list[tuple[int, int]] = []

    def visit(f: ltlf.LTLfFormula) -> int:
        node = len(types)
        if isinstance(f, ltlf.LTLfTrue | ltlf.LTLfFalse):  # subclasses of LTLfAtomic: test first
            types.append(SYNTAX_OPS.index(type(f)))
            atoms.append(-1)
            return node
        if isinstance(f, ltlf.LTLfAtomic):
            name = str(f.s)
            if name not in vocabulary:
                raise KeyError(f"atom '{name}' is not in the vocabulary")
            types.append(SYNTAX_ATOM)
            atoms.append(vocabulary[name])
            return node
        types.append(SYNTAX_OPS.index(type(f)))
        atoms.append(-1)
        children = getattr(f, "formulas", None) or ([f.f] if hasattr(f, "f") else [])
        for child in children:
            arcs.append((visit(child), node))
        return node

    visit(formula)
    return Data(
        node_type=torch.tensor(types, dtype=torch.long),
        atom=torch.tensor(atoms, dtype=torch.long),
        edge_index=_edge_index(arcs),
        num_nodes=len(types),
    )
