"""Choosing a model's settings on validation (`--grid`): one run per combination of the grid's
values, the best val score kept — the model selection of the field's protocols, never on test.

Each candidate trains from the same seed into `<run>/grid/<field-value_...>/` (a whole run
folder: resumable, inspectable); the best by the task's val score (ties: the first in the
grid's order) is copied into the run's folder (`run_folder.adopt_run`). Its config.json holds
the chosen settings, with `grid` naming the grid they were chosen from, so `eval` rebuilds the
chosen model; metrics.json's "grid" lists every candidate's settings and val score. A λ choice
is made on the chosen model afterwards, not across the grid (the settings refuse both at once).
No torch here.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

from tleaf_cli.data.artifacts import write_text_atomic
from tleaf_cli.errors import InputError
from tleaf_cli.settings.training import grid_axes, grid_candidates
from tleaf_cli.training.run_folder import CONFIG, METRICS, adopt_run

CANDIDATES = "grid"  # the folder of a run's grid candidates, inside the run's folder


def train_choosing_settings(
    train: Callable[[Path, Any], dict],
    out_dir: Path,
    settings: Any,
    score: str,
    resume: bool = False,
) -> dict:
    """One run `train(folder, candidate_settings)` per combination of `settings.grid`, the one
    with the best val `score` (its metrics' "best" entry) copied to `out_dir`; returns its
    metrics, whose "grid" names the choice and every candidate. `resume`: the candidates resume
    (`train` does); InputError, before any training, where `out_dir` holds candidates of
    another grid (`check_same_grid`)."""
    axes = grid_axes(settings)
    grid = [(one, {name: getattr(one, name) for name in axes}) for one in grid_candidates(settings)]
    names = [candidate_name(values) for _, values in grid]
    if resume:
        check_same_grid(out_dir, names)
    candidates = []
    for (one, values), name in zip(grid, names, strict=True):
        folder = out_dir / CANDIDATES / name
        metrics = train(folder, one)
        candidates.append(
            {
                "settings": values,
                score: metrics["best"][score],
                "run": f"{CANDIDATES}/{folder.name}",
            }
        )
    best = max(candidates, key=lambda c: c[score])  # the first of equals: the grid's order
    adopt_run(out_dir / best["run"], out_dir)
    metrics = json.loads((out_dir / METRICS).read_text())
    metrics["grid"] = {"chosen": best["settings"], "score": score, "candidates": candidates}
    write_text_atomic(out_dir / METRICS, json.dumps(metrics, indent=2))
    config = json.loads((out_dir / CONFIG).read_text())
    config["settings"] = {**asdict(settings), **best["settings"]}  # the chosen model, and how
    write_text_atomic(out_dir / CONFIG, json.dumps(config, indent=2))
    return metrics


def candidate_name(values: dict[str, Any]) -> str:
    """A candidate's folder name in the grid folder: its settings, `hidden-64_layers-2`."""
    return "_".join(f"{k}-{_text(v)}" for k, v in values.items())


def check_same_grid(out_dir: Path, names: list[str]) -> None:
    """InputError where `out_dir`'s grid folder holds a candidate whose name is not among
    `names`: a resumed grid must be the grid it resumes, or the old candidate would be left
    beside the new ones, unlisted and unchosen."""
    folder = out_dir / CANDIDATES
    other = sorted(p.name for p in folder.iterdir() if p.is_dir()) if folder.is_dir() else []
    other = [name for name in other if name not in names]
    if other:
        raise InputError(
            f"{folder}: holds {len(other)} candidate(s) of another grid ({', '.join(other[:3])}"
            f"{', ...' if len(other) > 3 else ''}); resume with the grid it was trained with, "
            "or train afresh into another folder"
        )


def _text(value: Any) -> str:
    """A value in a candidate's folder name: floats as %g (0.001, not 0.0010)."""
    return f"{value:g}" if isinstance(value, float) else str(value)
