"""Settings of next-activity prediction on an event log (`tleaf train-task next-activity`,
`tleaf eval next-activity`): fields and presets. `NextActivitySettings()` is preset `best`;
`NextActivitySettings.preset("tax")` is Tax et al.'s (CAiSE 2017) training as published (Nadam's
learning rate 0.002 as Adam's, early stop after 42 epochs). `SuffixSettings`: how eval predicts
the rest of a running case. Pure Python: the command line builds the options from this module."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from tleaf_cli.errors import SettingError
from tleaf_cli.settings import check_values, setting
from tleaf_cli.settings.training import TrainingSettings, grid_axes

NEXT_ACTIVITY_LOSSES = ("none", "exact", "tleaf")  # `tl.logic_loss` kinds with a gradient
NEXT_ACTIVITY_MODELS = ("lstm", "transformer", "prefix-table")  # model.py, transformer.py, ...
SCORED_CASES = ("all", "satisfying")  # eval next-activity: which test cases
# each model in words, for messages
MODEL_NAMES = {
    "lstm": "an LSTM",
    "transformer": "a Transformer",
    "prefix-table": "the prefix table",
}
# The settings each model does not read: given with it, they would change nothing. The prefix
# table is counted once from the training cases (whole), not trained: no shape, no epochs, no
# batches, nothing random; an LSTM has no attention heads.
UNREAD_BY_MODEL: dict[str, tuple[str, ...]] = {
    "lstm": ("heads",),
    "transformer": (),
    "prefix-table": (
        "hidden", "layers", "heads", "dropout", "max_events",
        "epochs", "patience", "lr", "batch_size", "seed",
    ),
}  # fmt: skip


@dataclass(frozen=True)
class NextActivitySettings(TrainingSettings):
    """Every setting of the next-activity model's training (saved as config.json's "settings"):
    the training fields every task shares (`TrainingSettings`: λ, batches, epochs, early stop,
    learning rate, seed, device) and the model's own. The field defaults are preset `best`."""

    logic_loss: str = setting(
        "none",
        "none (reference), exact (−log P(the case's soft trace satisfies the rules)) or tleaf "
        "(the paper's loss: q's distance of the soft trace from the rules; needs --embedder).",
        choices=NEXT_ACTIVITY_LOSSES,
    )
    model: str = setting(
        "lstm",
        "lstm (Tax et al.'s), transformer (a small causal Transformer, ProcessTransformer's "
        "size: e.g. --hidden 36 --layers 1 --heads 4) or prefix-table (the trivial baseline: the "
        "next activity most often seen after the same prefix in training, backing off to its "
        "suffixes; nothing to train).",
        choices=NEXT_ACTIVITY_MODELS,
    )
    hidden: int = setting(
        100, "Units of each LSTM layer, or the Transformer's width (Tax et al.: 100).", min=1
    )
    layers: int = setting(
        2,
        "Stacked LSTM layers (Tax et al.: one shared, one per output) or Transformer blocks.",
        min=1,
    )
    heads: int = setting(4, "Attention heads of each Transformer block (transformer).", min=1)
    dropout: float = setting(0.2, "Dropout between the layers (Tax et al.: 0.2).")
    attributes: str | None = setting(
        None,
        "Event attributes the model reads and predicts beside the activity, separated by "
        "commas (org:resource): each event's value an input, the next event's a second output "
        "(given the next activity). The cases must keep them (read-log --attributes).",
        auto="none: activities and times only",
    )
    inputs: str | None = setting(
        None,
        "Categorical attributes the model reads but does not predict, separated by commas: "
        "event attributes by name (org:resource), case attributes as case:<name>, as read-log "
        "--attributes / --case-attributes kept them; each a one-hot of its 32 most frequent "
        "training values and one for the rest.",
        auto="none",
    )
    numeric_inputs: str | None = setting(
        None,
        "Numeric attributes the model reads, as --inputs names them (CRP,case:AMOUNT_REQ): "
        "each normalised by the training values' mean and sd, with a flag where an event "
        "has none.",
        auto="none",
    )
    max_events: int | None = setting(
        1000,
        "Train on at most the first N events of a case (its later targets left out, and the "
        "logic loss skips it): one case of 100,000 events would make an epoch take minutes and "
        "gigabytes. Val and test cases are scored whole.",
        min=1,
        auto="none: every case whole",
    )

    DEFAULT_LAMBDA: ClassVar[float] = 0.1  # λ of the exact loss when none is given
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "best": {},
        "tax": {"patience": 42, "epochs": 500, "batch_size": 16},
    }
    PRESET_HELP: ClassVar[dict[str, str]] = {
        "best": "Adam lr 2e-3, batches of 32 cases, up to 100 epochs, early stop after 10",
        "tax": "Tax et al.'s: batches of 16, up to 500 epochs, early stop after 42",
    }

    def check(self) -> None:
        """SettingError for a setting out of range or settings that do not fit together."""
        super().check()
        if not 0 <= self.dropout < 1:
            raise SettingError("dropout", f"must be in [0, 1), not {self.dropout}")
        if self.model == "prefix-table" and self.attributes:
            raise SettingError("attributes", "the prefix table reads activities only")
        if self.attributes is not None and not self.attribute_names:
            raise SettingError("attributes", f"names no attribute: {self.attributes!r}")
        lists = (
            ("attributes", self.attribute_names),
            ("inputs", self.input_names),
            ("numeric_inputs", self.numeric_input_names),
        )
        for field, names in lists[1:]:
            if getattr(self, field) is not None and not names:
                raise SettingError(field, f"names no attribute: {getattr(self, field)!r}")
            if self.model == "prefix-table" and names:
                raise SettingError(field, "the prefix table reads activities only")
        seen: dict[str, str] = {}
        for field, names in lists:
            for name in names:
                if name in seen:
                    raise SettingError(field, f"{name!r} is already read by {seen[name]}")
                seen[name] = field
        if self.model == "prefix-table" and self.logic_loss != "none":
            raise SettingError("logic_loss", "the prefix table learns nothing: no logic loss")
        varied = [name for name in grid_axes(self) if name in self.unread]
        if varied and "model" not in grid_axes(self):
            raise SettingError(
                "grid",
                f"{MODEL_NAMES[self.model]} reads no {varied[0]}: every candidate would be "
                "the same model",
            )
        if self.model == "transformer" and self.hidden % self.heads:
            raise SettingError(
                "hidden",
                f"the Transformer's width {self.hidden} is not a multiple of {self.heads} heads",
            )

    @property
    def unread(self) -> tuple[str, ...]:
        """The settings this run's model does not read (`UNREAD_BY_MODEL`)."""
        return UNREAD_BY_MODEL[self.model]

    @property
    def attribute_names(self) -> tuple[str, ...]:
        """The event attributes of `attributes`, in order."""
        return _names(self.attributes)

    @property
    def input_names(self) -> tuple[str, ...]:
        """The attributes of `inputs`, in order (case attributes as case:<name>)."""
        return _names(self.inputs)

    @property
    def numeric_input_names(self) -> tuple[str, ...]:
        """The attributes of `numeric_inputs`, in order."""
        return _names(self.numeric_inputs)


