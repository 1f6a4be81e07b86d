"""Logic losses on a sequence model's per-step outputs over a one-hot vocabulary.

`logic_loss(kind, log_probs, rules, ...)` is the one implementation every task (action
recognition, next activity, Creative Cooking) and a researcher's own model use; `adapters` turn
two heads or a policy's logits into `log_probs`. See docs/losses.md.
"""

from tleaf_cli.losses.adapters import pair_log_probs, pair_vocabulary
from tleaf_cli.losses.checker import violates
from tleaf_cli.losses.logic_loss import LOGIC_LOSSES, LOSS_KINDS, logic_loss

__all__ = [
    "LOGIC_LOSSES",
    "LOSS_KINDS",
    "logic_loss",
    "pair_log_probs",
    "pair_vocabulary",
    "violates",
]
