"""Settings declared once: the fields of tleaf's trainable models' settings dataclasses.

Each trainable keeps its settings in one frozen dataclass, in this package: q_e
(`settings.edge.EdgeSettings`), q_m (`settings.meta.MetaSettings`), the action recogniser
(`settings.action_recognition.TaskSettings`) and GAIL (`settings.gail.GailSettings`); so do the
data stages (`settings.data`: compile-dfa, gen-formulas, gen-traces; `settings.knowledge`:
kb-extract), the generators (`settings.generators`) and the evaluations (`settings.evaluation`).
A field a user sets is declared with `setting`: its default, its help text, and the values it
may take. Every other place reads it from there: the command line builds its options from these
fields (`tleaf_cli.cli.options`), `config.json` stores `dataclasses.asdict(settings)`, and
docs/cli.md's option tables are written from them (`python -m tleaf_cli.cli.docs_tables`). A field
declared as a plain dataclass field is internal: saved with the run, not an option.

A settings class may also name presets (`Presets`): named sets of values on top of the field
defaults, the defaults themselves being the first preset. `MetaSettings.preset("paper")` is the
2021 paper's q, `MetaSettings()` the best q tleaf knows.

This package imports nothing heavy (no torch, no gymnasium): the command line reads it to build
its options at start-up.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import MISSING, Field, field, fields
from typing import Any, ClassVar

from tleaf_cli.errors import SettingError

DEVICES = ("cpu", "cuda")  # where torch computes
# how matrix products are computed: float32, bfloat16 (autocast), or auto (bfloat16 where the
# hardware computes it natively: AMX / AVX-512 BF16 CPUs, GPUs; float32 elsewhere)
PRECISIONS = ("float32", "bfloat16", "auto")
SCHEDULES = ("constant", "cosine")  # the embedders' learning-rate schedules (training/loop.py)
LOGIC_LOSSES = ("none", "tleaf", "checker", "exact")  # `tl.logic_loss` kinds, and "none"


def setting(
    default: Any,
    help: str,
    *,
    min: float | None = None,
    choices: tuple[str, ...] | None = None,
    auto: str | None = None,
    parse: Callable[[str], Any] | None = None,
) -> Any:
    """A dataclass field that is a user's setting.

    `help`: what it does, one or two sentences (the option's --help and its docs/cli.md row).
    `min`: the smallest value it takes (numbers). `choices`: the values it takes (strings).
    `auto`: for a default of None, what None means, shown as the default ("auto: chosen from
    the data as ...", "none: no early stop"). `parse`: for a value written as text on the
    command line in a form of its own (fractions "0.8,0.1,0.1" for a tuple), the function from
    that text to the value (a SettingError for text it cannot read).
    """
    meta = {"help": help, "min": min, "choices": choices, "auto": auto, "parse": parse}
    return field(default=default, metadata=meta)


def options(cls: type) -> list[Field]:
    """The fields of a settings dataclass that are user settings (declared with `setting`)."""
    return [f for f in fields(cls) if "help" in f.metadata]


def check_values(settings: object) -> None:
    """SettingError for the first setting outside its `choices` or below its `min` (the
    library's own check; the command line runs `check_value` on each option it is given)."""
    for f in options(type(settings)):
        check_value(f, getattr(settings, f.name))


def check_value(f: Field, value: Any) -> None:
    """SettingError when `value` is not one the setting `f` takes: outside its `choices`; for a
    setting with a `min`, NaN, infinite, or below it (a bounded number is a finite one)."""
    if value is None:
        return
    choices, low = f.metadata["choices"], f.metadata["min"]
    if choices is not None and value not in choices:
        raise SettingError(f.name, f"must be one of {', '.join(choices)}, not {value!r}")
    if low is not None and isinstance(value, int | float) and not isinstance(value, bool):
        if not math.isfinite(value):
            raise SettingError(f.name, f"must be a finite number of at least {low}, not {value}")
        if value < low:
            raise SettingError(f.name, f"must be at least {low}, not {value}")


def default_of(f: Field) -> Any:
    """A field's default value (its default factory called)."""
    if f.default is not MISSING:
        return f.default
    if f.default_factory is not MISSING:
        return f.default_factory()
    raise TypeError(f"setting {f.name} has no default")


class Presets:
    """Named presets of a settings dataclass: `PRESETS[name]` holds the values that differ from
    the field defaults; the first name is the defaults themselves (its entry is empty)."""

    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {}
    # one line per preset for --help and the docs
    PRESET_HELP: ClassVar[dict[str, str]] = {}

    @classmethod
    def preset(cls, name: str, **overrides: Any):
        """The settings of preset `name`, with `overrides` on top."""
        if name not in cls.PRESETS:
            raise SettingError("preset", f"must be one of {', '.join(cls.PRESETS)}, not {name!r}")
        return cls(**{**cls.PRESETS[name], **overrides})

    @classmethod
    def default_preset(cls) -> str:
        return next(iter(cls.PRESETS))
