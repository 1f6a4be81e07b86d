"""How far the monitors' shares alone decide satisfaction, with no learned q.

For every formula of a tier, its DFA's monitor shares μ_acc, μ_rej (logic/monitors.py, exact,
per length range as the pipeline's q_m reads them) and each trace's ψ(w) (satisfying and uniform
violating traces, as Table I scores them). Two fixed rules, per-formula balanced accuracy
averaged over the test formulas (and the train formulas, for comparison):

* nearest mean: w satisfies φ when ψ(w) is nearer μ_acc than μ_rej (in w's length range);
* naive Bayes: the monitors as independent evidence, log-odds
  Σ_k ψ_k log(a_k / r_k) + (1 − ψ_k) log((1 − a_k) / (1 − r_k)) > 0, with a, r the shares
  clipped to [1e-3, 1 − 1e-3]: a score linear in ψ(w) with weights fixed by the formula.
* with `--joint K`, naive Bayes plus the evidence of the word's first K letters and its last K
  letters, each block read jointly (exact shares of the DFA's words of that length starting,
  and ending, with that block): what monitors over whole letter blocks would add.

With `--mlp`, Table I's classifier (the MLP 512-128 of `tleaf eval model-checking`, balanced,
chosen on val, at most `--mlp-epochs`) fitted on the train formulas' raw features instead of
q's vectors and scored on the test formulas, with the pair features `concat` ([μ; ψ], Table
I's), `rich` (eval's `--pair-features rich`: |μ − ψ| and μ ⊙ ψ added) and `nb` (ψ times the
naive-Bayes log-odds added: the products the rule above sums).

    python benchmarks/monitor_ceiling.py out/mc/low [--slots 6] [--ranges 3] [--joint 2] [--mlp]

A yardstick for the trained q_m, not a Table I figure: the rules use one formula's exact shares
at a time, no learned embedding.
"""

from __future__ import annotations

import argparse
from collections import defaultdict

import numpy as np
import torch

from tleaf_cli.data.dfa_table import dfa_from_row, read_dfas
from tleaf_cli.data.monitor_cache import monitor_shares
from tleaf_cli.data.traces import read_traces
from tleaf_cli.embed.evidence import EPS  # the evidence block's clip, the same naive Bayes
from tleaf_cli.logic.monitors import MonitorBank
from tleaf_cli.tasks.model_checking import EvalSettings, Split, _fit_mlp, pair_features


