"""Settings of `tleaf kb-extract` (`ExtractSettings`): which rules a video gets, and whether
they are mined. Pure Python: the command line builds the command's options from this module
(with `settings.data.CompileSettings`' timeout and engine: its rule sets are compiled)."""

from __future__ import annotations

from dataclasses import dataclass

from tleaf_cli.settings import setting
from tleaf_cli.settings.action_recognition import RULE_SET_SPLITS

# Which pairs give a video its rules; train-time extraction from predictions is the loss's job.
FORMULA_SOURCES = ("labels",)


@dataclass(frozen=True)
class ExtractSettings:
    """Every setting of a knowledge extraction (saved in dfas.parquet's params)."""

    formula_from: str = setting(
        "labels", "Which pairs give a video its rules: labels.", choices=FORMULA_SOURCES
    )
    rule_sets: str = setting(
        "video",
        "video: one rule set per video; ingredient: one per (video, ingredient), the formulas "
        "of a q for train-task --rule-sets ingredient.",
        choices=RULE_SET_SPLITS,
    )
    mine: bool = setting(
        False,
        "Mine rules from the train split (written to OUT/kb.ltl; the knowledge base file is then "
        "optional).",
    )
    min_support: int = setting(3, "Train videos that must show an ordering to mine it.", min=1)
