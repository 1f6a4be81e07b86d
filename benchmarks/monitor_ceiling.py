"""How far the monitors' shares alone decide satisfaction, with no learning (issue 13).

For every test formula of a tier, its DFA's monitor shares μ_acc, μ_rej (logic/monitors.py,
exact) and each test trace's ψ(w) (satisfying and uniform violating traces, as Table I scores
them): the nearest-mean rule calls w satisfying when ψ(w) is nearer μ_acc than μ_rej. Printed:
the per-formula balanced accuracy averaged over formulas (each formula its own classes), the
same on the train formulas, and the rule's share of formulas at or above 0.95.

    python benchmarks/monitor_ceiling.py out/mc/low [--slots 6]

The rule is what a q built on these features could reach with one projection per formula and
no GNN: a yardstick for the trained q_m, not a Table I figure (Table I fits one MLP on the train
formulas' vectors and scores it on unseen ones).
"""

from __future__ import annotations

import argparse
from collections import defaultdict

import numpy as np

from tleaf_cli.data.dfa_table import dfa_from_row, read_dfas
from tleaf_cli.data.traces import read_traces
from tleaf_cli.logic.monitors import MonitorBank


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tier", help="a folder with dfas.parquet and traces.parquet")
    parser.add_argument("--slots", type=int, default=6, help="atom slots of the monitors")
    args = parser.parse_args()
    bank = MonitorBank(args.slots)
    rows = {r["formula_id"]: r for r in read_dfas(f"{args.tier}/dfas.parquet").rows}
    by_formula = defaultdict(list)
    for t in read_traces(f"{args.tier}/traces.parquet").to_pylist():
        if t["source"] == "uniform" and t["split"] in ("train", "test"):
            by_formula[t["formula_id"]].append(t)
    scores: dict[str, list[float]] = defaultdict(list)
    for fid, traces in by_formula.items():
        dfa = dfa_from_row(rows[fid])
        accepted, rejected = bank.of_dfa(dfa)
        truth = dfa.alphabet.truth()
        psi = np.stack(
            [bank.of_word(truth, [dfa.alphabet.index(x) for x in t["trace"]]) for t in traces]
        )
        label = np.array([t["label"] for t in traces])
        called = ((psi - rejected) ** 2).sum(1) > ((psi - accepted) ** 2).sum(1)
        recalls = [(called[label]).mean()] + ([(~called[~label]).mean()] if (~label).any() else [])
        scores[traces[0]["split"]].append(float(np.mean(recalls)))
    for split in ("train", "test"):
        s = np.array(scores[split])
        print(
            f"{args.tier} {split}: {len(s)} formulas, nearest-mean balanced accuracy "
            f"{100 * s.mean():.2f}, formulas >= 0.95: {100 * (s >= 0.95).mean():.0f} %"
        )


if __name__ == "__main__":
    main()