def log_odds(shares: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per feature, the naive-Bayes log-odds of a monitor accepting and of it rejecting."""
    a, r = np.clip(shares[..., 0, :], EPS, 1 - EPS), np.clip(shares[..., 1, :], EPS, 1 - EPS)
    return np.log(a / r), np.log((1 - a) / (1 - r))


def ends_log_odds(dfa, words: list[list[int]], k: int, max_length: int) -> np.ndarray:
    """Per word (length T >= k), the log-odds that its first k letters, and its last k letters,
    each jointly, give for "accepted" among the DFA's words of length T (exact, from where the
    letters lead: the share of words accepted from each state, and where T - k letters lead);
    0 for shorter words. Unlike the two-literal monitors, a joint letter block sees any function
    of those letters, parity included (formulas like b <-> (X a <-> !c))."""
    table, accepting = dfa.table, dfa.accepting.astype(float)
    accepted_from = [accepting]  # [t][s]: the share of t-letter words accepted from s
    reached = [np.eye(dfa.num_states)[dfa.initial]]  # [t][s]: P(at s after t letters)
    for _ in range(max_length):
        accepted_from.append(accepted_from[-1][table].mean(axis=1))
        step = np.zeros(dfa.num_states)
        np.add.at(step, table.ravel(), np.repeat(reached[-1], dfa.alphabet.size))
        reached.append(step / dfa.alphabet.size)
    out = np.zeros(len(words))
    for i, word in enumerate(words):
        length = len(word)
        if length < k or length > max_length:
            continue
        p = accepted_from[length][dfa.initial]  # P(accepted) at this length
        state = dfa.initial
        for letter in word[:k]:
            state = table[state, letter]
        first = accepted_from[length - k][state]
        ends = np.arange(dfa.num_states)
        for letter in word[-k:]:
            ends = table[ends, letter]
        last = reached[length - k] @ accepting[ends]
        # P(block | accepted) / P(block | rejected); the block's own share 1 / |Σ|^k cancels
        odds = np.clip([first, last], EPS, 1 - EPS)
        p = np.clip(p, EPS, 1 - EPS)
        out[i] = np.sum(np.log(odds / p) - np.log((1 - odds) / (1 - p)))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tier", help="a folder with dfas.parquet and traces.parquet")
    parser.add_argument("--slots", type=int, default=6, help="atom slots of the monitors")
    parser.add_argument("--ranges", type=int, default=3, help="length ranges (the pipeline's 3)")
    parser.add_argument("--mlp", action="store_true", help="also fit Table I's MLP on them")
    parser.add_argument("--mlp-epochs", type=int, default=15, help="the MLP's epochs at most")
    parser.add_argument(
        "--joint", type=int, default=0, help="K > 0: add the first and last K letters' evidence"
    )
    args = parser.parse_args()
    torch.set_num_threads(1)
    bank = MonitorBank(args.slots, ranges=args.ranges)
    rows = {r["formula_id"]: r for r in read_dfas(f"{args.tier}/dfas.parquet").rows}
    by_formula = defaultdict(list)
    for t in read_traces(f"{args.tier}/traces.parquet").to_pylist():
        if t["source"] == "uniform":
            by_formula[t["formula_id"]].append(t)
    scores: dict[tuple[str, str], list[float]] = defaultdict(list)
    pairs: dict[str, list] = defaultdict(list)  # split -> (shares, ψ, label) per formula
    dfas = [dfa_from_row(rows[fid]) for fid in by_formula]
    for traces, dfa, shares in zip(
        by_formula.values(), dfas, monitor_shares(dfas, bank), strict=True
    ):  # shares: [2, R F]
        truth = dfa.alphabet.truth()
        psi = np.stack(
            [bank.of_word(truth, [dfa.alphabet.index(x) for x in t["trace"]]) for t in traces]
        )
        in_range = np.stack(
            [
                np.repeat(np.eye(bank.ranges)[bank.range_of(len(t["trace"]))], bank.width)
                for t in traces
            ]
        )
        label = np.array([t["label"] for t in traces])
        split = traces[0]["split"]
        pairs[split].append((shares, psi, label))
        accepts, rejects = log_odds(shares)
        rules = {
            "nearest mean": (((psi - shares[1]) ** 2 - (psi - shares[0]) ** 2) * in_range).sum(1),
            "naive Bayes": ((psi * accepts + (1 - psi) * rejects) * in_range).sum(1),
        }
        if args.joint:
            words = [[dfa.alphabet.index(x) for x in t["trace"]] for t in traces]
            rules[f"naive Bayes + first / last {args.joint} letters"] = rules[
                "naive Bayes"
            ] + ends_log_odds(dfa, words, args.joint, bank.max_length)
        for name, score in rules.items():
            called = score > 0
            recalls = [called[label].mean()] + (
                [(~called[~label]).mean()] if (~label).any() else []
            )
            scores[(name, split)].append(float(np.mean(recalls)))
    for (name, split), s in sorted(scores.items()):
        if split == "val":
            continue
        s = np.array(s)
        print(
            f"{args.tier} {split}: {len(s)} formulas, {name} balanced accuracy "
            f"{100 * s.mean():.2f}, formulas >= 0.95: {100 * (s >= 0.95).mean():.0f} %"
        )
    if args.mlp:
        for kind in ("concat", "rich", "nb"):
            split = {name: _raw_split(pairs[name], kind) for name in ("train", "val", "test")}
            settings = EvalSettings(epochs=args.mlp_epochs)
            mlp = _fit_mlp(split["train"], split["val"], settings, balanced=True)
            with torch.no_grad():
                called = (mlp(split["test"].z_formula).squeeze(1) > 0).numpy()
            label = split["test"].label.numpy().astype(bool)
            balanced = np.mean([(called[label == c] == c).mean() for c in (False, True)])
            print(
                f"{args.tier} test: MLP on raw features, {kind}: "
                f"balanced accuracy {100 * balanced:.2f}"
            )


def _raw_split(per_formula: list, kind: str) -> Split:
    """One split's pairs as a Split whose z_formula holds the MLP's whole input (z_trace unused):
    the pair features of [μ_acc ; μ_rej] and ψ(w) (ψ against each of μ_acc, μ_rej for `rich`),
    and for `nb` ψ(w) times the log-odds besides."""
    inputs, labels = [], []
    for shares, psi, label in per_formula:
        phi = np.broadcast_to(shares.reshape(1, -1), (len(psi), shares.size))
        x = [phi, psi]
        if kind == "rich":
            f, w = torch.from_numpy(shares.astype(np.float32)), torch.from_numpy(psi)
            x = [pair_features(f[k].expand(len(psi), -1), w, "rich").numpy() for k in (0, 1)]
        elif kind == "nb":
            accepts, rejects = log_odds(shares)
            x += [psi * accepts, (1 - psi) * rejects]
        inputs.append(np.concatenate(x, axis=1).astype(np.float32))
        labels.append(label)
    z = torch.from_numpy(np.concatenate(inputs))
    y = torch.from_numpy(np.concatenate(labels).astype(np.float32))
    return Split([], z, torch.zeros(len(z), 0), y, ["uniform"] * len(z))


if __name__ == "__main__":
    main()
