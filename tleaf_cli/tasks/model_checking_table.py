"""One results table from many model-checking reports: mean ± standard error over seeds,
one row per embedder and preset (train-meta --preset), one column per label (tier), next to
the paper's Table I."""

from __future__ import annotations

import json
import math
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path

from tleaf_cli.data.artifacts import write_text_atomic
from tleaf_cli.errors import InputError

# Table I of the paper: accuracy %, mean (s.e.) over 3 runs.
PAPER = {
    "syntax": {"low": (56.16, 0.92), "moderate": (54.13, 0.62), "high": (50.00, 0.00)},
    "dfa": {"low": (83.43, 0.73), "moderate": (78.43, 1.54), "high": (66.90, 0.70)},
}
ROW_NAMES = {"syntax": "Syntax tree", "dfa": "DFA (T-LEAF)"}
CLASSIFIER_ROWS = (
    ("mlp", "MLP 512-128, balanced accuracy"),
    ("mlp_plain", "MLP 512-128, accuracy (2 : 1 satisfying)"),
    ("hard", "MLP, hard negatives only"),
    ("mlp_all", "MLP fitted on all negatives, balanced accuracy"),
    ("hard_all", "MLP fitted on all negatives, hard negatives only"),
    ("distance", "distance rule, balanced accuracy"),
)

# what `eval model-checking --pair-features` feeds the MLP
PAIR_INPUTS = {
    "concat": "concat, [z_φ ; z_w]",
    "rich": "rich, [z_φ ; z_w ; abs(z_φ − z_w) ; z_φ ⊙ z_w]",
}


def mean_se(values: Sequence[float]) -> tuple[float, float]:
    n = len(values)
    mean = sum(values) / n
    if n < 2:
        return mean, 0.0
    var = sum((v - mean) ** 2 for v in values) / (n - 1)
    return mean, math.sqrt(var / n)


def results_table(report_paths: Sequence[str | Path], out: str | Path) -> str:
    """Write a markdown table of test accuracy by embedder x label: the MLP fitted on the paper's
    negatives (balanced accuracy, plain accuracy, and its share of hard negatives caught), the MLP
    fitted on all negatives (balanced accuracy, hard negatives; where the reports have it), and
    the distance rule."""
    cells: dict[tuple[str, str, str], list[float]] = defaultdict(list)
    labels: list[str] = []
    inputs: set[str] = set()  # the MLPs' pair features, as the reports name them
    for path in report_paths:
        try:
            r = json.loads(Path(path).read_text())
            key = (r["embedder"], r.get("preset", ""), r["label"])
            # balanced accuracy (chance 50 %, as the paper's balanced sets) where the report
            # has it; older reports have only the plain accuracy and leave those cells blank
            scores = {
                "mlp": r["mlp"].get("balanced_accuracy"),
                "mlp_plain": r["mlp"]["accuracy"],
                "hard": r["mlp"]["hard_negative_accuracy"],
                "distance": r["distance"].get("balanced_accuracy"),
            }
            if "mlp_all_negatives" in r:  # reports written before the second MLP have none
                scores["mlp_all"] = r["mlp_all_negatives"].get("balanced_accuracy")
                scores["hard_all"] = r["mlp_all_negatives"]["hard_negative_accuracy"]
            inputs.add(r.get("settings", {}).get("pair_features", "concat"))
        except (OSError, ValueError, KeyError) as e:
            raise InputError(f"{path}: not a model-checking report ({e})") from None
        for clf, value in scores.items():
            if value is not None:
                cells[(*key, clf)].append(100 * value)
        if r["label"] not in labels:
            labels.append(r["label"])
    # rows: the syntax baseline, then the DFA embedder's presets, the paper's first
    order = {"syntax": 0, "dfa": 1, "paper": 0, "best": 1}
    rows = sorted({k[:2] for k in cells}, key=lambda k: (order[k[0]], order.get(k[1], 2), k[1]))

    def fmt(values: list[float]) -> str:
        if not values:
            return "–"
        m, se = mean_se(values)
        return f"{m:.2f} ± {se:.2f} (n={len(values)})"

    lines = [
        "| embedder | classifier | " + " | ".join(labels) + " |",
        "|---|---|" + "---|" * len(labels),
    ]
    for i, (e, preset) in enumerate(rows):
        title = ROW_NAMES[e] + (f", preset {preset}" if e == "dfa" and preset else "")
        for clf, name in CLASSIFIER_ROWS:
            values = [cells.get((e, preset, lab, clf), []) for lab in labels]
            if not any(values):  # no report has it (e.g. no --all-negatives MLP): no row
                continue
            lines.append(f"| {title} | {name} | " + " | ".join(map(fmt, values)) + " |")
        if i + 1 == len(rows) or rows[i + 1][0] != e:  # the paper's figures after its kind
            paper = [PAPER[e].get(lab) for lab in labels]
            shown = [f"{p[0]:.2f} ± {p[1]:.2f}" if p else "–" for p in paper]
            lines.append(f"| {ROW_NAMES[e]} | the paper's (MLP) | " + " | ".join(shown) + " |")
    text = "\n".join(lines) + "\n"
    named = ", ".join(PAIR_INPUTS.get(i, i) for i in sorted(inputs))
    text += f"\nThe MLPs' input (pair features): {named}.\n"
    write_text_atomic(out, text)
    return text
