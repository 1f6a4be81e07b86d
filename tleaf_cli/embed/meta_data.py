"""Inputs of the meta embedder: automaton and trace graphs whose edge nodes carry q_e vectors.

q_e is frozen while q_m trains, so every distinct (atoms, CNF) — a DFA guard, or a trace letter
written as a conjunction over its formula's atoms — is embedded once and cached, and each graph
gets its node features (`edge_vec`) when it is built.
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Collection, Sequence

import numpy as np
import torch
from torch_geometric.data import Batch, Data

from tleaf_cli.data.monitor_cache import monitor_shares
from tleaf_cli.embed.automaton import RUN_READOUTS
from tleaf_cli.embed.graphs import (
    cnf_graph_batch,
    dfa_graph,
    letter_cnf,
    trace_graph,
    trace_graph_batch,
)
from tleaf_cli.embed.proposition_encoder import PropositionEncoder
from tleaf_cli.errors import InputError
from tleaf_cli.logic.alphabet import Alphabet
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.kept import Kept
from tleaf_cli.logic.monitors import MonitorBank

Key = tuple[tuple[str, ...], tuple[tuple[int, ...], ...]]


class GuardVectors:
    """q_e(guard) for (atoms, cnf) keys, computed in batches and cached.

    The cache is keyed by the guard as it reads atoms' names (`_named`): q_e's graph of a
    guard holds only the atoms it mentions, so the same guard inside formulas over other atom
    lists (the rule sets a loss builds from ever new predictions) is computed once."""

    def __init__(self, model: PropositionEncoder, vocabulary: Sequence[str], batch: int = 1024):
        self.model = model.eval()
        self.index = {a: i for i, a in enumerate(vocabulary)}
        self.batch = batch
        self.cache: dict[tuple, torch.Tensor] = {}
        self.dim = model.head.out_features

    def __call__(self, keys: Sequence[Key]) -> torch.Tensor:
        named = [_named(k) for k in keys]
        missing = list(
            {n: k for n, k in zip(named, keys, strict=True) if n not in self.cache}.items()
        )
        for i in range(0, len(missing), self.batch):
            part = missing[i : i + self.batch]
            graphs = cnf_graph_batch([(cnf, self.ids(atoms)) for _, (atoms, cnf) in part])
            with torch.no_grad():
                vectors = self.model(graphs)
            self.cache.update(zip((n for n, _ in part), vectors, strict=True))
        if not keys:
            return torch.zeros((0, self.dim))
        return torch.stack([self.cache[n] for n in named])

    def ids(self, atoms: Sequence[str]) -> list[int]:
        """Vocabulary indices of `atoms`; InputError naming any the edge model never saw."""
        unknown = [a for a in atoms if a not in self.index]
        if unknown:
            raise InputError(
                f"atoms {unknown} are not in the edge model's vocabulary; train-edge on DFAs "
                "that contain them"
            )
        return [self.index[a] for a in atoms]


def _named(key: Key) -> tuple:
    """A guard's clauses as (sign, atom name) literals: the same key for the same guard over
    any atom list (q_e's graph of it is the same)."""
    atoms, cnf = key
    return tuple(tuple((lit > 0, atoms[abs(lit) - 1]) for lit in clause) for clause in cnf)


# `dfa_graph` per automaton (`DFA.structure`: the graph and its guards, CNFs over atom
# positions, never read the atoms' names): a loss's fresh rule sets often repeat an automaton
# over other atoms. At most GRAPHS_KEPT, the oldest dropped first.
GRAPHS_KEPT = 1024
_GRAPHS = Kept(GRAPHS_KEPT)  # per automaton: its graph and guards


def guard_keys(dfa: DFA) -> list[Key]:
    """The q_e keys of a DFA's guards, as `featured_dfa_graphs` reads them: for a caller that
    puts them through q_e together with other keys (`GuardVectors` keeps them)."""
    return [(dfa.atoms, g) for g in _dfa_graph(dfa)[1]]


def _dfa_graph(dfa: DFA) -> tuple[Data, list]:
    """`dfa_graph(dfa)`, built once per automaton; a shallow copy, so that the fields a caller
    adds (edge vectors, monitor shares) stay its own."""
    key = dfa.structure
    if key not in _GRAPHS:
        _GRAPHS.keep(key, dfa_graph(dfa))
    graph, guards = _GRAPHS[key]
    return copy.copy(graph), guards


# the fields of `dfa_graph`'s graphs that `dfa_batch` lays end to end (edge_index aside)
GRAPH_FIELDS = ("node_kind", "flags", "guard", "share", "rejecting", "horizon", "initial")
_ARRAYS = Kept(GRAPHS_KEPT)  # per automaton: its graph as arrays, and guards


def _dfa_arrays(dfa: DFA) -> tuple[dict[str, np.ndarray], list]:
    """`_dfa_graph(dfa)`'s fields as numpy arrays, and its guards; built once per automaton
    (at most GRAPHS_KEPT, the oldest dropped first)."""
    key = dfa.structure
    if key not in _ARRAYS:
        graph, guards = _dfa_graph(dfa)
        arrays = {field: graph[field].numpy() for field in (*GRAPH_FIELDS, "edge_index")}
        _ARRAYS.keep(key, (arrays, guards))
    return _ARRAYS[key]


def _with_edge_vectors(graph: Data, vectors: torch.Tensor) -> Data:
    edge_vec = torch.zeros((graph.num_nodes, vectors.shape[1]))
    on_edges = graph.guard >= 0
    edge_vec[on_edges] = vectors[graph.guard[on_edges]]
    graph.edge_vec = edge_vec
    return graph


def featured_dfa_graphs(
    dfas: Sequence[DFA],
    vectors: GuardVectors,
    monitors: MonitorBank | None = None,
    cache_shares: bool = False,
) -> list[Data]:
    """The graphs of `dfas` with q_e vectors on their edge nodes; every guard not seen before
    goes through q_e in one batch. With `monitors`, each graph also carries the shares of its
    accepted and rejected words that each monitor accepts (`monitor`, [1, 2 F]).

    `cache_shares`: keep this DFA set's shares on disk between processes
    (`data.monitor_cache`), for a whole dfas.parquet that train-meta and every evaluation read
    again. Off for sets that do not come back whole (a loss's fresh rule sets in one batch):
    each would leave a file never read."""
    built = [_dfa_graph(dfa) for dfa in dfas]
    keys = [[(dfa.atoms, g) for g in guards] for dfa, (_, guards) in zip(dfas, built, strict=True)]
    every = vectors([k for ks in keys for k in ks])  # every new guard in one q_e batch
    per_graph = torch.split(every, [len(ks) for ks in keys])
    graphs = [_with_edge_vectors(g, v) for (g, _), v in zip(built, per_graph, strict=True)]
    if monitors is not None:
        shares = monitor_shares(dfas, monitors, use_cache=cache_shares)
        for graph, one in zip(graphs, shares, strict=True):
            graph.monitor = torch.from_numpy(one).reshape(1, -1)
    return graphs


def dfa_batch(
    dfas: Sequence[DFA], vectors: GuardVectors, shares: np.ndarray | None = None
) -> Batch:
    """`Batch.from_data_list(featured_dfa_graphs(dfas, vectors, monitors))`, the same fields
    and values, collated on the host: each automaton's graph (built once per automaton) as
    numpy arrays laid end to end, its guards' q_e vectors placed on its edge nodes by one
    index-copy, and `shares` [len(dfas), 2, F] (`data.monitor_cache.monitor_shares` of the
    DFAs, where q reads monitors) as their `monitor`. A handful of operators, where collating
    the `Data` objects launches a few dozen per graph (the tleaf loss embeds a batch's new rule
    sets this way)."""
    built = [_dfa_arrays(dfa) for dfa in dfas]
    every = vectors([(dfa.atoms, g) for dfa, (_, guards) in zip(dfas, built, strict=True)
                     for g in guards])  # fmt: skip
    graphs = [g for g, _ in built]
    sizes = np.array([len(g["node_kind"]) for g in graphs], dtype=np.int64)
    ptr = np.concatenate([[0], np.cumsum(sizes)])
    arcs = np.array([g["edge_index"].shape[1] for g in graphs], dtype=np.int64)
    edge_index = np.concatenate([g["edge_index"] for g in graphs], axis=1)
    edge_index = edge_index + np.repeat(ptr[:-1], arcs)
    fields = {
        key: torch.from_numpy(np.concatenate([g[key] for g in graphs])) for key in GRAPH_FIELDS
    }
    on_edges = torch.from_numpy(np.flatnonzero(fields["guard"].numpy() >= 0))
    fields["edge_vec"] = every.new_zeros(int(ptr[-1]), every.shape[1]).index_copy_(
        0, on_edges, every
    )
    if shares is not None:
        fields["monitor"] = torch.from_numpy(np.ascontiguousarray(shares).reshape(len(dfas), -1))
    batch = Batch(**fields, edge_index=torch.from_numpy(edge_index), ptr=torch.from_numpy(ptr))
    batch.batch = torch.from_numpy(np.repeat(np.arange(len(graphs)), sizes))
    batch.num_nodes = int(ptr[-1])
    return batch


def trace_monitor_features(
    trace: Sequence[Collection[str]],
    atoms: tuple[str, ...],
    monitors: MonitorBank,
    one_hot: bool = False,
) -> torch.Tensor:
    """[2 R F]: a trace's monitor features as a DFA's are laid out: which monitors accept it
    (its one accepted word, in its length's range), then zeros (a trace chain has no rejected
    words)."""
    alphabet, truth = _alphabet(tuple(atoms), one_hot)
    word = monitors.of_word(truth, [alphabet.index(step) for step in trace])
    return torch.cat([torch.from_numpy(word), torch.zeros(len(word))])


@functools.lru_cache(maxsize=1024)
def _alphabet(atoms: tuple[str, ...], one_hot: bool) -> tuple[Alphabet, np.ndarray]:
    """An alphabet and its atom truth table, built once per (atoms, kind): a traces file
    holds tens of thousands of traces over a few atom lists."""
    alphabet = Alphabet(atoms, "one-hot" if one_hot else "powerset")
    return alphabet, alphabet.truth()


def trace_letter_vectors(
    trace: Sequence[Collection[str]],
    atoms: tuple[str, ...],
    vectors: GuardVectors,
    one_hot: bool = False,
) -> torch.Tensor:
    """[T, d]: q_e of a trace's letters over a formula's atoms (written as `letter_cnf` writes
    the alphabet's letters)."""
    return vectors([(atoms, tuple(map(tuple, letter_cnf(step, atoms, one_hot)))) for step in trace])


def trace_inputs(
    traces: Sequence[Sequence[Collection[str]]],
    atoms: Sequence[tuple[str, ...]],
    one_hot: Sequence[bool],
    vectors: GuardVectors,
    monitors: MonitorBank | None = None,
) -> tuple[list[torch.Tensor], torch.Tensor | None]:
    """What q_m reads of many traces: each trace's letter vectors [T, d]
    (`trace_letter_vectors`) and, with `monitors`, their monitor features [N, 2 R F]
    (`trace_monitor_features`), trace i read over `atoms[i]` (one-hot alphabet where
    `one_hot[i]`). The same values as those functions give one trace at a time, at a fraction
    of the cost: each step is indexed in its alphabet once, and each distinct letter of each
    alphabet goes through q_e once and is looked up by index."""
    rows: dict[tuple, int] = {}  # (atoms, one_hot, letter index) -> row of the letter table
    per_trace, words = [], []
    for trace, a, h in zip(traces, atoms, one_hot, strict=True):
        alphabet, truth = _alphabet(tuple(a), h)
        word = [alphabet.index(step) for step in trace]
        per_trace.append([rows.setdefault((alphabet, h, i), len(rows)) for i in word])
        if monitors is not None:
            word_features = monitors.of_word(truth, word)
            words.append(np.concatenate([word_features, np.zeros_like(word_features)]))
    keys = [
        (alphabet.atoms, tuple(map(tuple, letter_cnf(alphabet.letter(i), alphabet.atoms, h))))
        for alphabet, h, i in rows
    ]
    table = vectors(keys)
    letters = [table[torch.tensor(r, dtype=torch.long)] for r in per_trace]
    features = None if monitors is None else torch.from_numpy(np.stack(words)).float()
    return letters, features


def featured_trace_graph(
    trace: Sequence[Collection[str]],
    atoms: tuple[str, ...],
    vectors: GuardVectors,
    one_hot: bool = False,
) -> Data:
    """A trace over a formula's atoms as a chain graph with q_e vectors on its edge nodes."""
    letters = trace_letter_vectors(trace, atoms, vectors, one_hot)
    return _with_edge_vectors(trace_graph(len(trace)), letters)


def with_chain_templates(
    encoder: torch.nn.Module, graphs: Sequence[Data], lengths: Collection[int]
) -> tuple[list[Data], dict[int, int]]:
    """`graphs` (DFA graphs with their fields) followed by one trace chain per length in
    `lengths`, with the same fields (zero edge vectors and monitor features, the chain's run
    weights where `encoder`'s readout reads runs), for one `GraphStore` of both: a batch of
    formulas and traces is then one select, and the traces' letters go onto the chains' edge
    nodes, which the node field `letter` (step of the trace, -1 elsewhere) marks. Returns the
    graphs and each length's graph index."""
    first = graphs[0]
    out = []
    for graph in graphs:
        graph = copy.copy(graph)
        graph.letter = torch.full((graph.num_nodes,), -1, dtype=torch.long)
        out.append(graph)
    index = {}
    for length in sorted(lengths):
        chain = trace_graph(length)
        chain.edge_vec = first.edge_vec.new_zeros(chain.num_nodes, first.edge_vec.shape[1])
        chain.letter = torch.where(chain.guard >= 0, chain.guard, -1)
        if "monitor" in first:
            chain.monitor = first.monitor.new_zeros(first.monitor.shape)
        if "run_weights" in first:
            chain.run_weights = encoder.chain_run_weights([length])
        index[length] = len(out)
        out.append(chain)
    return out, index


def chain_batch(
    encoder: torch.nn.Module,
    letters: torch.Tensor,
    lengths: Sequence[int],
    monitor: torch.Tensor | None = None,
) -> Batch:
    """The trace chains of these lengths as one graph batch, step t of trace i carrying row
    sum(lengths[:i]) + t of `letters` [sum(lengths), d] (q_e vectors, or expected ones of soft
    traces) on its edge node; with the readout weights of `encoder` (an AutomatonEncoder) where
    its readout reads runs, and the traces' monitor features `monitor` [traces, 2 R F] where
    given (`trace_monitor_features`). Built with tensor ops: the same graphs as
    `featured_trace_graph` collated, without a Data object per trace."""
    batch, edge_nodes = trace_graph_batch(list(lengths))
    if encoder.readout in RUN_READOUTS:  # chains' readout weights, computed once per length
        batch.run_weights = encoder.chain_run_weights(list(lengths))
    batch, edge_nodes = batch.to(letters.device), edge_nodes.to(letters.device)
    edge_vec = letters.new_zeros(int(batch.num_nodes), letters.shape[-1])
    batch.edge_vec = edge_vec.index_copy(0, edge_nodes, letters)
    if monitor is not None:
        batch.monitor = monitor.to(letters.device)
    return batch
