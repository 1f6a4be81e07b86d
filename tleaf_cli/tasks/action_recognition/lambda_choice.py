"""The λ a `train-task action-recognition` run weighs its logic loss by: `resolve_lambda` (its
sources and their wording are every task's, `tasks.lambda_source`), or a choice on the val
split among the settings' `lambdas` and 0 (`train_choosing_lambda`): where a loss can hurt, "no
logic loss" is among the choices. The λ is `given` (--lambda), `recommended` by the tleaf loss's
q, the exact and checker losses' `default` (`EXACT_LAMBDA`), or `unused` without a logic loss and
self-training on unlabelled videos.

The trainer records the choice in metrics.json ("lambda") and hands it to its caller before the
first epoch (`RunSetup`; the command line prints it); a choice on validation is made after the
candidates' runs, and recorded with each candidate's val action accuracy.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from tleaf_cli.data.artifacts import relative_to, write_text_atomic
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.settings.action_recognition import EXACT_LAMBDA, TaskSettings, lambda_candidates
from tleaf_cli.tasks.lambda_source import LambdaChoice, RunSetup, resolve_lambda_source

CANDIDATES = "lambda-choice"  # the folder of a run's λ candidates, inside the run's folder
RUN_FILES = ("config.json", "metrics.json", "weights.pt")  # what the chosen candidate gives


def resolve_lambda(settings: TaskSettings, recommended: float | None) -> LambdaChoice:
    """The λ of a run of `settings` (one λ, not a choice on validation); `recommended`: the λ
    the tleaf loss's q recommends (None for the other losses)."""
    uses = settings.logic_loss != "none" or settings.unlabelled_loss != "logic"
    return resolve_lambda_source(
        settings.lam, used=uses, recommended=recommended, default=EXACT_LAMBDA
    )


def best_candidate(candidates: list[dict], score: str = "val_action_accuracy") -> dict:
    """The candidate with the best val `score`; ties go to the smaller λ (so 0, no logic loss,
    wins a tie)."""
    return max(candidates, key=lambda c: (c[score], -c["lambda"]))


def train_choosing_lambda(
    train: Callable[..., dict],
    out_dir: Path,
    settings: TaskSettings | Any,
    on_setup: Callable[[RunSetup], None] | None,
    score: str = "val_action_accuracy",
    reference: Path | None = None,
    **kwargs,
) -> dict:
    """One run of `train` (`train.train_action_recognition`, or another task's trainer with
    the same arguments) per λ of `settings.lambdas` and 0, each in out_dir/lambda-choice/
    lambda-<λ>/ from the same seed; the run with the best val `score` (its metrics' "best"
    entry, `best_candidate`) is copied to out_dir, its metrics.json's "lambda" naming the choice
    and every candidate. Returns its metrics.

    `reference`: a finished λ-0 run of the same settings and data (another loss's candidate:
    λ 0 trains without the logic term, so it is the same run) taken as the λ-0 candidate
    instead of training it again; SettingError unless its settings and inputs match those of
    a candidate trained here (only the loss and λ may differ). The run's config.json names
    this run's loss and the chosen λ, whichever candidate it came from."""
    candidates = []
    for value in lambda_candidates(settings.lambdas or ""):
        if value == 0 and reference is not None:
            continue  # taken below, once a trained candidate can vouch for it
        one = replace(settings, lam=value, lambdas=None)
        folder = out_dir / CANDIDATES / f"lambda-{value:g}"
        metrics = train(out_dir=folder, settings=one, on_setup=_as_candidate(on_setup), **kwargs)
        candidates.append(
            {
                "lambda": value,
                score: metrics["best"][score],
                "run": f"{CANDIDATES}/{folder.name}",
            }
        )
    if reference is not None:
        folder = out_dir / CANDIDATES / "lambda-0"
        metrics = _take_reference(Path(reference), folder, candidates, out_dir)
        candidates.insert(
            0, {"lambda": 0.0, score: metrics["best"][score], "run": f"{CANDIDATES}/{folder.name}"}
        )
    best = best_candidate(candidates, score)
    choice = LambdaChoice(best["lambda"], "validation", candidates)
    chosen = out_dir / best["run"]
    for name in RUN_FILES:
        shutil.copyfile(chosen / name, out_dir / name)
    metrics = json.loads((out_dir / "metrics.json").read_text())
    metrics["lambda"] = choice.as_dict()
    if "logic_loss" in metrics:  # as config.json's below: this run's loss
        metrics["logic_loss"] = settings.logic_loss
    write_text_atomic(out_dir / "metrics.json", json.dumps(metrics, indent=2))
    config = json.loads((out_dir / "config.json").read_text())
    config["settings"]["lambdas"] = settings.lambdas  # how this run chose its λ
    # this run's loss at the chosen λ, also where the λ-0 candidate is a run without a logic
    # loss (`reference`): readers name a run by its settings
    config["settings"]["logic_loss"] = settings.logic_loss
    config["settings"]["lam"] = best["lambda"]
    if config.get("embedder") is not None:  # relative to this folder, not the candidate's
        config["embedder_relative"] = relative_to(out_dir, config["embedder"])
    write_text_atomic(out_dir / "config.json", json.dumps(config, indent=2))
    return metrics


def _take_reference(reference: Path, folder: Path, candidates: list[dict], out_dir: Path) -> dict:
    """Copy the λ-0 run `reference` into `folder` after checking it against a trained
    candidate; its metrics."""
    if not candidates:
        raise SettingError("reference", "needs a λ candidate besides 0 to be checked against")
    for name in RUN_FILES:
        if not (reference / name).is_file():
            raise InputError(f"{reference / name}: missing (not a finished run)")
    theirs = json.loads((reference / "config.json").read_text())
    ours = json.loads((out_dir / candidates[0]["run"] / "config.json").read_text())
    loose = {"logic_loss", "lam", "lambdas", "device"}
    differ = sorted(
        k
        for k in set(theirs["settings"]) | set(ours["settings"])
        if k not in loose and theirs["settings"].get(k) != ours["settings"].get(k)
    )
    lam = theirs["settings"].get("lam")
    if theirs["settings"].get("logic_loss") != "none" and lam != 0:
        differ.append(f"λ {lam} (not a λ-0 run)")
    data = [i["sha256"] for i in theirs.get("inputs", [])[:1]]
    if data != [i["sha256"] for i in ours.get("inputs", [])[:1]]:
        differ.append("its data (another file)")
    if differ:
        raise SettingError(
            "reference", f"{reference} is not this run's λ-0 candidate: {', '.join(differ)} differ"
        )
    folder.mkdir(parents=True, exist_ok=True)
    for name in RUN_FILES:
        shutil.copyfile(reference / name, folder / name)
    return json.loads((folder / "metrics.json").read_text())


def _as_candidate(
    on_setup: Callable[[RunSetup], None] | None,
) -> Callable[[RunSetup], None] | None:
    """`on_setup` for a candidate's run: its λ's source is `candidate`, not `given`."""
    if on_setup is None:
        return None
    return lambda setup: on_setup(replace(setup, lam=replace(setup.lam, source="candidate")))
