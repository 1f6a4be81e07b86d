"""Constrained decoding of action-recognition outputs (`train-task --decode constrained`).

A video's pair distribution per step (`losses.pair_log_probs`) is decoded by `tl.
constrained_decode` under a rule set built from the knowledge base WITHOUT the labels:

1. candidates C: the `top_k` pairs with the highest probability at some step of the video;
2. R: the conjunction of the KB rules whose atoms all lie in C (`KnowledgeRuleSets`);
3. decode under R (letter 0, "none of R's atoms", decodes to the best pair outside them);
4. the violation metric reads the rules relevant to the DECODED pairs D (those whose atoms all
   occur in D); if one of them is not in R, the decoded sequence might break it, so C grows by
   D and the video is decoded again. Each round adds a pair or ends, so it stops; when it ends,
   every rule relevant to the output is in R, which the output satisfies: 0 violations by
   construction, with R chosen from the model's outputs alone.

`soft_pairs` uses the rules as a weighted prior instead (`decode.soft_choice`): per video and
weight w, the argmax pairs unless their log-probability exceeds the constrained decoding's by
less than w (weight 0: argmax; a large weight: constrained decoding).
"""

from __future__ import annotations

from collections.abc import Sequence

import torch

from tleaf_cli.decode import constrained_decode, soft_choice
from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
from tleaf_cli.losses import pair_log_probs


def candidate_pairs(log_pairs: torch.Tensor, length: int, top_k: int) -> set[int]:
    """The `top_k` pair indices with the highest log-probability at some step < `length`."""
    best = log_pairs[:length].max(dim=0).values
    return set(best.topk(min(top_k, best.numel())).indices.tolist())


def decode_pairs(
    log_pairs: torch.Tensor,
    lengths: torch.Tensor,
    rules: KnowledgeRuleSets,
    top_k: int,
) -> tuple[torch.Tensor, int]:
    """Pair indices [B, T] (−1 past a length) decoded under each video's rule set (module
    docstring), and the number of decoding rounds the batch took."""
    vocabulary = rules.vocabulary
    sizes = lengths.tolist()
    candidates = [candidate_pairs(log_pairs[b], n, top_k) for b, n in enumerate(sizes)]
    out = torch.full(log_pairs.shape[:2], -1, dtype=torch.long, device=log_pairs.device)
    pending = list(range(len(sizes)))
    rounds = 0
    while pending:
        rounds += 1
        chosen = [{vocabulary[k] for k in candidates[b]} for b in pending]
        sets = rules.one_each(chosen)
        rows = torch.tensor(pending, device=log_pairs.device)
        decoded = constrained_decode(log_pairs[rows], sets, lengths[rows])
        still = []
        for j, b in enumerate(pending):
            pairs = decoded[j, : sizes[b]]
            used = set(pairs.tolist())
            if _covered(rules, {vocabulary[k] for k in used}, chosen[j]):
                out[b] = decoded[j]
            else:
                candidates[b] |= used
                still.append(b)
        pending = still
    return out, rounds


def soft_pairs(
    log_pairs: torch.Tensor,
    lengths: torch.Tensor,
    rules: KnowledgeRuleSets,
    top_k: int,
    weights: Sequence[float],
) -> dict[float, torch.Tensor]:
    """Pair indices [B, T] (−1 past a length) per weight of the rules' prior: `soft_choice`
    between the argmax pairs and `decode_pairs`' (computed once for every weight)."""
    hard, _ = decode_pairs(log_pairs, lengths, rules, top_k)
    return {w: soft_choice(log_pairs, hard, w) for w in weights}


def own_labels(
    actions: torch.Tensor,
    ingredients: torch.Tensor,
    lengths: torch.Tensor,
    rules: KnowledgeRuleSets | None,
    top_k: int,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Labels for videos that have none, from the model's own outputs (logits [B, T, A] and
    [B, T, I]): its constrained decoding under `rules` (the knowledge picks, among the model's
    top_k candidate pairs, a sequence that breaks no rule), or its argmax per step where `rules`
    is None. Action and ingredient indices [B, T], −100 past a length (cross-entropy's ignore)."""
    with torch.no_grad():
        if rules is None:
            a, i = actions.argmax(-1), ingredients.argmax(-1)
        else:
            pairs, _ = decode_pairs(pair_log_probs(actions, ingredients), lengths, rules, top_k)
            pairs = pairs.clamp(min=0)
            a, i = pairs // ingredients.shape[-1], pairs % ingredients.shape[-1]
        past = torch.arange(a.shape[1], device=a.device)[None, :] >= lengths[:, None]
        return a.masked_fill(past, -100), i.masked_fill(past, -100)


def _covered(rules: KnowledgeRuleSets, decoded: set[str], candidates: set[str]) -> bool:
    """Every KB rule relevant to the decoded atoms is one of the rules decoded under."""
    return decoded <= candidates or {r.name for r in rules.rules(decoded)} <= {
        r.name for r in rules.rules(candidates)
    }
