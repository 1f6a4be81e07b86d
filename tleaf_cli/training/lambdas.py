"""The λ a run weighs its logic loss by, and where it came from: one rule and one wording for
every task (`train-task action-recognition`, `next-activity`, `cooking`).

A run's λ is one of (`LambdaChoice.source`):

- `given`: the settings' `lam` (the command line's --lambda, or the preset's value; the caller
  says which, `LambdaChoice.text(given=...)`);
- `recommended`: the tleaf loss without a λ: the one q's train-meta folder recommends for this q
  (`settings.meta.recommended_lambda`: 1 / q's satisfy/violate boundary);
- `default`: another logic loss without a λ: the task's `DEFAULT_LAMBDA`;
- `validation`: chosen among a list of λs and 0 on the val split (`train_choosing_lambda`):
  where a loss can hurt, "no logic loss" is a choice;
- `candidate`: one of the runs a choice on validation chooses among;
- `unused`: nothing λ weighs (no logic loss, nor anything else the task weighs by λ).

A trainer records its choice in metrics.json ("lambda": `LambdaChoice.as_dict`) and hands it to
its caller before the first update (`RunSetup`; the command line prints `LambdaChoice.text`).
A choice on validation is made after the candidates' runs, and recorded with each candidate's
val score. No torch here.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from tleaf_cli.data.artifacts import describe_inputs, relative_to, write_text_atomic
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.settings.training import lambda_candidates
from tleaf_cli.training.q_coverage import QCoverage
from tleaf_cli.training.run_folder import CONFIG, METRICS, RUN_FILES, adopt_run

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


def resolve_lambda(settings: Any, recommended: float | None) -> LambdaChoice:
    """The λ of one run of a task's `settings` (a `TrainingSettings`): `resolve_lambda_source`
    with what the settings say is weighed by λ and the task's `DEFAULT_LAMBDA`; `recommended`:
    the λ the tleaf loss's q recommends (None for the other losses)."""
    return resolve_lambda_source(
        settings.lam,
        used=settings.uses_lambda,
        recommended=recommended,
        default=type(settings).DEFAULT_LAMBDA,
    )


CANDIDATES = "lambda-choice"  # the folder of a run's λ candidates, inside the run's folder
# may differ between a reference and its run; "grid": a run chosen on a grid has the chosen
# candidate's settings, and the grid only says how they were chosen
LOOSE = ("logic_loss", "lam", "lambdas", "grid", "device")


def best_candidate(candidates: list[dict], score: str) -> dict:
    """The candidate with the best val `score`; ties go to the smaller λ (so 0, no logic loss,
    wins a tie)."""
    return max(candidates, key=lambda c: (c[score], -c["lambda"]))


def train_choosing_lambda(
    train: Callable[[Path, Any, Callable[[RunSetup], None] | None], dict],
    out_dir: Path,
    settings: Any,
    on_setup: Callable[[RunSetup], None] | None,
    score: str,
    reference: str | Path | None = None,
    data: str | Path | None = None,
) -> dict:
    """One run `train(folder, settings, on_setup)` per λ of `settings.lambdas` and 0, each in
    out_dir/lambda-choice/lambda-<λ>/ from the same seed; the run with the best val `score`
    (its metrics' "best" entry, `best_candidate`) is copied to out_dir, its metrics.json's
    "lambda" naming the choice and every candidate. Returns its metrics.

    `reference`: a finished λ-0 run of the same settings and `data` (another loss's candidate:
    λ 0 trains without the logic term, so it is the same run) taken as the λ-0 candidate
    instead of training it again; SettingError, before anything trains, unless its settings
    and data are this run's (only the loss and λ may differ). The run's config.json names this
    run's loss and the chosen λ, whichever candidate it came from."""
    values = lambda_candidates(settings.lambdas or "")
    if reference is not None:
        check_reference(Path(reference), settings, data)
    candidates = []
    for value in values:
        if value == 0 and reference is not None:
            continue  # the reference is the λ-0 candidate
        one = replace(settings, lam=value, lambdas=None)
        folder = out_dir / CANDIDATES / f"lambda-{value:g}"
        metrics = train(folder, one, _as_candidate(on_setup))
        candidates.append(
            {"lambda": value, score: metrics["best"][score], "run": f"{CANDIDATES}/{folder.name}"}
        )
    if reference is not None:
        folder = out_dir / CANDIDATES / "lambda-0"
        folder.mkdir(parents=True, exist_ok=True)
        adopt_run(Path(reference), folder)
        metrics = json.loads((folder / METRICS).read_text())
        candidates.insert(
            0, {"lambda": 0.0, score: metrics["best"][score], "run": f"{CANDIDATES}/{folder.name}"}
        )
    best = best_candidate(candidates, score)
    choice = LambdaChoice(best["lambda"], "validation", candidates)
    adopt_run(out_dir / best["run"], out_dir)
    metrics = json.loads((out_dir / METRICS).read_text())
    metrics["lambda"] = choice.as_dict()
    if "logic_loss" in metrics:  # as config.json's below: this run's loss
        metrics["logic_loss"] = settings.logic_loss
    write_text_atomic(out_dir / METRICS, json.dumps(metrics, indent=2))
    config = json.loads((out_dir / CONFIG).read_text())
    config["settings"]["lambdas"] = settings.lambdas  # how this run chose its λ
    # this run's loss at the chosen λ, also where the λ-0 candidate is a run without a logic
    # loss (`reference`): readers name a run by its settings
    config["settings"]["logic_loss"] = settings.logic_loss
    config["settings"]["lam"] = best["lambda"]
    if config.get("embedder") is not None:  # relative to this folder, not the candidate's
        config["embedder_relative"] = relative_to(out_dir, config["embedder"])
    write_text_atomic(out_dir / CONFIG, json.dumps(config, indent=2))
    return metrics


def check_reference(reference: Path, settings: Any, data: str | Path | None) -> None:
    """SettingError unless `reference` is a finished λ-0 run of `settings` (but the loss, λ
    and the grid that chose them: `LOOSE`) on `data`; InputError for a folder that is not a
    finished run."""
    for name in RUN_FILES:
        if not (reference / name).is_file():
            raise InputError(f"{reference / name}: missing (not a finished run)")
    theirs = json.loads((reference / CONFIG).read_text())
    ours = json.loads(json.dumps(asdict(settings)))
    differ = sorted(
        k
        for k in set(theirs["settings"]) | set(ours)
        if k not in LOOSE and theirs["settings"].get(k) != ours.get(k)
    )
    lam = theirs["settings"].get("lam")
    if theirs["settings"].get("logic_loss") != "none" and lam != 0:
        differ.append(f"λ {lam} (not a λ-0 run)")
    if data is not None:
        trained_on = [i["sha256"] for i in theirs.get("inputs", [])[:1]]
        if trained_on != [i["sha256"] for i in describe_inputs([data])]:
            differ.append("its data (another file)")
    if differ:
        raise SettingError(
            "reference", f"{reference} is not this run's λ-0 candidate: {', '.join(differ)} differ"
        )


def _as_candidate(
    on_setup: Callable[[RunSetup], None] | None,
) -> Callable[[RunSetup], None] | None:
    """`on_setup` for a candidate's run: its λ's source is `candidate`, not `given`."""
    if on_setup is None:
        return None
    return lambda setup: on_setup(replace(setup, lam=replace(setup.lam, source="candidate")))
