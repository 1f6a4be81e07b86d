"""`logic_loss`: how far a sequence model's outputs are from the rules, as a loss.

A model gives, at every step, log-probabilities over a one-hot vocabulary (`log_probs`
[B, T, V], `lengths` [B]); rules are `RuleSet`s over that vocabulary, one for the whole batch or
one (or None) per sequence. Kinds:

* ``exact``   −log P(w ⊨ φ), w drawn step by step from the outputs (losses/exact.py);
* ``tleaf``   ‖q(A_φ) − q(w̃)‖², the paper's loss, with a trained embedder q (losses/tleaf.py);
* ``checker`` 1 where the argmax sequence violates φ, no gradient (losses/checker.py).

A sequence without rules, or whose rules no non-empty sequence satisfies (no signal: −log 0 is
infinite, and an unsatisfiable φ has no region in q's space to pull towards), gets 0 from exact
and tleaf; checker scores every sequence with rules. All rows are computed together: one padded
forward algorithm, or one q_m call, per batch.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import torch

from tleaf_cli import arguments
from tleaf_cli.errors import ArgumentError, ArgumentTypeError, SettingError
from tleaf_cli.losses.checker import checker_loss
from tleaf_cli.losses.exact import exact_loss
from tleaf_cli.losses.packed import letter_log_probs, pack_rows, rules_per_sequence
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.settings import LOGIC_LOSSES  # noqa: F401  (re-exported: a trainer's losses)

if TYPE_CHECKING:  # q's modules load torch_geometric: only the tleaf loss imports them
    from tleaf_cli.embed.embedder import Embedder

LossKind = Literal["exact", "tleaf", "checker"]
LOSS_KINDS: tuple[LossKind, ...] = ("exact", "tleaf", "checker")
REDUCTIONS = ("mean", "sum", "none")


def logic_loss(
    kind: LossKind,
    log_probs: torch.Tensor,
    rules: RuleSet | Sequence[RuleSet | None],
    lengths: torch.Tensor | None = None,
    embedder: Embedder | str | os.PathLike | None = None,
    reduction: str = "mean",
    *,
    per_sequence_vocabulary: bool = False,
) -> torch.Tensor:
    """The logic loss of `kind` for each sequence, reduced over the batch.

    Args:
        kind: ``"exact"``, ``"tleaf"`` or ``"checker"`` (module docstring).
        log_probs: float [B, T, V], per-step log-probabilities over the rules' vocabulary (e.g.
            ``log_softmax(logits, -1)``); they must be normalised over V.
        rules: one RuleSet for every sequence, or a list of B RuleSets (None: no rules).
        lengths: long [B]; steps at or past a length are not read (default: all T steps).
        embedder: q, from ``load_embedder(dir)``, or its folder's path (loaded once, and again
            when its files change); needed by ``tleaf`` only.
        reduction: ``"mean"`` over all B sequences (those without rules count 0), ``"sum"``, or
            ``"none"`` for the [B] losses.
        per_sequence_vocabulary: the rule sets are over one vocabulary, item by item (else
            ArgumentError, as ``tl.Shield``'s); True where each sequence names its V items by
            its own rule set's vocabulary (Creative Cooking's episodes name their action ids
            after their ingredients).

    Raises SettingError for a bad kind, reduction or missing embedder, ArgumentTypeError for an
    embedder that is neither an Embedder nor a path, InputError for shapes or rule sets that do
    not fit `log_probs` and for a folder that holds no q.
    """
    if kind not in LOSS_KINDS:
        raise SettingError("kind", f"must be one of {', '.join(LOSS_KINDS)}, not {kind!r}")
    if reduction not in REDUCTIONS:
        raise SettingError(
            "reduction", f"must be one of {', '.join(REDUCTIONS)}, not {reduction!r}"
        )
    if kind == "tleaf":
        embedder = _embedder(embedder)
    given = getattr(log_probs, "dtype", None)  # float16 / bfloat16 come back as float32
    log_probs, per_sequence, lengths = rules_per_sequence(
        log_probs, rules, lengths, per_sequence_vocabulary
    )
    batch, _, vocabulary = log_probs.shape
    _check_normalised(log_probs, lengths, torch.finfo(given).eps)

    out = log_probs.new_zeros(batch)
    rows = [
        b
        for b, r in enumerate(per_sequence)
        if r is not None and (r.satisfiable or kind == "checker")
    ]
    if rows:
        chosen = [per_sequence[b] for b in rows]
        which = torch.tensor(rows, device=log_probs.device)
        if kind == "checker":
            values = checker_loss(log_probs[which], lengths[which], chosen)
        else:
            packed, index = pack_rows(chosen, vocabulary, log_probs.device)
            letters = letter_log_probs(log_probs[which], packed, index)
            if kind == "exact":
                values = exact_loss(letters, lengths[which], packed, index)
            else:
                from tleaf_cli.losses.tleaf import tleaf_loss  # q runs: torch_geometric loads

                values = tleaf_loss(letters, lengths[which], packed, index, embedder)
        out = out.index_put((which,), values)
    if reduction == "none":
        return out
    return out.sum() if reduction == "sum" else out.mean()


def _embedder(embedder: object) -> Embedder:
    """The tleaf loss's q: an Embedder as given, or the one a model folder's path holds."""
    from tleaf_cli.embed.embedder import Embedder

    if embedder is None:
        raise SettingError("embedder", "the tleaf loss needs an embedder (load_embedder(dir))")
    if isinstance(embedder, str | os.PathLike):
        folder = Path(embedder)
        stamps = tuple(_stamp(folder / name) for name in ("config.json", "weights.pt"))
        return _load(str(folder.resolve()), stamps)
    if not isinstance(embedder, Embedder):
        raise ArgumentTypeError(
            "embedder",
            "must be an Embedder (load_embedder(dir)) or a train-meta folder's path, not "
            f"{arguments.given(embedder)}",
        )
    return embedder


def _stamp(path: Path) -> tuple[int, int] | None:
    """(mtime, size) of a file, None where it is missing: a folder rewritten loads afresh."""
    try:
        status = path.stat()
    except OSError:
        return None
    return status.st_mtime_ns, status.st_size


@lru_cache(maxsize=4)
def _load(folder: str, stamps: tuple) -> Embedder:
    """q of a folder, loaded once per state of its files (`stamps`): a loss called every batch
    with a path would otherwise read and rebuild q every batch."""
    from tleaf_cli.embed.load import load_embedder

    return load_embedder(folder)


def _check_normalised(log_probs: torch.Tensor, lengths: torch.Tensor, eps: float) -> None:
    """ArgumentError unless every read step's probabilities sum to 1, to the precision `eps` of
    the dtype they came in (logits passed by mistake would give wrong losses silently)."""
    with torch.no_grad():
        steps = torch.arange(log_probs.shape[1], device=log_probs.device)
        read = steps[None, :] < lengths[:, None]
        total = torch.logsumexp(log_probs.float(), dim=-1)[read]  # log Σ_v P_t(v), 0 if normalised
        if not total.numel():
            return
        worst = total[total.abs().argmax()]
    if abs(float(worst)) > max(1e-3, 16 * eps):
        raise ArgumentError(
            "log_probs",
            f"not normalised over the vocabulary (a step's probabilities sum to "
            f"{float(worst.exp()):.4g}): pass log_softmax(logits, -1), not logits",
        )
