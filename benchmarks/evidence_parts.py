"""The distance rule of a q trained with `--evidence`, on the whole vector and on each part.

q's vectors are [learned part ; evidence block] (embed/evidence.py). For the val and test pairs
of a tier (satisfying and uniform violating traces, as Table I scores them), the distance rule
d < τ (τ chosen on val, balanced accuracy as `eval model-checking` computes it) and the mean
per-formula AUC (the share of satisfying-violating pairs of one formula ordered right) on:

* the whole vector (what `eval model-checking` and the T-LEAF loss read),
* the learned part alone,
* the evidence block alone, and the block at its own boundary 2γ² (the naive-Bayes decision).

    python benchmarks/evidence_parts.py out/mc/low/seed0/meta-dfa out/mc/low

A diagnostic, not a Table I figure: it tells whether the learned part adds to the block or
blurs its boundary (docs/embedder.md, "The evidence block").
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from tleaf_cli.data.dfa_table import read_dfas
from tleaf_cli.data.traces import read_traces
from tleaf_cli.embed.load import load_embedder
from tleaf_cli.tasks.model_checking import Split, _balanced_accuracy, _fit_threshold


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", help="a q_m trained with --evidence")
    parser.add_argument("tier", help="a folder with dfas.parquet and traces.parquet")
    args = parser.parse_args()
    torch.set_num_threads(1)
    q = load_embedder(args.model)
    evidence = q.model.evidence
    if evidence is None:
        parser.error(f"{args.model}: not trained with --evidence")
    rows = {r["formula_id"]: r for r in read_dfas(f"{args.tier}/dfas.parquet").rows}
    rows = {k: r for k, r in rows.items() if r["error"] is None}
    traces = [
        t
        for t in read_traces(f"{args.tier}/traces.parquet").to_pylist()
        if t["formula_id"] in rows
        and t["split"] in ("val", "test")
        and (t["label"] or t["source"] == "uniform")
    ]
    ids = list(rows)
    with torch.no_grad():
        by_id = dict(zip(ids, q.embed_formula_rows([rows[i] for i in ids]), strict=True))
        z_trace = q.embed_traces(
            [t["trace"] for t in traces],
            [tuple(rows[t["formula_id"]]["atoms"]) for t in traces],
            [rows[t["formula_id"]]["alphabet"] == "one-hot" for t in traces],
        )
    z_formula = torch.stack([by_id[t["formula_id"]] for t in traces])
    label = np.array([t["label"] for t in traces], dtype=bool)
    split = np.array([t["split"] for t in traces])
    formula = np.array([t["formula_id"] for t in traces])
    val, test = split == "val", split == "test"
    learned = z_formula.shape[1] - evidence.dim
    print(f"{args.model}: γ² = {evidence.boundary / 2:.2f}")
    for name, part in (
        ("whole vector", slice(None)),
        ("learned part", slice(0, learned)),
        ("evidence block", slice(learned, None)),
    ):
        d = (z_formula[:, part] - z_trace[:, part]).pow(2).sum(dim=1).numpy()
        on_val = Split(
            list(formula[val]),
            z_formula[val][:, part],
            z_trace[val][:, part],
            torch.from_numpy(label[val]).float(),
            [t["source"] for t, v in zip(traces, val, strict=True) if v],
        )
        tau = _fit_threshold(on_val)  # eval model-checking's own τ
        auc = []
        for f in np.unique(formula[test]):
            mine = test & (formula == f)
            sat, viol = d[mine & label], d[mine & ~label]
            if len(sat) and len(viol):
                auc.append((sat[:, None] < viol[None, :]).mean())
        line = (
            f"  {name}: distance rule {100 * _balanced_accuracy(d[test] < tau, label[test]):.2f}"
            f" (τ {tau:.3g} on val), per-formula AUC {100 * np.mean(auc):.2f}"
        )
        if name == "evidence block":
            own = _balanced_accuracy(d[test] < evidence.boundary, label[test])
            line += f", at 2γ² (naive Bayes) {100 * own:.2f}"
        print(line)


if __name__ == "__main__":
    main()
