"""Which rules to decode under: the candidate budget k of constrained decoding, on VALIDATION.

For trained action-recognition runs (train-task folders) of a SYNTHETIC activities file: the val
videos decoded by argmax and by constrained decoding with the rules over each video's top-k
candidate pairs (tasks/action_recognition/decoding.py), for several k: val action accuracy,
violations (the rules relevant to the decoded pairs), decoding ms per video. The pipeline's
`DECODE_TOP_K` is chosen here, never on test.

    python benchmarks/decode_choice.py RUN_DIR... [--k 3 5 10 20 40]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from tleaf_cli.knowledge.base import read_knowledge_base
from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
from tleaf_cli.losses import pair_vocabulary
from tleaf_cli.tasks.action_recognition.activities import read_activities
from tleaf_cli.tasks.action_recognition.models import ActionRecognizer
from tleaf_cli.tasks.action_recognition.train import score


def load_run(run: Path) -> tuple[ActionRecognizer, dict]:
    config = json.loads((run / "config.json").read_text())
    s = config["settings"]
    model = ActionRecognizer(
        s["model"], config["feature_dim"], len(config["actions"]), len(config["ingredients"]),
        s["hidden"], s["head_hidden"], s["dropout"],
    )  # fmt: skip
    model.load_state_dict(torch.load(run / "weights.pt", weights_only=True))
    return model.eval(), config


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--k", nargs="+", type=int, default=[3, 5, 10, 20, 40])
    args = parser.parse_args()
    torch.set_num_threads(1)
    device = torch.device("cpu")
    rows: dict[str, list[dict]] = {}
    for run in args.runs:
        model, config = load_run(run)
        data = read_activities(config["inputs"][0]["path"])
        kb = read_knowledge_base(config["inputs"][1]["path"])
        rules = KnowledgeRuleSets(kb, pair_vocabulary(data.actions, data.ingredients))
        val = data.split("val")
        rows.setdefault("argmax", []).append(score(model, data, val, 16, device, rules))
        for k in args.k:
            rows.setdefault(f"k={k}", []).append(score(model, data, val, 16, device, rules, k))
    print(f"{len(args.runs)} runs, val split; mean over runs")
    print("| decoding | val action acc | violations | ms / video | most rounds |")
    print("|---|---|---|---|---|")
    for name, rs in rows.items():
        acc = np.mean([r["action_accuracy"] for r in rs])
        viol = np.mean([r["violation_fraction"] for r in rs])
        ms = 1000 * np.mean([r.get("decode_seconds_per_video", 0.0) for r in rs])
        rounds = max(r.get("decode_rounds", 0) for r in rs)
        print(f"| {name} | {100 * acc:.2f}% | {100 * viol:.1f}% | {ms:.1f} | {rounds} |")


if __name__ == "__main__":
    main()
