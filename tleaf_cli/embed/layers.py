"""`NormalisedGCNConv`: torch-geometric's GCN layer over an adjacency normalised once per batch.

    X' = Â X W + b,    Â = D^-1/2 (A + I) D^-1/2     (Kipf & Welling; `GCNConv`)

`GCNConv` normalises its `edge_index` at every call (self loops, degrees, weights) and gathers and
scatters messages; q's encoders call four to eight layers per batch on the same graphs. Here Â is
built once per batch as a sparse CSR matrix with its transpose (`graphs.gcn_adjacency`) and each
layer is one dense product and one sparse product, whose backward multiplies by the stored
transpose. The weights are `GCNConv`'s own (`lin.weight`, `bias`): a model saved with `GCNConv`
layers loads unchanged, and gives the same vectors to float rounding.
"""

from __future__ import annotations

import torch
from torch_geometric.nn import GCNConv

from tleaf_cli.embed.graphs import Adjacency


class _SparseProduct(torch.autograd.Function):
    """Â · X, differentiable in X only, its backward Âᵀ · G with Âᵀ given."""

    @staticmethod
    def forward(ctx, matrix: torch.Tensor, transposed: torch.Tensor, x: torch.Tensor):
        ctx.transposed = transposed
        return matrix @ x

    @staticmethod
    def backward(ctx, grad: torch.Tensor):
        return None, None, ctx.transposed @ grad


def sparse_product(adjacency: Adjacency, x: torch.Tensor) -> torch.Tensor:
    """`adjacency.matrix` · x, differentiable in x, its backward reading the stored transpose
    (any sparse CSR pair: a normalised adjacency, a readout's pooling matrix)."""
    return _SparseProduct.apply(adjacency.matrix, adjacency.transposed, x)


class NormalisedGCNConv(GCNConv):
    """A GCN layer reading a normalised adjacency (`graphs.gcn_adjacency`).

    Args:
        in_channels: width of the input node states.
        out_channels: width of the output node states.

    `forward(x, adjacency)`: x [n, in_channels], `adjacency` the batch's `Adjacency`; returns
    Â x W + b [n, out_channels], what `GCNConv(in, out)(x, edge_index)` returns for the
    edge_index Â was built from.
    """

    def __init__(self, in_channels: int, out_channels: int) -> None:
        super().__init__(in_channels, out_channels, normalize=False)

    def forward(self, x: torch.Tensor, adjacency: Adjacency) -> torch.Tensor:  # type: ignore[override]
        out = sparse_product(adjacency, self.lin(x))
        return out if self.bias is None else out + self.bias
