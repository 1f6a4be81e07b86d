"""`tleaf predict`: a next-activity run's predictions for the running cases of a cases artifact
(predict.py's `Predictor`), written as the `predictions` artifact, one row per (case, prefix
length); the schema is docs/monitoring.md's.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path

import pyarrow as pa

from tleaf_cli.data.artifacts import check_writable, describe_inputs, write_artifact
from tleaf_cli.data.cases import Case
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.errors import InputError
from tleaf_cli.settings.next_activity import PredictSettings, prefix_lengths
from tleaf_cli.tasks.next_activity.evaluate import check_same_log
from tleaf_cli.tasks.next_activity.predict import Prediction, Predictor, cut

KIND = "predictions"
SCHEMA_VERSION = 1
END = "<end>"  # true_next where the replayed case ended after the prefix
BATCH = 256  # prefixes predicted together

_NAMES = pa.list_(pa.string())
_VALUES = pa.list_(pa.list_(pa.string()))
SCHEMA = pa.schema(
    [
        ("case_id", pa.string()),
        ("split", pa.string()),
        ("prefix_length", pa.int32()),
        ("prefix", _NAMES),
        ("reason", pa.string()),
        (
            "next_activities",
            pa.list_(pa.struct([("activity", pa.string()), ("probability", pa.float64())])),
        ),
        ("end_probability", pa.float64()),
        (
            "next_attributes",
            pa.list_(
                pa.struct(
                    [
                        ("attribute", pa.string()),
                        ("value", pa.string()),
                        ("probability", pa.float64()),
                    ]
                )
            ),
        ),
        ("suffix", _NAMES),
        ("suffix_values", _VALUES),
        ("suffix_log_prob", pa.float64()),
        ("suffix_found", pa.bool_()),
        (
            "rules",
            pa.list_(
                pa.struct(
                    [
                        ("rule", pa.string()),
                        ("verdict", pa.string()),
                        ("probability", pa.float64()),
                        ("low", pa.float64()),
                        ("high", pa.float64()),
                        ("method", pa.string()),
                    ]
                )
            ),
        ),
        ("samples_at_cap", pa.int32()),
        ("recommendation_status", pa.string()),
        ("recommendation", _NAMES),
        ("recommendation_values", _VALUES),
        ("recommendation_log_prob", pa.float64()),
        ("recommendation_relative", pa.float64()),
        ("true_next", pa.string()),
        ("true_suffix", _NAMES),
    ]
)


def running_prefixes(
    cases: Sequence[Case], lengths: Sequence[int] | None
) -> list[tuple[Case, Case]]:
    """(case, its prefix) pairs: every case as it is (running), or with `lengths` each case cut
    at each length it reaches (cases shorter skipped), case by case."""
    if lengths is None:
        return [(c, c) for c in cases]
    return [(c, cut(c, k)) for c in cases for k in lengths if len(c) >= k]


def predict_cases(
    run_dir: str | os.PathLike,
    cases_path: str | os.PathLike,
    out: str | os.PathLike,
    settings: PredictSettings | None = None,
    rules_path: str | os.PathLike | None = None,
    rule_names: Sequence[str] = (),
    split: str | None = None,
    on_progress: Callable[[int, int], None] | None = None,
) -> dict:
    """Predict every running case of `cases_path` (or of its `split`; with
    `settings.prefix_lengths`, its cases replayed as running) and write the `predictions`
    artifact to `out`, atomically; a summary: rows, predicted, the rule names, the first
    predictions, seconds, the predicted suffixes that reach `max_suffix` (and, replayed, the
    true ones that long). InputError, nothing written, for a folder that is not a
    next-activity run, cases of another preprocessing of the log, no cases to predict, or
    rules that cannot be read."""
    settings = settings or PredictSettings()
    settings.check()
    check_writable(out)
    predictor = Predictor.load(run_dir, settings, rules_path, rule_names)
    cases = read_cases(cases_path)
    check_same_log(cases, predictor.encoder, run_dir)
    chosen = cases.cases
    if split is not None:
        chosen = [c for c in cases.cases if c.split == split]
        if not chosen:
            have = ", ".join(sorted(cases.split_counts())) or "none"
            raise InputError(f"{cases_path}: no cases in the split {split!r} (it has: {have})")
    lengths = None if settings.prefix_lengths is None else prefix_lengths(settings.prefix_lengths)
    pairs = running_prefixes(chosen, lengths)
    if not pairs:
        raise InputError(f"{cases_path}: no case reaches the prefix lengths {lengths}")
    start = time.perf_counter()
    predictions = predict_pairs(predictor, pairs, on_progress)
    seconds = time.perf_counter() - start
    table = predictions_table(pairs, predictions, replayed=lengths is not None)
    params = {
        "run": os.fspath(Path(run_dir).resolve()),
        "rules": None if predictor.rules is None else predictor.rules.path,
        "rule_names": list(predictor.rule_names),
        "attributes": list(predictor.encoder.attributes),
        "split": split,
        "replayed": lengths is not None,
        "settings": asdict(settings),
    }
    inputs = [cases_path] + ([] if predictor.rules is None else [predictor.rules.path])
    write_artifact(
        table, out, kind=KIND, schema=SCHEMA_VERSION, params=params,
        inputs=describe_inputs(inputs),
    )  # fmt: skip
    return {
        "rows": len(predictions),
        "predicted": sum(p.reason is None for p in predictions),
        "rule_names": list(predictor.rule_names),
        "unseen": dict(predictor.rules.unseen) if predictor.rules is not None else {},
        "predictions": predictions,
        "seconds": seconds,
        # a predicted rest of the case that runs to the cap is most likely a loop (eval's at_cap)
        "suffixes_at_cap": sum(
            p.suffix is not None and len(p.suffix) >= settings.max_suffix for p in predictions
        ),
        "true_at_cap": None
        if lengths is None
        else sum(len(case) - len(prefix) >= settings.max_suffix for case, prefix in pairs),
    }


def predict_pairs(
    predictor: Predictor,
    pairs: Sequence[tuple[Case, Case]],
    on_progress: Callable[[int, int], None] | None = None,
) -> list[Prediction]:
    """The predictions of `running_prefixes`' pairs, BATCH prefixes at a time (the batches seed
    the samples: the command and `tl.load_run(...).predict` batch alike, so they agree)."""
    predictions: list[Prediction] = []
    for first in range(0, len(pairs), BATCH):
        predictions += predictor.predict([p for _, p in pairs[first : first + BATCH]])
        if on_progress is not None:
            on_progress(min(first + BATCH, len(pairs)), len(pairs))
    return predictions


def predictions_table(
    pairs: Sequence[tuple[Case, Case]], predictions: Sequence[Prediction], replayed: bool
) -> pa.Table:
    """The artifact's rows (`SCHEMA`), one per prediction."""
    rows = []
    for (case, prefix), p in zip(pairs, predictions, strict=True):
        k = len(prefix)
        rows.append(
            {
                "case_id": case.case_id,
                "split": case.split,
                "prefix_length": k,
                "prefix": list(prefix.activities),
                "reason": p.reason,
                "next_activities": [
                    {"activity": a, "probability": q} for a, q in p.next_activities
                ],
                "end_probability": p.end_probability,
                "next_attributes": [
                    {"attribute": a, "value": v, "probability": q} for a, v, q in p.next_attributes
                ],
                "suffix": _list(p.suffix),
                "suffix_values": _nested(p.suffix_values),
                "suffix_log_prob": p.suffix_log_prob,
                "suffix_found": p.suffix_found,
                "rules": [vars(r) for r in p.rules],
                "samples_at_cap": p.samples_at_cap,
                "recommendation_status": p.recommendation_status,
                "recommendation": _list(p.recommendation),
                "recommendation_values": _nested(p.recommendation_values),
                "recommendation_log_prob": p.recommendation_log_prob,
                "recommendation_relative": p.recommendation_relative,
                "true_next": (case.activities[k] if k < len(case) else END) if replayed else None,
                "true_suffix": list(case.activities[k:]) if replayed else None,
            }
        )
    return pa.Table.from_pylist(rows, schema=SCHEMA)


def _list(items) -> list | None:
    return None if items is None else list(items)


def _nested(items) -> list | None:
    return None if items is None else [list(row) for row in items]
