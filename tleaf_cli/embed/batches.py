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
