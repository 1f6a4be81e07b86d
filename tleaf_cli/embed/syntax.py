"""The syntax-tree baseline (the paper's comparison row): an LTLf parse tree to a vector.

    h_v^0   = [ onehot(type_v) ; A[atom_v] ]     type: operator or atom; A: atom features
    h^{l+1} = ReLU( GCNConv_l(h^l) )             (arcs taken both ways)
    q_s(T)  = W_out · mean_v h_v^L

The same encoder as q_e's (`TypedGraphEncoder`) over parse-tree node types. Traces are embedded
for it by an `AutomatonEncoder` of their own, trained jointly, so the two rows of the comparison
differ only in how the formula is seen: as its tree, or as its DFA.
"""

from __future__ import annotations

import torch

from tleaf_cli.embed.graphs import SYNTAX_TYPES
from tleaf_cli.embed.proposition_encoder import TypedGraphEncoder


class SyntaxEncoder(TypedGraphEncoder):
    """q_s: syntax-tree graph -> R^out_dim (GCN, mean readout, linear head)."""

    def __init__(
        self, atom_table: torch.Tensor, hidden: int = 100, layers: int = 4, out_dim: int = 200
    ) -> None:
        super().__init__(SYNTAX_TYPES, atom_table, hidden, layers, out_dim)
