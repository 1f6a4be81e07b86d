"""Graph batches assembled with tensor indexing instead of collating `Data` objects.

Training embeds the same graphs again every epoch in new combinations. `Batch.from_data_list`
collates Python objects field by field for every batch; a `GraphStore` collates its graphs once
and gives the batch of any of them (`select`) with a few gathers, the same batch as collating
those graphs would give. `join` puts two batches into one, so that formulas and traces read by
the same encoder go through it in one pass (every layer's cost is mostly per call on graphs this
small, not per node).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np
import torch
from torch_geometric.data import Batch, Data

from tleaf_cli.embed.graphs import Adjacency

# fields every batch has that are not graph data: how graphs and nodes are laid out
LAYOUT = ("batch", "ptr", "edge_index", "num_nodes")


class Unit(NamedTuple):
    """How a block matrix's rows (or columns) are laid out: `per` 1 per node of each graph
    (node u's at k u .. k u + k - 1), or `per_graph` k per graph."""

    k: int
    per_graph: bool = False

    def starts(self, ptr: torch.Tensor) -> torch.Tensor:
        """[graphs + 1]: where each graph's rows begin, for node pointers `ptr`."""
        if self.per_graph:
            return self.k * torch.arange(ptr.numel(), device=ptr.device)
        return self.k * ptr

    def of(self, ids: torch.Tensor, nodes: torch.Tensor, ptr: torch.Tensor):
        """The rows of graphs `ids` (whose nodes are `nodes`, newly at `ptr`), graph by
        graph, and where each selected graph's rows begin."""
        if self.per_graph:
            units, starts = ids, torch.arange(ids.numel() + 1, device=ids.device)
        else:
            units, starts = nodes, ptr
        if self.k == 1:
            return units, starts
        spread = self.k * units[:, None] + torch.arange(self.k, device=ids.device)
        return spread.flatten(), self.k * starts


class Blocks(NamedTuple):
    """A block-diagonal sparse CSR matrix over a collated store, one block per graph: graph g's
    block spans rows rows[g]..rows[g + 1] and columns cols[g]..cols[g + 1] (its nodes, or its
    nodes times directions, or its readout parts), and its entries are the CSR entries
    entries[g]..entries[g + 1], with column indices kept relative to its block."""

    entries: torch.Tensor  # [graphs + 1]
    row_entries: torch.Tensor  # [rows]: entries of each row
    col: torch.Tensor  # [entries]: column within its block
    values: torch.Tensor
    row_unit: Unit
    col_unit: Unit

    @classmethod
    def of(cls, matrix: torch.Tensor, ptr: torch.Tensor, row_unit: Unit, col_unit: Unit):
        """The blocks of a block-diagonal sparse CSR `matrix` over a store with node pointers
        `ptr`, whose graphs' rows and columns are laid out as `row_unit` and `col_unit` say."""
        crow, col = matrix.crow_indices(), matrix.col_indices()
        rows, cols = row_unit.starts(ptr), col_unit.starts(ptr)
        entries = crow[rows]
        local = col - torch.repeat_interleave(cols[:-1], entries.diff())
        return cls(entries, crow.diff(), local, matrix.values(), row_unit, col_unit)

    def select(self, ids: torch.Tensor, row_ids: torch.Tensor, col_ptr: torch.Tensor):
        """The block-diagonal matrix of graphs `ids` (in that order), whose rows are the store's
        rows `row_ids` (the graphs' rows, graph by graph) and whose graph k starts at column
        col_ptr[k] (col_ptr [len(ids) + 1]): each block's entries gathered, its columns moved to
        the block's new place. What building the matrix from those graphs collated gives."""
        entries, entry_ptr = _ranges(self.entries, ids)
        crow = torch.cat([entry_ptr.new_zeros(1), self.row_entries[row_ids].cumsum(0)])
        col = self.col[entries] + col_ptr[:-1].repeat_interleave(entry_ptr.diff())
        size = (int(row_ids.numel()), int(col_ptr[-1]))
        with warnings.catch_warnings():  # torch marks CSR support beta
            warnings.simplefilter("ignore", UserWarning)
            return torch.sparse_csr_tensor(crow, col, self.values[entries], size)


# what a store's graphs' matrices come from: the collated store -> {field: (Â, Âᵀ) as Blocks}
BlockMatrices = Callable[[Batch], dict[str, tuple[Blocks, Blocks]]]


class GraphStore:
    """Graphs collated once; `select(ids)` gives the batch of some of them.

    Each field of the graphs is a node field (one row per node), a graph field (one row per
    graph, e.g. its initial node, its monitor features) or `edge_index`; which, is read from
    how the collation sliced it. Args: `graphs`, PyG `Data` objects with the same fields;
    `device`, where the store is kept (and its batches built).
    """

    def __init__(
        self,
        graphs: Sequence[Data],
        device: torch.device | str = "cpu",
        matrices: BlockMatrices | None = None,
    ) -> None:
        self.store = Batch.from_data_list(list(graphs))
        slices = self.store._slice_dict
        self.ptr = self.store.ptr
        self.edge_ptr = slices["edge_index"]
        self.node_fields, self.graph_fields = [], []
        graph_slices = torch.arange(len(graphs) + 1)
        for key in self.store.keys():  # noqa: SIM118 (iterating a Batch yields items)
            if key in LAYOUT:
                continue
            if torch.equal(slices[key], self.ptr):
                self.node_fields.append(key)
            elif torch.equal(slices[key], graph_slices):
                self.graph_fields.append(key)
            else:
                raise ValueError(f"field {key!r} is neither one row per node nor one per graph")
        self.store = self.store.to(device)
        self.ptr, self.edge_ptr = self.ptr.to(device), self.edge_ptr.to(device)
        self.matrices = {} if matrices is None else matrices(self.store)

    def __len__(self) -> int:
        return int(self.ptr.numel() - 1)

    def select(self, ids: Sequence[int] | torch.Tensor) -> Batch:
        """The batch of graphs `ids` (in that order, repeats allowed), as
        `Batch.from_data_list([graphs[i] for i in ids])` would give it."""
        ids = torch.as_tensor(ids, dtype=torch.long, device=self.ptr.device)
        nodes, ptr = _ranges(self.ptr, ids)
        edges, edge_ptr = _ranges(self.edge_ptr, ids)
        # each arc moves with its graph: from the graph's old first node to its new one
        shift = torch.repeat_interleave(ptr[:-1] - self.ptr[ids], edge_ptr.diff())
        fields = {key: self.store[key][nodes] for key in self.node_fields}
        fields |= {key: self.store[key][ids] for key in self.graph_fields}
        batch = _batch(fields, self.store.edge_index[:, edges] + shift, ptr)
        for key, (matrix, transposed) in self.matrices.items():
            # a matrix's rows and columns per graph: its nodes, or parts (rows of a graph's
            # block) per node or per graph
            row_ids, row_ptr = matrix.row_unit.of(ids, nodes, ptr)
            col_ids, col_ptr = matrix.col_unit.of(ids, nodes, ptr)
            batch[key] = Adjacency(
                matrix.select(ids, row_ids, col_ptr), transposed.select(ids, col_ids, row_ptr)
            )
        return batch


def join(first: Batch, second: Batch) -> Batch:
    """One batch holding `first`'s graphs, then `second`'s: the fields both have (node fields
    and graph fields alike are stacked), `second`'s nodes renumbered after `first`'s."""
    offset = first.ptr[-1]
    ptr = torch.cat([first.ptr, second.ptr[1:] + offset])
    fields = {
        key: torch.cat([first[key], second[key]])
        for key in first.keys()  # noqa: SIM118 (iterating a Batch yields items)
        if key not in LAYOUT and key in second.keys()  # noqa: SIM118
    }
    return _batch(fields, torch.cat([first.edge_index, second.edge_index + offset], dim=1), ptr)


def _ranges(ptr: torch.Tensor, ids: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The positions of items ptr[i]..ptr[i + 1] for each i in `ids`, concatenated, and the
    new offsets of each i's items."""
    starts, sizes = ptr[ids], ptr[ids + 1] - ptr[ids]
    new_ptr = torch.cat([sizes.new_zeros(1), sizes.cumsum(0)])
    positions = torch.repeat_interleave(starts - new_ptr[:-1], sizes)
    return positions + torch.arange(int(new_ptr[-1]), device=ptr.device), new_ptr


def _batch(fields: dict, edge_index: torch.Tensor, ptr: torch.Tensor) -> Batch:
    graphs = torch.arange(ptr.numel() - 1, device=ptr.device)
    batch = Batch(**fields, edge_index=edge_index, ptr=ptr)
    batch.batch = torch.repeat_interleave(graphs, ptr.diff())
    batch.num_nodes = int(ptr[-1])
    return batch


class JointBatch(NamedTuple):
    """What q_m's encoder reads of one training batch of formula graphs and trace chains
    (`JointStore.select`): the nodes' input vectors, the joint adjacency and the readout pool
    as CSR pairs, each graph's monitor features (None without monitors), and each trace's
    letters. `AutomatonEncoder.forward` reads it as it reads a graph batch. The inputs are
    few distinct vectors repeated (a batch of ~3,500 nodes has ~55: kinds, flags, guards
    and letters), so `x` holds them once and `x_index` says which each node reads."""

    x: torch.Tensor  # [distinct, input width]: one-hot kind, flags, edge-node vector
    adjacency: Adjacency
    pool: Adjacency
    monitor: torch.Tensor | None  # [graphs, features]
    lengths: torch.Tensor  # [traces]: letters of each trace chain
    graphs: int
    evidence: torch.Tensor | None = None  # [graphs, dim]: the evidence block's unit vectors
    x_index: torch.Tensor | None = None  # [n]: node i's input is x[x_index[i]] (None: x per node)

    def node_inputs(self) -> torch.Tensor:
        """[n, input width]: every node's input vector."""
        return self.x if self.x_index is None else self.x.index_select(0, self.x_index)


class JointStore:
    """q_m's training graphs (formulas, then one trace chain per length) laid out once, with
    every trace's letters and monitor features, so that a batch of formulas and traces
    (`select`) is index arithmetic on the host (numpy: which nodes, which matrix entries,
    where each block's columns move) and a handful of operations on the device: one gather of
    the nodes' input vectors (the letters' rows on the chains' edge nodes), one of the
    monitor features, and the CSR matrices made from the host's arrays (int32 indices, which
    the CSR product reads without converting). The same inputs and matrices as a
    `GraphStore` select of the formulas and chains with the letters placed (tests). The input
    vectors are kept once each (the store's rows repeat a few kinds of node and q_e vector),
    and a batch carries the distinct ones it reads with each node's index into them.

    Args: `graphs`, the formula graphs then the chain templates (`meta_data.
    with_chain_templates`, whose node field `letter` marks the chains' edge nodes); `chain_of`,
    each trace length's template; `inputs`, the nodes' input vectors of a collated batch
    (`AutomatonEncoder.node_inputs`); `matrices`, the adjacency and pool blocks of a collated
    batch (`AutomatonEncoder.block_matrices`); `letters`, every trace's letter vectors [T, d];
    `monitor`, every trace's monitor features [traces, F] (None: no monitors; the formulas'
    are cut to the same F columns, which a batch's graphs then carry); `evidence`,
    the evidence block's unit vectors (`evidence.MonitorEvidence.formula_units`,
    `trace_units`) of every formula and every trace, constants carried like the features.
    """

    def __init__(
        self,
        graphs: Sequence[Data],
        chain_of: dict[int, int],
        inputs: Callable[[Batch], torch.Tensor],
        matrices: BlockMatrices,
        letters: Sequence[torch.Tensor],
        monitor: torch.Tensor | None,
        device: torch.device | str = "cpu",
        evidence: tuple[torch.Tensor, torch.Tensor] | None = None,
    ) -> None:
        store = Batch.from_data_list(list(graphs))
        self.device = torch.device(device)
        self.ptr = store.ptr.numpy()
        self.letter = store.letter.numpy()
        x = inputs(store)
        self.lengths = np.array([len(t) for t in letters], dtype=np.int64)
        self.letter_ptr = np.concatenate([[0], np.cumsum(self.lengths)])
        self.chain_of = np.zeros(int(self.lengths.max(initial=0)) + 1, dtype=np.int64)
        for length, graph in chain_of.items():
            self.chain_of[length] = graph
        # the letters as the rows their edge nodes read (kind "edge", no flags, the vector)
        # after the store's nodes' rows: a batch's input vectors are one gather
        rows = torch.cat(list(letters)).to(x.dtype)
        on_edge = x[store.letter >= 0][:1, : x.shape[1] - rows.shape[1]]
        letter_rows = torch.cat([on_edge.expand(len(rows), -1), rows], dim=1)
        # each distinct input vector once: a node reads row `input_of[node]`
        inputs, self.input_of = _distinct_rows(torch.cat([x, letter_rows]))
        self.x = inputs.to(self.device)
        self.nodes = x.shape[0]
        self.formulas = len(graphs) - len(chain_of)
        self.monitor = None
        if monitor is not None:  # the formulas' features, then the traces'
            formulas = store.monitor[: self.formulas, : monitor.shape[1]].to(monitor.dtype)
            self.monitor = torch.cat([formulas, monitor]).to(self.device)
        self.evidence = None if evidence is None else torch.cat(evidence).to(self.device)
        self.matrices = {
            key: tuple(_HostBlocks.of(blocks) for blocks in pair)
            for key, pair in matrices(store).items()
        }

    def select(self, formulas: Sequence[int], traces: Sequence[int]) -> JointBatch:
        """The batch of formula graphs `formulas` (store indices, in that order), then the
        chains of traces `traces` (trace indices) with their letters and monitor features."""
        formula_ids = np.asarray(formulas, dtype=np.int64)
        trace_ids = np.asarray(traces, dtype=np.int64)
        lengths = self.lengths[trace_ids]
        ids = np.concatenate([formula_ids, self.chain_of[lengths]])
        nodes, ptr = _host_ranges(self.ptr, ids)
        on_letters = np.flatnonzero(self.letter[nodes] >= 0)  # trace by trace, step by step
        letter_rows, _ = _host_ranges(self.letter_ptr, trace_ids)
        sources = nodes.copy()
        sources[on_letters] = self.nodes + letter_rows
        # the batch's distinct inputs, and each node's among them
        distinct, x_index = np.unique(self.input_of[sources], return_inverse=True)
        x = self.x.index_select(0, self.on_device(distinct))
        rows = self.on_device(np.concatenate([formula_ids, self.formulas + trace_ids]))
        monitor = None if self.monitor is None else self.monitor.index_select(0, rows)
        evidence = None if self.evidence is None else self.evidence.index_select(0, rows)
        pairs = {
            key: Adjacency(
                self._csr(matrix.select(ids, nodes, ptr)),
                self._csr(transposed.select(ids, nodes, ptr)),
            )
            for key, (matrix, transposed) in self.matrices.items()
        }
        return JointBatch(
            x,
            pairs["adjacency"],
            pairs["pool"],
            monitor,
            self.on_device(lengths),
            len(ids),
            evidence,
            self.on_device(x_index.astype(np.int64)),
        )

    def on_device(self, array: np.ndarray) -> torch.Tensor:
        """A host array as a tensor on the store's device (on the CPU, the same memory)."""
        out = torch.from_numpy(array)
        return out if self.device.type == "cpu" else out.to(self.device, non_blocking=True)

    def _csr(self, parts: tuple[np.ndarray, np.ndarray, np.ndarray, tuple[int, int]]):
        crow, col, values, size = parts
        with warnings.catch_warnings():  # torch marks CSR support beta
            warnings.simplefilter("ignore", UserWarning)
            # the arrays are a CSR matrix by construction (tests): no checks, no conversions
            return torch.ops.aten._sparse_compressed_tensor_unsafe(
                self.on_device(crow),
                self.on_device(col),
                self.on_device(values),
                list(size),
                layout=torch.sparse_csr,
            )


class _HostBlocks(NamedTuple):
    """`Blocks` as host (numpy) arrays, for `JointStore`: the same layout, selected with numpy."""

    entries: np.ndarray
    row_entries: np.ndarray
    col: np.ndarray
    values: np.ndarray
    row_unit: Unit
    col_unit: Unit

    @classmethod
    def of(cls, blocks: Blocks) -> _HostBlocks:
        return cls(
            blocks.entries.cpu().numpy(),
            blocks.row_entries.cpu().numpy(),
            blocks.col.cpu().numpy(),
            blocks.values.detach().cpu().numpy(),
            blocks.row_unit,
            blocks.col_unit,
        )

    def select(self, ids: np.ndarray, nodes: np.ndarray, ptr: np.ndarray):
        """`Blocks.select` of graphs `ids` (whose nodes are `nodes`, newly at `ptr`) on the
        host: the CSR arrays (int32 indices) and the size."""
        row_ids, _ = _host_units(self.row_unit, ids, nodes, ptr)
        _, col_ptr = _host_units(self.col_unit, ids, nodes, ptr)
        entries, entry_ptr = _host_ranges(self.entries, ids)
        crow = np.zeros(len(row_ids) + 1, dtype=np.int32)
        np.cumsum(self.row_entries[row_ids], out=crow[1:])
        col = self.col[entries] + np.repeat(col_ptr[:-1], np.diff(entry_ptr))
        size = (len(row_ids), int(col_ptr[-1]))
        return crow, col.astype(np.int32), self.values[entries], size


def _distinct_rows(x: torch.Tensor) -> tuple[torch.Tensor, np.ndarray]:
    """The distinct rows of x [n, d], in order of first sight, and each row's index among
    them (a host array): rows compared by their bytes through a dict (0.03 s on 91,000 rows;
    `torch.unique(dim=0)` took 0.7 s, numpy's unique over the bytes 0.2 s)."""
    rows = np.ascontiguousarray(x.detach().cpu().numpy())
    seen: dict[bytes, int] = {}
    index = np.fromiter(
        (seen.setdefault(row, len(seen)) for row in map(bytes, rows)), np.int64, len(rows)
    )
    first = np.zeros(len(seen), dtype=np.int64)
    first[index[::-1]] = np.arange(len(rows) - 1, -1, -1)  # each row's first occurrence
    return x[torch.from_numpy(first).to(x.device)], index


def _host_units(unit: Unit, ids: np.ndarray, nodes: np.ndarray, ptr: np.ndarray):
    """`Unit.of` on the host."""
    if unit.per_graph:
        units, starts = ids, np.arange(len(ids) + 1)
    else:
        units, starts = nodes, ptr
    if unit.k == 1:
        return units, starts
    spread = unit.k * units[:, None] + np.arange(unit.k)
    return spread.reshape(-1), unit.k * starts


def _host_ranges(ptr: np.ndarray, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`_ranges` on the host."""
    starts, sizes = ptr[ids], ptr[ids + 1] - ptr[ids]
    new_ptr = np.zeros(len(ids) + 1, dtype=np.int64)
    np.cumsum(sizes, out=new_ptr[1:])
    positions = np.repeat(starts - new_ptr[:-1], sizes) + np.arange(new_ptr[-1])
    return positions, new_ptr
