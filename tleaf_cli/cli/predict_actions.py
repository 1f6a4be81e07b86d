"""`tleaf predict` on a train-task action-recognition run (the library's
tasks/action_recognition/predict.py): new videos decoded by argmax and under the rules."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import given_flags, refuse

SHOWN_VIDEOS = 8  # videos the terminal's table shows
SHOWN_STEPS = 6  # steps of a video the table spells out
# PredictSettings' options that only a next-activity run reads (--top-k applies to both)
NEXT_ACTIVITY_ONLY = (
    "way", "beam_width", "temperature", "suffix_rules", "rule_weight", "max_suffix", "samples",
    "seed", "prefix_lengths", "risk",
)  # fmt: skip


def predict_actions(
    ctx: typer.Context,
    run: Path,
    activities: Path,
    rules: Path | None,
    rule: list[str] | None,
    split: str | None,
    out: Path,
    quiet: bool,
    values: dict[str, Any],
) -> None:
    """Decode the activities' videos with the action-recognition run `run` and print the first."""
    from tleaf_cli.tasks.action_recognition.predict import predict_activities

    refuse(given_flags(ctx, *NEXT_ACTIVITY_ONLY), "only for a next-activity run")
    with ui.progress("predicting", quiet) as update:
        summary = predict_activities(
            run, activities, out, rules, tuple(rule or ()), split, values["top_k"],
            on_progress=update,
        )  # fmt: skip
    if not quiet:
        show(summary["predictions"][:SHOWN_VIDEOS])
    videos, accuracy = summary["videos"], summary["accuracy"]
    labelled = (
        ""
        if accuracy is None
        else f"; action accuracy against the file's labels {100 * accuracy['argmax']:.2f}% by "
        f"argmax, {100 * accuracy['constrained']:.2f}% under the rules"
    )
    ui.summary(
        f"{out}: {videos} videos, {summary['steps']} steps; the argmax labels break a rule in "
        f"{summary['argmax_breaking']} videos, the labels under the rules in "
        f"{summary['constrained_breaking']} ({summary['rules']} rules){labelled}; "
        f"{1000 * summary['seconds'] / max(videos, 1):.1f} ms per video",
        quiet,
    )


def _labels(actions: list[str], ingredients: list[str]) -> str:
    pairs = [f"{a}_{i}" for a, i in zip(actions, ingredients, strict=True)]
    more = f" … (+{len(pairs) - SHOWN_STEPS})" if len(pairs) > SHOWN_STEPS else ""
    return " ".join(pairs[:SHOWN_STEPS]) + more


def show(predictions) -> None:
    """The first videos as a table: steps, the argmax labels and the rules they break, the
    labels under the rules and how probable they are against the argmax ones."""
    import math

    rows = []
    for p in predictions:
        changed = sum(
            (a, i) != (ca, ci)
            for a, i, ca, ci in zip(p.actions, p.ingredients, p.constrained_actions,
                                    p.constrained_ingredients, strict=True)
        )  # fmt: skip
        broken = ", ".join(p.argmax_broken[:3]) + (
            f" (+{len(p.argmax_broken) - 3})" if len(p.argmax_broken) > 3 else ""
        )
        relative = math.exp(p.constrained_log_prob - p.argmax_log_prob)
        rows.append(
            [p.video_id, str(len(p)), _labels(p.actions, p.ingredients), broken or "—",
             _labels(p.constrained_actions, p.constrained_ingredients) if changed else "(same)",
             f"{changed} (×{relative:.2g})"]
        )  # fmt: skip
    ui.table(
        f"first {len(rows)} videos",
        ["video", "steps", "argmax", "breaks", "under the rules", "steps changed (× p)"],
        rows,
    )
