"""The settings every task's training shares, declared once: λ (given, or chosen on validation
among candidates), the loop (batch size, epochs, early stop, learning rate), the seed and the
device. A task's settings class extends `TrainingSettings` with its own fields (its model, its
loss, its data) and, where its best value differs, takes a shared field with its own default
(`training_field`): the field's help, bounds and checks stay those declared here.

Pure Python: the command line builds its options from these fields.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, fields, replace
from typing import Any, ClassVar

from tleaf_cli.errors import SettingError
from tleaf_cli.settings import DEVICES, Presets, check_values, setting


@dataclass(frozen=True)
class TrainingSettings(Presets):
    """The training fields of every task (saved in config.json's "settings" with the task's).

    `DEFAULT_LAMBDA`: the λ of a logic loss without one given and without a q to recommend one
    (the tleaf loss's q recommends its own), chosen on validation for each task."""

    lam: float | None = setting(
        None,
        "Weight λ of the logic loss.",
        min=0.0,
        auto="auto: with tleaf, the λ the embedder's folder recommends; otherwise "
        "{cls.DEFAULT_LAMBDA:g}",
    )
    lambdas: str | None = setting(
        None,
        "Choose λ on validation: one run per value of this list (commas or spaces, e.g. "
        "'0.3,1,3'), 0 (the logic loss weighing nothing) always among them, each from the same "
        "seed; the run with the best val score is kept (ties: the smaller λ), every candidate's "
        "run in its lambda-choice folder.",
        auto="none: one run, at --lambda",
    )
    grid: str | None = setting(
        None,
        "Choose the model on validation: one run per combination of these settings' values, "
        "each a field, =, its values by commas, fields apart by spaces (e.g. hidden=64,128 "
        "layers=1,2), each from the same seed; the run with the best val score is kept (ties: "
        "the first in the grid's order), its settings in config.json, every candidate's run "
        "in its grid folder.",
        auto="none: one run, at the settings given",
    )
    batch_size: int = setting(32, "Sequences (cases, videos) per batch.", min=1)
    epochs: int = setting(100, "Most epochs to train.", min=1)
    patience: int | None = setting(
        10, "Stop after this many epochs without a better val score.", min=1
    )
    lr: float = setting(2e-3, "Adam learning rate (a finite number above 0).")
    seed: int = setting(0, "Random seed; the same seed trains the same model.")
    device: str = setting("cpu", "Where to compute.", choices=DEVICES)

    DEFAULT_LAMBDA: ClassVar[float] = 1.0

    @property
    def uses_lambda(self) -> bool:
        """Whether anything is weighed by λ (a logic loss, for most tasks)."""
        return getattr(self, "logic_loss", "none") != "none"

    def check(self) -> None:
        """SettingError for a setting out of range or settings that do not fit together."""
        check_values(self)
        if not (math.isfinite(self.lr) and self.lr > 0):
            raise SettingError("lr", f"must be a finite number above 0, not {self.lr}")
        if self.lambdas is not None:
            lambda_candidates(self.lambdas)
            if self.lam is not None:
                raise SettingError("lambdas", "chooses λ itself: not with lam")
            if not self.uses_lambda:
                raise SettingError("lambdas", "λ weighs nothing without a logic loss")
        if self.grid is not None:
            if self.lambdas is not None:
                raise SettingError("grid", "choose the model first, then λ: not with lambdas")
            for one in grid_candidates(self):
                one.check()


def training_field(name: str, default: Any) -> Any:
    """The shared setting `name` of `TrainingSettings` with a task's own default (its best
    measured value): the same help, bounds and checks."""
    base = TrainingSettings.__dataclass_fields__[name]
    return field(default=default, metadata=base.metadata)


def lambda_candidates(text: str) -> tuple[float, ...]:
    """The λs a `lambdas` list names, with 0 (no logic loss's weight) always among them,
    increasing; SettingError for a value that is not a finite number of at least 0."""
    values = {0.0}
    for word in text.replace(",", " ").split():
        try:
            value = float(word)
        except ValueError:
            raise SettingError("lambdas", f"{word!r} is not a number") from None
        if not (math.isfinite(value) and value >= 0):
            raise SettingError("lambdas", f"must be finite numbers of at least 0, not {word}")
        values.add(value)
    return tuple(sorted(values))


# what a grid may not vary: how the choice is made, the run's identity and where it runs
NOT_IN_GRID = ("grid", "lam", "lambdas", "seed", "device", "epochs", "patience", "resume")


def grid_candidates(settings: Any) -> list[Any]:
    """The settings of each combination of `settings.grid`'s values, in the grid's order (the
    last field's values turn fastest); SettingError naming what does not read: a word without
    =, a field the settings do not have or a grid may not vary, a value not of the field's
    type, a field or a value named twice."""
    names = {f.name for f in fields(settings)}
    axes: dict[str, list[Any]] = {}
    for word in (settings.grid or "").split():
        name, equals, values = word.partition("=")
        name = name.strip().replace("-", "_")
        if not equals or not values.strip(","):
            raise SettingError("grid", f"{word!r} is not field=value,value,...")
        if name not in names or name in NOT_IN_GRID:
            raise SettingError(
                "grid",
                f"{name!r} is not a setting a grid may vary"
                + (" (how the choice is made, or the run's seed, device and length)"
                   if name in NOT_IN_GRID else ""),
            )  # fmt: skip
        if name in axes:
            raise SettingError("grid", f"{name!r} is named twice")
        kind = type(getattr(settings, name))
        if getattr(settings, name) is None or kind not in (int, float, str):
            raise SettingError("grid", f"{name!r} takes no list of values here")
        try:
            axes[name] = [kind(v) for v in values.split(",") if v]
        except ValueError:
            raise SettingError(
                "grid", f"{name}: {values!r} are not {kind.__name__} values"
            ) from None
        twice = [v for i, v in enumerate(axes[name]) if v in axes[name][:i]]
        if twice:  # the same candidate trained again, to the same score
            raise SettingError("grid", f"{name}: {twice[0]!r} is named twice")
    if not axes:
        raise SettingError("grid", "names no setting to vary")
    return [
        replace(settings, grid=None, **dict(zip(axes, combo, strict=True)))
        for combo in itertools.product(*axes.values())
    ]


def grid_axes(settings: Any) -> tuple[str, ...]:
    """The fields `settings.grid` varies, in order."""
    return tuple(
        w.partition("=")[0].strip().replace("-", "_") for w in (settings.grid or "").split()
    )
