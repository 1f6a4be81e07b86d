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


def csr_product(matrix: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
    """matrix · x for a sparse CSR `matrix` and a dense `x`, written into a fresh tensor by
    `addmm` with β = 0 (the tensor's contents are ignored): `@` first fills a zero tensor
    and then adds the product into it, seven operators more for the same values."""
    out = x.new_empty(matrix.shape[0], x.shape[1])
    return torch.addmm(out, matrix, x, beta=0, out=out)


class _SparseProduct(torch.autograd.Function):
    """Â · X, differentiable in X only, its backward Âᵀ · G with Âᵀ given."""

    @staticmethod
    def forward(ctx, matrix: torch.Tensor, transposed: torch.Tensor, x: torch.Tensor):
        ctx.transposed = transposed
        return csr_product(matrix, x)

    @staticmethod
    def backward(ctx, grad: torch.Tensor):
        return None, None, csr_product(ctx.transposed, grad)


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


class _GCNLayer(torch.autograd.Function):
    """ReLU(Â · (X Wᵀ viewed as [ways · n, h]) + b) for a joint adjacency Â [n, ways · n]
    (`graphs.joint_adjacency`), W the directions' weights stacked, b their biases summed: one
    dense product, one sparse product with the bias, an in-place ReLU; the backward written
    out (the ReLU's mask, Âᵀ · G, the two weight products), so a layer is a few operators
    each way instead of an autograd node per step. With `index`, node i's input is
    x[index[i]] (x holds the distinct inputs): the dense product runs on the distinct rows and
    is gathered, and the weights' gradient sums each row's nodes first. Gradients nobody
    asked for (a frozen q's weights, constant inputs) are not computed."""

    @staticmethod
    def forward(ctx, x, index, matrix, transposed, *weights_and_biases):
        ways = len(weights_and_biases) // 2
        weights, biases = weights_and_biases[:ways], weights_and_biases[ways:]
        weight = weights[0] if ways == 1 else torch.cat(weights)
        bias = biases[0] if ways == 1 else sum(biases[1:], biases[0])
        states = torch.mm(x, weight.transpose(0, 1))
        if index is not None:
            states = states.index_select(0, index)
        out = torch.addmm(bias, matrix, states.view(-1, bias.shape[0])).relu_()
        ctx.save_for_backward(x, index, weight, out)
        ctx.transposed, ctx.ways = transposed, ways
        return out

    @staticmethod
    def backward(ctx, grad):
        x, index, weight, out = ctx.saved_tensors
        ways = ctx.ways
        wants_weights = any(ctx.needs_input_grad[4 : 4 + ways])
        wants_biases = any(ctx.needs_input_grad[4 + ways :])
        grad = torch.ops.aten.threshold_backward(grad, out, 0)  # where the ReLU passed
        grad_bias = grad.sum(0) if wants_biases else None
        grad_x = grad_weights = None
        if ctx.needs_input_grad[0] or wants_weights:
            grad_states = csr_product(ctx.transposed, grad).view(out.shape[0], -1)
            if index is not None:  # each distinct input's nodes summed
                rows = grad_states.new_zeros(x.shape[0], grad_states.shape[1])
                grad_states = rows.index_add_(0, index, grad_states)
            if ctx.needs_input_grad[0]:
                grad_x = torch.mm(grad_states, weight)
            if wants_weights:
                grad_weight = torch.mm(grad_states.transpose(0, 1), x)
                grad_weights = grad_weight.view(ways, -1, x.shape[1]).unbind(0)
        return (
            grad_x,
            None,
            None,
            None,
            *(grad_weights or [None] * ways),
            *([grad_bias] * ways),
        )


def gcn_layer(
    x: torch.Tensor,
    adjacency: Adjacency,
    weights: tuple[torch.Tensor, ...],
    biases: tuple[torch.Tensor, ...],
    index: torch.Tensor | None = None,
) -> torch.Tensor:
    """ReLU(Σ_d Â_d X W_dᵀ + b_d) over a joint adjacency of len(weights) directions
    (`graphs.joint_adjacency`: direction d's Â at columns ways · u + d), in one autograd node
    (`_GCNLayer`): what one `NormalisedGCNConv` per direction, their sum and a ReLU give.
    With `index` [n], x holds distinct input rows and node i reads x[index[i]] (a batch whose
    nodes repeat few inputs: q_m's first layer over many graphs)."""
    return _GCNLayer.apply(x, index, adjacency.matrix, adjacency.transposed, *weights, *biases)
