"""Settings of the action recogniser h (`tleaf train-task action-recognition`): fields and
presets. `TaskSettings()` is preset `best`, the setting behind every documented result (Adam lr
1e-3, up to 150 epochs, early stop after 20, test videos also decoded under the rules);
`TaskSettings.preset("paper")` the 2021 paper's (lr 1e-4, 60 epochs, early stop after 10, argmax
decoding), which on the walk-through's 60 training videos stops far short (22 % action accuracy
against the default's 62 %). `ReportSettings`: those of its report, `tleaf eval
action-recognition`. Pure Python: the command line builds the commands' options from this
module."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from tleaf_cli.settings import LOGIC_LOSSES, setting
from tleaf_cli.settings.training import TrainingSettings, training_field

MODELS = ("lstm", "tcn")  # h's backbone (tasks/action_recognition/models.py)
FORMULA_SOURCES = ("predictions", "labels", "kb")  # where a video's rule set comes from
RULE_SET_SPLITS = ("video", "ingredient")  # one rule set per video, or one per ingredient
DECODINGS = ("argmax", "constrained")  # test-time decoding
UNLABELLED_LOSSES = ("logic", "decoded", "argmax")  # what unlabelled videos are trained on


@dataclass(frozen=True)
class TaskSettings(TrainingSettings):
    """Every setting of h's training (saved as config.json's "settings").

    The field defaults are preset `best`; `TaskSettings.preset("paper")` is the paper's."""

    model: str = setting("lstm", "Backbone of h: lstm or tcn.", choices=MODELS)
    logic_loss: str = setting(
        "none", "none (reference), tleaf, exact, or checker (no gradient).", choices=LOGIC_LOSSES
    )
    formula_from: str = setting(
        "predictions",
        "Rules relevant to the predicted pairs (the paper) or to the labels; or kb: the whole "
        "knowledge base, each rule where its pairs all occur, one rule set per ingredient, the "
        "same for every video (no guess of the model picks them).",
        choices=FORMULA_SOURCES,
    )
    rule_sets: str = setting(
        "video",
        "video: one rule set φ per video (the paper); ingredient: φ split into one conjunction "
        "per ingredient, loss summed over them (tleaf, exact).",
        choices=RULE_SET_SPLITS,
    )
    unlabelled: bool = setting(
        True,
        "Also apply the logic loss (tleaf, exact) to the data's unlabelled videos, one batch of "
        "them per training batch; their labels are never read.",
    )
    unlabelled_loss: str = setting(
        "logic",
        "What unlabelled videos train: logic (the logic loss, as on labelled videos); decoded "
        "(cross-entropy to h's own constrained decoding under the rules: the knowledge as a "
        "teacher); argmax (to h's own argmax: self-training without the knowledge). Weighted by "
        "λ.",
        choices=UNLABELLED_LOSSES,
    )
    unlabelled_videos: int | None = setting(
        None,
        "Read only the first N unlabelled videos (in file order).",
        min=0,
        auto="all: every video of the unlabelled split",
    )
    unlabelled_warmup: int = setting(
        0,
        "Weight the unlabelled videos' loss by epoch/N over the first N epochs (0: full weight "
        "from the start).",
        min=0,
    )
    train_videos: int | None = setting(
        None,
        "Train on the first N videos of the train split (in file order), so that a larger N "
        "holds every smaller one: a learning curve over one data set.",
        min=1,
        auto="all: every video of the train split",
    )
    hidden: int = setting(128, "Backbone width.", min=1)
    head_hidden: int = 64
    dropout: float = 0.2
    batch_size: int = training_field("batch_size", 16)
    epochs: int = training_field("epochs", 150)
    patience: int | None = training_field("patience", 20)
    lr: float = training_field("lr", 1e-3)
    decode: str = setting(
        "constrained",
        "Test-time decoding: argmax per step, or also constrained (the most probable sequence "
        "the knowledge base's rules accept; both are reported).",
        choices=DECODINGS,
    )
    decode_top_k: int = setting(
        5, "Constrained decoding: candidate pairs per video (top k; chosen on val).", min=1
    )

    DEFAULT_LAMBDA: ClassVar[float] = 1.0  # of the exact and checker losses (chosen on val)
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "best": {},
        "paper": {"lr": 1e-4, "epochs": 60, "patience": 10, "decode": "argmax"},
    }
    PRESET_HELP: ClassVar[dict[str, str]] = {
        "best": "every documented result's h: Adam lr 1e-3, up to 150 epochs, early stop after "
        "20, test videos decoded by argmax and under the rules",
        "paper": "the 2021 paper's: Adam lr 1e-4, up to 60 epochs, early stop after 10, argmax "
        "decoding (on 60 training videos it stops far short of the best preset's accuracy)",
    }

    @property
    def uses_lambda(self) -> bool:
        """λ weighs the logic loss, and self-training on unlabelled videos."""
        return self.logic_loss != "none" or self.unlabelled_loss != "logic"


@dataclass(frozen=True)
class ReportSettings:
    """Settings of the action-recognition report (`tleaf eval action-recognition`)."""

    decode: str = setting(
        "argmax",
        "Whose test figures fill the main table: argmax, or constrained decoding (runs trained "
        "with --decode constrained). Runs that have both also get a table of the two side by "
        "side.",
        choices=DECODINGS,
    )
