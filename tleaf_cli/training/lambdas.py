"""The λ a task's run weighs its logic loss by, and where it came from: one rule and one wording
for every task (`train-task action-recognition`, `train-task cooking`).

A run's λ is one of (`LambdaChoice.source`):

- `given`: the settings' `lam` (the command line's --lambda, or the preset's value; the caller
  says which, `LambdaChoice.text(given=...)`);
- `recommended`: the tleaf loss without a λ: the one q's train-meta folder recommends for this q
  (`settings.meta.recommended_lambda`: 1 / q's satisfy/violate boundary);
- `default`: another logic loss without a λ: the task's default;
- `validation`: chosen among a list of λs and 0 on the val split (action recognition's
  `lambda_choice.train_choosing_lambda`): where a loss can hurt, "no logic loss" is a choice;
- `candidate`: one of the runs a choice on validation chooses among;
- `unused`: nothing λ weighs (no logic loss, nor anything else the task weighs by λ).

A trainer records its choice in metrics.json ("lambda": `LambdaChoice.as_dict`) and hands it to
its caller before the first update (`RunSetup`; the command line prints `LambdaChoice.text`).
No torch here.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

from tleaf_cli.tasks.q_coverage import QCoverage

SOURCES = ("given", "recommended", "default", "validation", "candidate", "unused")


@dataclass(frozen=True)
class LambdaChoice:
    """A run's λ and where it came from; `candidates`: with `validation`, every λ tried and its
    best val score, e.g. `val_action_accuracy` (increasing λ)."""

    value: float
    source: str
    candidates: list[dict] = field(default_factory=list)

    def text(self, given: str = "given") -> str:
        """One line: the λ and its source (`given`: how to say the caller set it); no value where
        nothing weighs by it (a run without logic loss)."""
        if self.source == "unused":
            return "λ unused: no logic loss"
        why = {
            "given": given,
            "recommended": "recommended for this q by its train-meta folder",
            "default": "the loss's default",
            "candidate": "a candidate for the choice on validation",
            "validation": "chosen on validation among "
            + ", ".join(f"{c['lambda']:g} ({100 * _val_score(c):.2f}%)" for c in self.candidates),
        }[self.source]
        return f"λ {self.value:g} ({why})"

    def as_dict(self) -> dict:
        return asdict(self)


def _val_score(candidate: dict) -> float:
    """A candidate's val score: its one `val_...` entry (action accuracy, next-activity
    accuracy)."""
    return next(v for k, v in candidate.items() if k.startswith("val_"))


@dataclass(frozen=True)
class RunSetup:
    """What a run tells its caller before the first update: its λ, and with the tleaf loss how
    much of the knowledge base q can read (`coverage.left_out` rules are left out of the loss)."""

    lam: LambdaChoice
    coverage: QCoverage | None = None


def resolve_lambda_source(
    given: float | None, *, used: bool, recommended: float | None, default: float
) -> LambdaChoice:
    """The λ of one run: `given` (the settings' `lam`), else q's `recommended` λ (None where
    the loss reads no q), else the task's `default`; `unused` where nothing weighs by λ
    (`used` False), whatever was given."""
    if not used:
        return LambdaChoice(float(default if given is None else given), "unused")
    if given is not None:
        return LambdaChoice(float(given), "given")
    if recommended is not None:
        return LambdaChoice(float(recommended), "recommended")
    return LambdaChoice(float(default), "default")
