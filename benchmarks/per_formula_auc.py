"""Which test formulas does q rank badly? (docs/results/model_checking.md, "What was tried")

For each test formula of a SYNTHETIC tier: the AUC of −d(z_φ, z_w) between its satisfying traces
and its uniform violating ones (1: every satisfying trace nearer than every violating one; 0.5:
chance), then the mean per-formula AUC beside the global AUC (one threshold for all formulas),
the same split between formulas with an equivalence `<->` and the others, and the worst formulas.

    python benchmarks/per_formula_auc.py TIER_DIR Q_DIR [Q_DIR ...]

TIER_DIR holds dfas.parquet and traces.parquet (with a split); Q_DIR is a train-meta folder.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from sklearn.metrics import roc_auc_score

from tleaf_cli.data.dfa_table import read_dfas
from tleaf_cli.data.traces import read_traces
from tleaf_cli.embed.load import load_embedder


def per_formula_auc(tier: Path, model: Path) -> tuple[dict[str, float], float, dict[str, str]]:
    rows = {r["formula_id"]: r for r in read_dfas(tier / "dfas.parquet").rows if not r["error"]}
    traces = [
        t
        for t in read_traces(tier / "traces.parquet").to_pylist()
        if t["split"] == "test"
        and t["formula_id"] in rows
        and (t["label"] or t["source"] == "uniform")
    ]
    q = load_embedder(model)
    ids = sorted({t["formula_id"] for t in traces})
    z_formula = dict(zip(ids, q.embed_formula_rows([rows[i] for i in ids]), strict=True))
    z_trace = q.embed_traces(
        [t["trace"] for t in traces],
        [tuple(rows[t["formula_id"]]["atoms"]) for t in traces],
        [rows[t["formula_id"]]["alphabet"] == "one-hot" for t in traces],
    )
    d = np.array(
        [
            float((z_formula[t["formula_id"]] - z).pow(2).sum())
            for t, z in zip(traces, z_trace, strict=True)
        ]
    )
    label = np.array([t["label"] for t in traces])
    formula = np.array([t["formula_id"] for t in traces])
    aucs = {
        i: float(roc_auc_score(label[formula == i], -d[formula == i]))
        for i in ids
        if len(set(label[formula == i])) == 2
    }
    return aucs, float(roc_auc_score(label, -d)), {i: rows[i]["formula"] for i in ids}


def main(tier: str, *models: str) -> None:
    for model in models:
        aucs, overall, text = per_formula_auc(Path(tier), Path(model))
        values = np.array(list(aucs.values()))
        eq = [a for i, a in aucs.items() if "<->" in text[i]]
        other = [a for i, a in aucs.items() if "<->" not in text[i]]
        print(
            f"{model}: {len(values)} formulas, mean per-formula AUC {values.mean():.3f}, "
            f"global AUC {overall:.3f}; above 0.95: {(values > 0.95).sum()}, "
            f"below 0.7: {(values < 0.7).sum()}"
        )
        print(
            f"  with <->: {len(eq)} formulas, {np.mean(eq):.3f}; others: {len(other)}, "
            f"{np.mean(other):.3f}"
        )
        for i in sorted(aucs, key=aucs.get)[:5]:
            print(f"  {aucs[i]:.2f}  {text[i]}")


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    main(*sys.argv[1:])
