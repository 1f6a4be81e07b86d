"""A training run's folder, and what keeps one run's files one run's.

A run folder holds `config.json` (the settings, the inputs with their sha256 — the data first,
then the knowledge base —, the embedder, and the task's own fields such as its vocabulary),
`weights.pt` (the best epoch), `metrics.json` and `checkpoint.pt` (the last finished epoch,
for `--resume`). The checkpoint also holds the run's identity (`run_identity`): its settings
and its inputs' sha256s. A resumed run must be the same run (`check_same_run`): the same cases,
rules, q, loss and learning rate; only how long it trains (epochs, patience) and where (device)
may change. Otherwise resuming would continue one run's weights on another's data and write
metrics that name only the second.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from tleaf_cli.data.artifacts import file_sha256, read_json_file
from tleaf_cli.errors import InputError

CONFIG, METRICS = "config.json", "metrics.json"
CHECKPOINT = "checkpoint.pt"  # the last finished epoch (training/loop.py writes it)
RUN_FILES = (CONFIG, METRICS, "weights.pt")  # what a finished run has (and a λ choice copies)
RESUMABLE = ("epochs", "patience", "device", "max_minutes")  # may differ when resuming


def run_identity(
    settings: object, inputs: Sequence[dict[str, str]], embedder: str | os.PathLike | None
) -> dict[str, Any]:
    """What makes a run this run: its settings (but those a resumed run may change), its
    inputs' sha256s in order (data, knowledge base: `describe_inputs`' records), its embedder's
    folder. JSON-ready."""
    values = json.loads(json.dumps(asdict(settings)))
    return {
        "settings": {k: v for k, v in values.items() if k not in RESUMABLE},
        "inputs": [i["sha256"] for i in inputs],
        "embedder": None if embedder is None else str(Path(embedder).resolve()),
    }


def identity_differences(saved: dict[str, Any], now: dict[str, Any]) -> list[str]:
    """What differs between two runs' identities, in words ("lr 0.002 → 0.05", "the data")."""
    out = []
    before, after = saved.get("settings", {}), now.get("settings", {})
    for key in sorted(set(before) | set(after)):
        if before.get(key) != after.get(key):
            out.append(f"{key} {before.get(key)} → {after.get(key)}")
    names = ("the data", "the knowledge base")
    old, new = saved.get("inputs", []), now.get("inputs", [])
    for k in range(max(len(old), len(new))):
        if old[k : k + 1] != new[k : k + 1]:
            out.append(names[k] if k < len(names) else f"input {k + 1}")
    if saved.get("embedder") != now.get("embedder"):
        out.append("the embedder")
    return out


def check_same_run(checkpoint: Path, saved: dict[str, Any] | None, now: dict[str, Any]) -> None:
    """InputError unless the checkpoint's run is the run `now` describes."""
    if saved is None:
        raise InputError(
            f"{checkpoint}: written without the run's settings and inputs, so it cannot be "
            "told to be this run's; train afresh without resuming"
        )
    differ = identity_differences(saved, now)
    if differ:
        raise InputError(
            f"{checkpoint}: another run's checkpoint ({'; '.join(differ)}); resume it with its "
            "own settings and inputs, or train afresh into another folder"
        )


def has_checkpoint(folder: str | os.PathLike) -> bool:
    """Whether `folder` holds a checkpoint to resume from: its own, or a candidate's (a grid's
    or a λ choice's, `<folder>/<choice>/<candidate>/checkpoint.pt`)."""
    folder = Path(folder)
    return (folder / CHECKPOINT).is_file() or any(folder.glob(f"*/*/{CHECKPOINT}"))


def finished_run(folder: str | os.PathLike) -> bool:
    """Whether `folder` holds a finished run (its metrics.json)."""
    return (Path(folder) / METRICS).is_file()


def read_run_config(folder: str | os.PathLike, kind: str) -> dict[str, Any]:
    """A finished run's config.json, checked to be of `kind`; InputError naming the file."""
    path = Path(folder) / CONFIG
    if not path.is_file():
        raise InputError(f"{path}: missing (not a finished {kind} run)")
    config = read_json_file(path)
    if not isinstance(config, dict) or config.get("kind") != kind:
        found = config.get("kind") if isinstance(config, dict) else None
        raise InputError(f"{path}: not a {kind} run (kind {found})")
    return config


ROLES = {"data": 0, "kb": 1}  # a run's inputs in config.json's "inputs" list, by position


def recorded_input(run_dir: str | os.PathLike, config: dict[str, Any], role: str) -> Path | None:
    """The input a run's config.json records for `role` ("data" or "kb"), checked to exist and
    to be the bytes the run read; None where the run read none (a run without rules).
    InputError naming the run otherwise. config.json names them by role in "trained_on"; runs
    written before it did are read by the "inputs" list's order (the data, then the knowledge
    base)."""
    if "trained_on" in config:
        item = config["trained_on"][role]
    else:
        listed = config.get("inputs") or []
        item = listed[ROLES[role]] if ROLES[role] < len(listed) else None
    if item is None:
        return None
    what = {"data": "data", "kb": "knowledge base"}[role]
    path = Path(item["path"])
    if not path.is_file():
        raise InputError(f"{run_dir}: its {what} {path} is gone")
    if item.get("sha256") not in (None, file_sha256(path)):
        raise InputError(f"{run_dir}: its {what} {path} changed since the run was trained")
    return path


def adopt_run(chosen: Path, out_dir: Path) -> None:
    """Copy a finished candidate run's files (`RUN_FILES`) into `out_dir`: a choice among runs
    (λ on validation, a model grid) keeps the chosen one's files as the run's own."""
    for name in RUN_FILES:
        shutil.copyfile(chosen / name, out_dir / name)
