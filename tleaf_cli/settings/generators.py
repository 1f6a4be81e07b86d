"""Settings of the synthetic data generators: `tleaf gen-activities` (`ActivitySettings`) and
`tleaf gen-demos` (`DemoSettings`). Pure Python: the command line builds both commands' options
from this module."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from tleaf_cli.errors import SettingError
from tleaf_cli.settings import setting

MAX_ACTIONS = 64  # the paper's vocabulary
MAX_INGREDIENTS = 155


@dataclass(frozen=True)
class ActivitySettings:
    """Every setting of the synthetic activity videos (saved in the artifact's params)."""

    actions: int = setting(16, f"Actions (at most the paper's {MAX_ACTIONS}).")
    ingredients: int = setting(24, f"Ingredients (at most the paper's {MAX_INGREDIENTS}).")
    feature_dim: int = setting(128, "Feature size per step (2048 like ResNet).")
    noise: float = setting(1.0, "Std of the per-step Gaussian noise.")
    confusable: float = setting(0.5, "0..1: how far paired classes' means are pulled together.")
    ingredient_scale: float = setting(
        1.5, "Ingredient means' norm relative to actions' (>1: easier to see)."
    )
    train: int = setting(60, "Training videos.")
    val: int = setting(40, "Validation videos.")
    test: int = setting(200, "Test videos.")
    unlabelled: int = setting(
        0, "Unlabelled videos (split 'unlabelled'; only logic losses use them)."
    )
    min_steps: int = setting(5, "Fewest steps in a video.")
    max_steps: int = setting(15, "Most steps in a video.")
    seed: int = setting(0, "Random seed; the same seed writes the same file.")

    def check(self) -> None:
        """SettingError for settings no process can satisfy."""
        if not 2 <= self.actions <= MAX_ACTIONS:
            raise SettingError("actions", f"must be in 2..{MAX_ACTIONS}, got {self.actions}")
        if not 1 <= self.ingredients <= MAX_INGREDIENTS:
            raise SettingError(
                "ingredients", f"must be in 1..{MAX_INGREDIENTS}, got {self.ingredients}"
            )
        if self.feature_dim < 1:
            raise SettingError("feature_dim", f"must be at least 1, got {self.feature_dim}")
        if self.noise < 0:
            raise SettingError("noise", f"must be >= 0, got {self.noise}")
        if not 0 <= self.confusable <= 1:
            raise SettingError("confusable", f"must be in [0, 1], got {self.confusable}")
        if self.ingredient_scale <= 0:
            raise SettingError("ingredient_scale", f"must be > 0, got {self.ingredient_scale}")
        sizes = {"train": self.train, "val": self.val, "test": self.test}
        sizes["unlabelled"] = self.unlabelled
        for name, size in sizes.items():
            if size < 0:
                raise SettingError(name, f"must be >= 0, got {size}")
        if sum(sizes.values()) == 0:
            raise SettingError("train", "no videos at all: every split's count is 0")
        if not 1 <= self.min_steps <= self.max_steps:
            raise SettingError(
                "min_steps",
                f"must be between 1 and the most steps ({self.max_steps}), got {self.min_steps}",
            )


@dataclass(frozen=True)
class DemoSettings:
    """Every setting of the expert demonstrations (saved in the artifact's params)."""

    episodes: int = setting(32, "Expert episodes to record.", min=1)
    seed: int = setting(0, "Random seed; the same seed writes the same file.")
    domain: Path | None = setting(
        None, "Domain TOML.", auto="the Creative Cooking domain in examples/"
    )
