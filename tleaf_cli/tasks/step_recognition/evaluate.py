"""`tleaf eval step-recognition`: trained step recognisers (train-task action-recognition on a
`recording-activities` artifact) decoded three ways, scored on the test recordings that keep and
that break their recipe's rules.

Decodings of each run's outputs (`decoding.py`): argmax per step; constrained (the most probable
pair sequence that keeps the rules relevant to it); soft, the rules as a weighted prior
(`soft_pairs`: score − w · [breaks them]), w chosen per run on the val recordings among
`WEIGHTS` (0 is argmax, inf constrained decoding; the best val step accuracy, ties to the
smaller w). A step is right when both its step and its recipe are (pair accuracy).

Which recordings keep their rules is the exact check's (`check-recordings`' checks.parquet: a
recording breaks them when it breaks at least one of its recipe's rules), so a recording a
person performed out of order is scored apart from those done by the book.

Writes step_recognition.json (every run's figures) and step_recognition.md (mean ± s.e. over
seeds per training method and number of training recordings).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

from tleaf_cli.data.artifacts import check_writable, read_artifact, write_text_atomic
from tleaf_cli.errors import InputError
from tleaf_cli.losses import pair_log_probs
from tleaf_cli.tasks.action_recognition.batch import Batch
from tleaf_cli.tasks.action_recognition.decoding import soft_pairs
from tleaf_cli.tasks.action_recognition.violations import CPU, Run, load_run
from tleaf_cli.tasks.model_checking_table import mean_se
from tleaf_cli.tasks.procedure_checks import KIND as CHECKS_KIND
from tleaf_cli.tasks.procedure_checks import SCHEMA_VERSION as CHECKS_SCHEMA

WEIGHTS = (0.0, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, math.inf)
DECODINGS = ("argmax", "constrained", "soft")
GROUPS = ("all", "keep", "break")
METHOD_ORDER = ("none", "exact", "tleaf")
JSON_FILE, MARKDOWN_FILE = "step_recognition.json", "step_recognition.md"


def read_breaks(checks: str | Path) -> dict[str, bool]:
    """recording_id -> it breaks at least one of its recipe's rules (check-recordings'
    checks.parquet; only the recordings it checked)."""
    table, _ = read_artifact(checks, CHECKS_KIND, CHECKS_SCHEMA)
    return {
        r["recording_id"]: bool(r["broken_rules"])
        for r in table.select(["recording_id", "checked", "broken_rules"]).to_pylist()
        if r["checked"]
    }


def decoded_steps(run: Run, split: str, top_k: int) -> tuple[list[str], dict, list[np.ndarray]]:
    """A split's video ids, each weight's decoded pair indices per video, and the labelled
    pair indices per video."""
    data = run.inputs.data
    videos = data.split(split)
    if not videos:
        raise InputError(f"{run.path}: no {split} recordings in {data.path}")
    n = len(data.ingredients)
    decoded: dict[float, list[np.ndarray]] = {w: [] for w in WEIGHTS}
    with torch.no_grad():
        for i in range(0, len(videos), run.batch_size):
            batch = Batch.of(videos[i : i + run.batch_size], CPU)
            log_pairs = pair_log_probs(*run.model(batch.features, batch.lengths))
            chosen = soft_pairs(log_pairs, batch.lengths, run.inputs.rules, top_k, WEIGHTS)
            for w, pairs in chosen.items():
                decoded[w] += [
                    p[:k].numpy() for p, k in zip(pairs, batch.lengths.tolist(), strict=True)
                ]
    labels = [v.actions * n + v.ingredients for v in videos]
    return [v.video_id for v in videos], decoded, labels


def _accuracy(hits: Sequence[np.ndarray]) -> float | None:
    return float(np.concatenate(hits).mean()) if hits else None


def score_run(run_dir: str | Path, breaks: dict[str, bool], cache: dict | None = None) -> dict:
    """One run's figures: its method, seed and training recordings, the val-chosen weight, and
    test step accuracy per decoding on all / keeping / breaking recordings."""
    run = load_run(run_dir, cache)
    config = json.loads((Path(run_dir) / "config.json").read_text())
    top_k = int(config["settings"]["decode_top_k"])
    _, val, val_labels = decoded_steps(run, "val", top_k)
    val_accuracy = {
        w: _accuracy([p == y for p, y in zip(val[w], val_labels, strict=True)]) for w in WEIGHTS
    }
    chosen = max(WEIGHTS, key=lambda w: (val_accuracy[w], -w))
    ids, test, labels = decoded_steps(run, "test", top_k)
    missing = [v for v in ids if v not in breaks]
    if missing:
        raise InputError(
            f"{run_dir}: {len(missing)} test recordings not in the checks (first: {missing[0]})"
        )
    weight_of = {"argmax": 0.0, "constrained": math.inf, "soft": chosen}
    figures: dict[str, dict] = {}
    for decoding, w in weight_of.items():
        hits = [p == y for p, y in zip(test[w], labels, strict=True)]
        figures[decoding] = {
            "all": _accuracy(hits),
            "keep": _accuracy([h for h, v in zip(hits, ids, strict=True) if not breaks[v]]),
            "break": _accuracy([h for h, v in zip(hits, ids, strict=True) if breaks[v]]),
        }
    return {
        "run": str(run_dir),
        "method": run.row["method"],
        "seed": run.row["seed"],
        "train_recordings": run.row["train_videos"],
        "test_recordings": {
            "keep": sum(not breaks[v] for v in ids),
            "break": sum(breaks[v] for v in ids),
        },
        "weight": _weight_text(chosen),
        "val_step_accuracy": {_weight_text(w): a for w, a in val_accuracy.items()},
        "test_step_accuracy": figures,
    }


def _weight_text(w: float) -> str:
    return "inf" if math.isinf(w) else f"{w:g}"


def summarise(rows: Sequence[dict]) -> list[dict]:
    """Mean ± s.e. over seeds per (method, training recordings)."""
    groups: dict[tuple[str, int], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["method"], r["train_recordings"]), []).append(r)
    out = []
    for (method, size), runs in sorted(groups.items(), key=lambda kv: _order(*kv[0])):
        cells = {
            d: {g: _mean_se([r["test_step_accuracy"][d][g] for r in runs]) for g in GROUPS}
            for d in DECODINGS
        }
        out.append(
            {
                "method": method,
                "train_recordings": size,
                "seeds": len(runs),
                "weights": sorted({r["weight"] for r in runs}, key=float),
                "test_step_accuracy": cells,
            }
        )
    return out


def _order(method: str, size: int) -> tuple:
    """Sizes increasing; within a size the reference first, then the logic losses."""
    known = METHOD_ORDER.index(method) if method in METHOD_ORDER else len(METHOD_ORDER)
    return size, known, method


def _mean_se(values: Sequence[float | None]) -> tuple[float, float]:
    """Mean and standard error of the values that exist; nan where there are none (a s.e. of
    one value is nan)."""
    present = [v for v in values if v is not None]
    if not present:
        return math.nan, math.nan
    mean, se = mean_se(present)
    return mean, se if len(present) > 1 else math.nan


def _cell(mean_and_se: tuple[float, float]) -> str:
    mean, se = mean_and_se
    if math.isnan(mean):
        return "–"
    return f"{100 * mean:.1f}" + ("" if math.isnan(se) else f" ± {100 * se:.1f}")


def markdown(summary: Sequence[dict], rows: Sequence[dict]) -> str:
    """The table: per method and training recordings, test step accuracy (%) by decoding, on
    all test recordings and on those that keep and that break their recipe's rules."""
    counts = rows[0]["test_recordings"] if rows else {"keep": 0, "break": 0}
    head = ["method", "train recordings", "seeds", "soft w (val)"]
    head += [f"{d} {g}" for d in DECODINGS for g in GROUPS]
    lines = [
        f"Test step accuracy (%; a step right when its step and recipe are), mean ± s.e. over "
        f"seeds, on all test recordings, the {counts['keep']} that keep and the "
        f"{counts['break']} that break their recipe's rules:",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for s in summary:
        cells = [s["method"], str(s["train_recordings"]), str(s["seeds"]), ", ".join(s["weights"])]
        cells += [_cell(s["test_step_accuracy"][d][g]) for d in DECODINGS for g in GROUPS]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def evaluate_step_recognition(
    runs: Sequence[str | Path], checks: str | Path, out_dir: str | Path
) -> dict:
    """Score every run (`score_run`), summarise, write step_recognition.json and .md."""
    out_dir = Path(out_dir)
    for name in (JSON_FILE, MARKDOWN_FILE):
        check_writable(out_dir / name)
    if not runs:
        raise InputError("no runs to evaluate")
    breaks = read_breaks(checks)
    cache: dict = {}
    rows = [score_run(r, breaks, cache) for r in runs]
    summary = summarise(rows)
    report = {"weights": [_weight_text(w) for w in WEIGHTS], "summary": summary, "runs": rows}
    write_text_atomic(out_dir / JSON_FILE, json.dumps(report, indent=2))
    write_text_atomic(out_dir / MARKDOWN_FILE, markdown(summary, rows))
    return report