def _names(text: str | None) -> tuple[str, ...]:
    """The names of a comma-separated list (none: none)."""
    if text is None:
        return ()
    return tuple(a.strip() for a in text.split(",") if a.strip())


@dataclass(frozen=True)
class SuffixSettings:
    """How `tleaf eval next-activity` predicts suffixes and which cases it scores."""

    beam_width: int = setting(
        5, "Continuations kept per step by the suffix search (1: greedy argmax).", min=1
    )
    max_suffix: int = setting(
        60, "Most activities a predicted suffix adds (the longest test case's is typical).", min=1
    )
    prefix_lengths: str | None = setting(
        None,
        "Suffixes predicted from the prefixes of these lengths ('2-5' or '2,3,4,5').",
        auto="none: accuracy only, no suffix prediction",
    )
    temperature: float | None = setting(
        None,
        "Also sample each suffix token by token at this temperature (Mezini et al.: 0.7), "
        "with and without the rules as a hard filter; the draws are seeded (0). A finite "
        "number above 0.",
        auto="none: argmax and beam only",
    )
    rule_weight: float | None = setting(
        None,
        "Also search with the rules as a soft score instead of a filter (NeSy4PPM's "
        "knowledge-contextualised mode): each rule a token leaves unable to accept costs this "
        "weight μ in log-probability (argmax_soft, beam_soft, sample_soft).",
        min=0.0,
        auto="none: the rules a hard filter only",
    )
    mbr_samples: int | None = setting(
        None,
        "Also choose each suffix by minimum Bayes risk: of this many completions drawn from "
        "the model, the one most similar to the others on average (Damerau-Levenshtein); "
        "mbr, and under the rules mbr_rules and mbr_soft. The draws are seeded (0).",
        min=1,
        auto="none: no such choice",
    )
    min_suffix: int = setting(
        0,
        "Score only the prefixes whose true suffix has at least this many activities "
        "(NeSy4PPM: 1, no prefix that is already the whole case).",
        min=0,
    )
    scored: str = setting(
        "all",
        "The test cases scored: all, or those that satisfy --rules (Di Francescomarino et al.'s "
        "protocol).",
        choices=SCORED_CASES,
    )
    split: str = setting(
        "test",
        "The split scored: test, or val to choose settings (a suffix way, a sample count) on "
        "validation.",
        choices=("test", "val"),
    )

    def check(self) -> None:
        check_values(self)
        if self.rule_weight is not None and not math.isfinite(self.rule_weight):
            raise SettingError("rule_weight", f"must be finite, not {self.rule_weight}")
        # no `min` on the field: its bound is "above 0", not "at least 0" (0 divides by zero)
        if self.temperature is not None and not (
            math.isfinite(self.temperature) and self.temperature > 0
        ):
            raise SettingError(
                "temperature", f"must be a finite number above 0, not {self.temperature}"
            )
        if self.prefix_lengths is not None:
            prefix_lengths(self.prefix_lengths)


