"""Training data for the edge embedder q_e: (guard, satisfying letter, violating letter) triplets.

Guards come from the edges of a `dfas.parquet` (each distinct guard once per formula; `true`
guards have no violating letter and are skipped) plus random CNFs over the same atoms, so q_e
also sees propositions that are not DFA guards. Letters are drawn uniformly from the guard's
letter set and from its complement, over the formula's alphabet (so one-hot DFAs give one-hot
letters). Held-out triplets come from formulas never used for training.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch
from torch_geometric.utils import to_undirected

from tleaf_cli.data.dfa_table import DfaTable
from tleaf_cli.embed.batches import GraphStore
from tleaf_cli.embed.graphs import cnf_graph, letter_cnf
from tleaf_cli.logic.alphabet import Alphabet
from tleaf_cli.logic.guards import cnf_holds


@dataclass(frozen=True)
class GuardTriplet:
    formula_id: str
    atoms: tuple[str, ...]
    cnf: tuple[tuple[int, ...], ...]
    sat: frozenset[str]
    unsat: frozenset[str]
    one_hot: bool = False  # the formula's alphabet: how its letters are written (letter_cnf)


def vocabulary(table: DfaTable) -> list[str]:
    """Sorted atoms of every compiled formula: the index space of atom features."""
    return sorted({a for r in table.rows if r["error"] is None for a in r["atoms"]})


def guard_triplets(
    table: DfaTable, per_guard: int, random_guards: int, rng: np.random.Generator
) -> list[GuardTriplet]:
    """Triplets for every compiled formula, in table order."""
    out: list[GuardTriplet] = []
    for row in table.rows:
        if row["error"] is not None or not row["atoms"]:
            continue
        alphabet = Alphabet(tuple(row["atoms"]), row["alphabet"])
        guards = list(dict.fromkeys(tuple(map(tuple, e["cnf"])) for e in row["edges"]))
        guards += [_random_cnf(rng, len(alphabet.atoms)) for _ in range(random_guards)]
        for cnf in guards:
            on = cnf_holds(cnf, alphabet)
            if on.all() or not on.any():
                continue
            inside, outside = np.flatnonzero(on), np.flatnonzero(~on)
            for _ in range(per_guard):
                out.append(
                    GuardTriplet(
                        row["formula_id"],
                        alphabet.atoms,
                        cnf,
                        alphabet.letter(int(rng.choice(inside))),
                        alphabet.letter(int(rng.choice(outside))),
                        alphabet.kind == "one-hot",
                    )
                )
    return out


def _random_cnf(rng: np.random.Generator, n_atoms: int) -> tuple[tuple[int, ...], ...]:
    """1-3 clauses of 1-3 distinct literals over n_atoms atoms."""
    clauses = []
    for _ in range(int(rng.integers(1, 4))):
        k = int(rng.integers(1, min(3, n_atoms) + 1))
        atoms = rng.choice(n_atoms, size=k, replace=False) + 1
        signs = rng.choice([-1, 1], size=k)
        clauses.append(tuple(int(a * s) for a, s in zip(atoms, signs, strict=True)))
    return tuple(clauses)


def split_by_formula(
    triplets: Sequence[GuardTriplet], holdout: float, rng: np.random.Generator
) -> tuple[list[GuardTriplet], list[GuardTriplet]]:
    """(train, held-out): whole formulas go to one side."""
    ids = sorted({t.formula_id for t in triplets})
    held = set(rng.permutation(ids)[: max(1, round(holdout * len(ids)))].tolist()) if ids else set()
    train = [t for t in triplets if t.formula_id not in held]
    return train, [t for t in triplets if t.formula_id in held]


Key = tuple[tuple[int, ...], tuple[tuple[int, ...], ...]]  # (atom ids, CNF): one graph


def triplet_keys(t: GuardTriplet, index: dict[str, int]) -> tuple[Key, Key, Key]:
    """(guard, satisfying letter, violating letter) as the keys of their propositional graphs:
    the CNF's atoms as vocabulary indices, and the CNF."""
    ids = tuple(index[a] for a in t.atoms)
    letters = (letter_cnf(x, t.atoms, t.one_hot) for x in (t.sat, t.unsat))
    return (ids, t.cnf), *((ids, tuple(map(tuple, cnf))) for cnf in letters)


class TripletStore:
    """Triplets' propositional graphs, each distinct graph built and collated once
    (`batches.GraphStore`: guards and letters repeat across triplets); `embed` puts some
    triplets' graphs through q_e in one pass."""

    def __init__(
        self, triplets: Sequence[GuardTriplet], index: dict[str, int], device="cpu"
    ) -> None:
        keys = [triplet_keys(t, index) for t in triplets]
        distinct = {k: i for i, k in enumerate(dict.fromkeys(k for ks in keys for k in ks))}
        graphs = [cnf_graph(cnf, ids) for ids, cnf in distinct]
        for g in graphs:  # q_e reads arcs both ways: made so once per graph, not per batch
            g.edge_index = to_undirected(g.edge_index, num_nodes=g.num_nodes)
        self.graphs = GraphStore(graphs, device)
        self.triples = torch.tensor(
            [[distinct[k] for k in ks] for ks in keys], dtype=torch.long
        ).reshape(-1, 3)

    def __len__(self) -> int:
        return len(self.triples)

    def embed(self, model: torch.nn.Module, ids: Sequence[int]) -> tuple[torch.Tensor, ...]:
        """(anchors, positives, negatives) [len(ids), d] of triplets `ids`."""
        order = self.triples[list(ids)].t().reshape(-1)  # all anchors, then positives, ...
        batch = self.graphs.select(order)
        batch.undirected = True
        return tuple(model(batch).split(len(ids)))
