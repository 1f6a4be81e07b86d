"""Soft traces: a model's per-step probabilities read as a distribution over a formula's letters,
and their vectors under q (the tleaf loss's q(w̃)).

A soft trace is a [T, k] tensor of per-step probabilities over named atoms (`columns`). Each
step's letter distribution over a formula's atoms is

* one-hot domain: P(atom a) for each of the formula's atoms, and the rest of the mass —
  the domain's other atoms — on the empty letter;
* powerset domain: independent probabilities,
  P(letter) = prod_a (p_a if a is in the letter else 1 - p_a).

The edge node of step t then carries the expected q_e vector sum_l P_t(l) q_e(l), which is
exactly the discrete letter's vector when P_t is one-hot, and differentiable in P throughout.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Sequence

import numpy as np
import torch

from tleaf_cli.embed.graphs import letter_cnf
from tleaf_cli.embed.meta_data import chain_batch
from tleaf_cli.errors import SettingError
from tleaf_cli.logic.alphabet import Alphabet


def letter_keys(atoms: tuple[str, ...], domain: str) -> tuple[list, list]:
    """The letters over `atoms` (one-hot: none, then each atom; powerset: every subset, bit
    k = atoms[k]) and their q_e cache keys."""
    if domain == "one-hot":
        letters = [frozenset()] + [frozenset({a}) for a in atoms]
    elif domain == "powerset":
        letters = [
            frozenset(a for k, a in enumerate(atoms) if i >> k & 1) for i in range(1 << len(atoms))
        ]
    else:
        raise SettingError("domain", f"must be one-hot or powerset, not {domain!r}")
    one_hot = domain == "one-hot"
    return letters, [(atoms, tuple(map(tuple, letter_cnf(x, atoms, one_hot)))) for x in letters]


def letter_probabilities(
    probs: torch.Tensor, columns: Sequence[str], atoms: tuple[str, ...], domain: str
) -> torch.Tensor:
    """[T, letters] distribution of each step over the letters of `letter_keys`."""
    p = probs[:, [list(columns).index(a) for a in atoms]]
    if domain == "one-hot":
        return torch.cat([(1 - p.sum(dim=1, keepdim=True)).clamp(min=0), p], dim=1)
    out = []
    for bits in itertools.product((0, 1), repeat=len(atoms)):
        # letter index i has atom k iff bit k of i is set: product() varies the last fastest
        chosen = torch.tensor(bits[::-1], dtype=torch.bool, device=probs.device)
        out.append(torch.where(chosen, p, 1 - p).prod(dim=1))
    return torch.stack(out, dim=1)


def soft_trace_vectors(
    model: torch.nn.Module,
    expected: torch.Tensor,
    lengths: torch.Tensor,
    monitor: torch.Tensor | None = None,
) -> torch.Tensor:
    """q(w̃) [N, d] of soft traces whose step-t edge node carries expected[i, t] (t < lengths[i]),
    with their monitor features [N, 2 R F] where q reads them (`soft_monitor_features`); `model`
    is q's TripletEmbedder (embed_traces), all traces in one graph batch."""
    valid = torch.arange(expected.shape[1], device=expected.device)[None, :] < lengths[:, None]
    return model.embed_traces(chain_batch(model.trace, expected[valid], lengths.tolist(), monitor))


@functools.lru_cache(maxsize=64)
def one_hot_truth(atoms: int) -> np.ndarray:
    """The atom truth table of a one-hot alphabet of `atoms` atoms (letter 0 none, letter k + 1
    atom k): monitors read atoms by position, so their classes depend on the count alone."""
    truth = Alphabet(tuple(f"x{k:04d}" for k in range(atoms)), "one-hot").truth()
    truth.setflags(write=False)
    return truth