def prefix_lengths(text: str) -> tuple[int, ...]:
    """The prefix lengths '2-5' (both ends included) or '2,3,5' names; SettingError otherwise."""
    values: set[int] = set()
    for word in text.replace(",", " ").split():
        low, _, high = word.partition("-")
        try:
            start, end = int(low), int(high or low)
        except ValueError:
            raise SettingError("prefix_lengths", f"{word!r} is not a length or a range") from None
        if start < 1 or end < start:
            raise SettingError("prefix_lengths", f"{word!r}: lengths are at least 1, low to high")
        values.update(range(start, end + 1))
    if not values:
        raise SettingError("prefix_lengths", "names no length")
    return tuple(sorted(values))


PREDICT_WAYS = ("argmax", "beam", "sample", "mbr")  # how `tleaf predict` continues a running case
SUFFIX_RULES = ("none", "filter", "soft")  # the rules in its predicted suffix


@dataclass(frozen=True)
class PredictSettings:
    """How `tleaf predict` answers for running cases (tasks/next_activity/predict.py): the next
    event, the rest of the case, each rule's verdict and chance of holding, a recommendation."""

    top_k: int = setting(3, "Next activities listed per prefix, most probable first.", min=1)
    way: str = setting(
        "beam",
        "How the rest of the case is predicted: argmax (the most probable next event at each "
        "step), beam (beam search of --beam-width), sample (one draw at --temperature) or mbr "
        "(of --mbr-samples draws, the one most similar to the others: the continuation "
        "expected to score best). Beam is the default: it scored at or above argmax in most "
        "measured settings (the results pages on event logs and on suffix knowledge); a draw "
        "is one possible future, not the most probable one.",
        choices=PREDICT_WAYS,
    )
    beam_width: int = setting(
        5, "Continuations kept per step by the beam search (the recommendation's too).", min=1
    )
    mbr_samples: int = setting(
        32, "Draws --way mbr chooses among (temperature 1, seeded by --seed).", min=1
    )
    temperature: float = setting(
        0.7, "The temperature of --way sample (Mezini et al.: 0.7); a number above 0."
    )
    suffix_rules: str = setting(
        "none",
        "The rules in the predicted rest of the case: none (the model's own forecast; the "
        "recommendation column holds the best continuation that keeps the rules), filter "
        "(only continuations that keep every rule) or soft (each rule left unmet costs "
        "--rule-weight in log-probability).",
        choices=SUFFIX_RULES,
    )
    rule_weight: float = setting(
        20.0,
        "The soft score's weight μ with --suffix-rules soft (20: every Helpdesk case compliant "
        "at the best similarity, on the suffix knowledge results page).",
        min=0.0,
    )
    max_suffix: int = setting(
        60,
        "Most events a predicted or sampled continuation adds; a sampled one that reaches it "
        "ends there (counted in samples_at_cap).",
        min=1,
    )
    samples: int = setting(
        200,
        "Completions sampled per prefix (temperature 1) to estimate each rule's probability of "
        "holding when the case ends (0: none; a permanent verdict's is exact anyway).",
        min=0,
    )
    seed: int = setting(0, "Seed of the sampled completions (and of --way sample).", min=0)
    prefix_lengths: str | None = setting(
        None,
        "Replay completed cases as running: each case cut at each of these lengths ('1-4' or "
        "'1,2,3'), cases shorter than a length skipped, the true continuation kept beside the "
        "prediction.",
        auto="none: every case as it is, running",
    )
    risk: float = setting(
        0.5,
        "The terminal's table lists a rule not yet decided as at risk where its estimated "
        "probability of holding is below this.",
        min=0.0,
    )

    def check(self) -> None:
        check_values(self)
        if not (math.isfinite(self.temperature) and self.temperature > 0):
            raise SettingError(
                "temperature", f"must be a finite number above 0, not {self.temperature}"
            )
        if not math.isfinite(self.rule_weight):
            raise SettingError("rule_weight", f"must be finite, not {self.rule_weight}")
        if self.risk > 1:
            raise SettingError("risk", f"is a probability, at most 1, not {self.risk}")
        if self.prefix_lengths is not None:
            prefix_lengths(self.prefix_lengths)
