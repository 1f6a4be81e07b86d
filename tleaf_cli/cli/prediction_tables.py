"""The terminal's tables of `tleaf predict`: the first predictions of a next-activity run, the
first videos of an action-recognition run (shared by the command's ways, predict.py)."""

from __future__ import annotations

import math

from tleaf_cli import ui

SHOWN_STEPS = 6  # steps of a video the table spells out


def show(predictions, risk: float) -> None:
    """The first predictions as a table: case, prefix length, next activity (p), the rules
    broken for good and those at risk (undecided, probability of holding below `risk`), the
    recommendation."""
    rows = []
    for p in predictions:
        if p.reason is not None:
            rows.append([p.case_id, str(p.prefix_length), f"— ({p.reason})", "", "", ""])
            continue
        name, q = p.next_activities[0]
        if p.end_probability > q:
            name, q = "(end)", p.end_probability
        broken = [r.rule for r in p.rules if r.verdict == "permanently violated"]
        at_risk = [
            f"{r.rule} ({r.probability:.2f})"
            for r in p.rules
            if r.method == "sampled" and r.probability < risk
        ]
        advice = ""
        if p.recommendation_status == "found":
            advice = f"{' → '.join(p.recommendation)} (×{p.recommendation_relative:.2g})"
        elif p.recommendation_status == "none":
            advice = "no continuation keeps every rule"
        rows.append(
            [p.case_id, str(p.prefix_length), f"{name} ({q:.2f})", ", ".join(broken) or "—",
             ", ".join(at_risk) or "—", advice or "—"]
        )  # fmt: skip
    ui.table(
        f"first {len(rows)} predictions",
        ["case", "k", "next (p)", "broken", "at risk (p holds)", "recommendation (× p)"],
        rows,
    )


def _labels(actions: list[str], ingredients: list[str]) -> str:
    pairs = [f"{a}_{i}" for a, i in zip(actions, ingredients, strict=True)]
    more = f" … (+{len(pairs) - SHOWN_STEPS})" if len(pairs) > SHOWN_STEPS else ""
    return " ".join(pairs[:SHOWN_STEPS]) + more


def show_videos(predictions) -> None:
    """The first videos as a table: steps, the argmax labels and the rules they break, the
    labels under the rules and how probable they are against the argmax ones."""
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
