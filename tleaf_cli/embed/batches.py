"""Graph batches assembled with tensor indexing instead of collating `Data` objects.

Training embeds the same graphs again every epoch in new combinations. `Batch.from_data_list`
collates Python objects field by field for every batch; a `GraphStore` collates its graphs once
and gives the batch of any of them (`select`) with a few gathers, the same batch as collating
those graphs would give. `join` puts two batches into one, so that formulas and traces read by
the same encoder go through it in one pass (every layer's cost is mostly per call on graphs this
small, not per node).
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch_geometric.data import Batch, Data

# fields every batch has that are not graph data: how graphs and nodes are laid out
LAYOUT = ("batch", "ptr", "edge_index", "num_nodes")


class GraphStore:
    """Graphs collated once; `select(ids)` gives the batch of some of them.

    Each field of the graphs is a node field (one row per node), a graph field (one row per
    graph, e.g. its initial node, its monitor features) or `edge_index`; which, is read from
    how the collation sliced it. Args: `graphs`, PyG `Data` objects with the same fields;
    `device`, where the store is kept (and its batches built).
    """

    def __init__(self, graphs: Sequence[Data], device: torch.device | str = "cpu") -> None:
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
        return _batch(fields, self.store.edge_index[:, edges] + shift, ptr)


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
