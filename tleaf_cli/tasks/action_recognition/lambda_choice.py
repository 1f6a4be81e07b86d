"""The λ a `train-task action-recognition` run weighs its logic loss by, and where it came from.

A run's λ is one of (`LambdaChoice.source`):

- `given`: the settings' `lam` (the command line's --lambda);
- `recommended`: the tleaf loss without a λ: the one q's train-meta folder recommends for this q
  (`settings.meta.recommended_lambda`: 1 / q's satisfy/violate boundary);
- `default`: the exact and checker losses without a λ: `EXACT_LAMBDA`;
- `validation`: chosen among the settings' `lambdas` and 0 on the val split
  (`train_choosing_lambda`): where a loss can hurt, "no logic loss" is among the choices;
- `candidate`: one of the runs `train_choosing_lambda` chooses among;
- `unused`: no logic loss and no self-training on unlabelled videos, nothing λ weighs.

The trainer records the choice in metrics.json ("lambda") and hands it to its caller before the
first epoch (`RunSetup`; the command line prints it); a choice on validation is made after the
candidates' runs, and recorded with each candidate's val action accuracy.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

from tleaf_cli.data.artifacts import relative_to, write_text_atomic
from tleaf_cli.settings.action_recognition import EXACT_LAMBDA, TaskSettings, lambda_candidates
from tleaf_cli.tasks.q_coverage import QCoverage

SOURCES = ("given", "recommended", "default", "validation", "candidate", "unused")
CANDIDATES = "lambda-choice"  # the folder of a run's λ candidates, inside the run's folder
RUN_FILES = ("config.json", "metrics.json", "weights.pt")  # what the chosen candidate gives


@dataclass(frozen=True)
class LambdaChoice:
    """A run's λ and where it came from; `candidates`: with `validation`, every λ tried and its
    best val action accuracy (increasing λ)."""

    value: float
    source: str
    candidates: list[dict] = field(default_factory=list)

    def text(self, given: str = "given") -> str:
        """One line: the λ and its source (`given`: how to say the caller set it)."""
        why = {
            "given": given,
            "recommended": "recommended for this q by its train-meta folder",
            "default": "the loss's default",
            "unused": "unused: no logic loss",
            "candidate": "a candidate for the choice on validation",
            "validation": "chosen on validation among "
            + ", ".join(
                f"{c['lambda']:g} ({100 * c['val_action_accuracy']:.2f}%)" for c in self.candidates
            ),
        }[self.source]
        return f"λ {self.value:g} ({why})"

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class RunSetup:
    """What a run tells its caller before the first epoch: its λ, and with the tleaf loss how
    much of the knowledge base q can read (`coverage.left_out` rules are left out of the loss)."""

    lam: LambdaChoice
    coverage: QCoverage | None = None


def resolve_lambda(settings: TaskSettings, recommended: float | None) -> LambdaChoice:
    """The λ of a run of `settings` (one λ, not a choice on validation); `recommended`: the λ
    the tleaf loss's q recommends (None for the other losses)."""
    if settings.lam is not None:
        return LambdaChoice(float(settings.lam), "given")
    if settings.logic_loss == "none" and settings.unlabelled_loss == "logic":
        return LambdaChoice(EXACT_LAMBDA, "unused")
    if recommended is not None:
        return LambdaChoice(float(recommended), "recommended")
    return LambdaChoice(EXACT_LAMBDA, "default")


def best_candidate(candidates: list[dict]) -> dict:
    """The candidate with the best val action accuracy; ties go to the smaller λ (so 0, no
    logic loss, wins a tie)."""
    return max(candidates, key=lambda c: (c["val_action_accuracy"], -c["lambda"]))


def train_choosing_lambda(
    train: Callable[..., dict],
    out_dir: Path,
    settings: TaskSettings,
    on_setup: Callable[[RunSetup], None] | None,
    **kwargs,
) -> dict:
    """One run of `train` (`train.train_action_recognition`) per λ of `settings.lambdas` and 0,
    each in out_dir/lambda-choice/lambda-<λ>/ from the same seed; the run with the best val
    action accuracy (`best_candidate`) is copied to out_dir, its metrics.json's "lambda" naming
    the choice and every candidate. Returns its metrics."""
    candidates = []
    for value in lambda_candidates(settings.lambdas or ""):
        one = replace(settings, lam=value, lambdas=None)
        folder = out_dir / CANDIDATES / f"lambda-{value:g}"
        metrics = train(out_dir=folder, settings=one, on_setup=_as_candidate(on_setup), **kwargs)
        candidates.append(
            {
                "lambda": value,
                "val_action_accuracy": metrics["best"]["val_action_accuracy"],
                "run": f"{CANDIDATES}/{folder.name}",
            }
        )
    best = best_candidate(candidates)
    choice = LambdaChoice(best["lambda"], "validation", candidates)
    chosen = out_dir / best["run"]
    for name in RUN_FILES:
        shutil.copyfile(chosen / name, out_dir / name)
    metrics = json.loads((out_dir / "metrics.json").read_text())
    metrics["lambda"] = choice.as_dict()
    write_text_atomic(out_dir / "metrics.json", json.dumps(metrics, indent=2))
    config = json.loads((out_dir / "config.json").read_text())
    config["settings"]["lambdas"] = settings.lambdas  # how this run chose its λ
    if config.get("embedder") is not None:  # relative to this folder, not the candidate's
        config["embedder_relative"] = relative_to(out_dir, config["embedder"])
    write_text_atomic(out_dir / "config.json", json.dumps(config, indent=2))
    return metrics


def _as_candidate(
    on_setup: Callable[[RunSetup], None] | None,
) -> Callable[[RunSetup], None] | None:
    """`on_setup` for a candidate's run: its λ's source is `candidate`, not `given`."""
    if on_setup is None:
        return None
    return lambda setup: on_setup(replace(setup, lam=replace(setup.lam, source="candidate")))
