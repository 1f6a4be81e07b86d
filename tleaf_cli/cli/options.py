"""Command-line options and docs rows built from settings dataclasses (`tleaf_cli.settings`).

A training command declares only its own arguments (inputs, --out, --quiet, ...) and names
the settings class it runs; `with_settings` adds one option per setting of that class, with the
setting's help, bounds and values, its default shown as the default preset's value. The command
then gets the values the user gave (`given`) and builds its settings from a preset plus those.
`cli/docs_tables.py` writes the same options as the Markdown rows of docs/cli.md
(`python -m tleaf_cli.cli.docs_tables docs/cli.md`; a test checks that docs/cli.md is up to
date).

Only the command line knows flags: a setting's flag is `--` + its name with dashes, except where
`FLAGS` (another name) or `SWITCHES` (one flag selecting one of two values) say otherwise.
"""

from __future__ import annotations

import functools
import inspect
import typing
from dataclasses import Field, dataclass
from typing import Annotated, Any, Literal

import typer

from tleaf_cli.errors import SettingError
from tleaf_cli.settings import check_value, default_of, options
from tleaf_cli.settings.action_recognition import TaskSettings
from tleaf_cli.settings.data import CompileSettings, FormulaSettings, TraceSettings
from tleaf_cli.settings.declare import DeclareSettings
from tleaf_cli.settings.edge import EdgeSettings
from tleaf_cli.settings.evaluation import EvalSettings, FigureSettings
from tleaf_cli.settings.event_logs import FoldSettings, LogSettings
from tleaf_cli.settings.gail import GailSettings
from tleaf_cli.settings.generators import ActivitySettings, DemoSettings
from tleaf_cli.settings.knowledge import ExtractSettings
from tleaf_cli.settings.meta import MetaSettings
from tleaf_cli.settings.next_activity import NextActivitySettings, PredictSettings, SuffixSettings
from tleaf_cli.settings.procedures import StepFeatureSettings, TaskGraphSettings

# The library names a setting as its keyword; the flag is `--` + that name with dashes, except here.
FLAGS = {
    "lam": "--lambda",  # `lambda` is a Python keyword
    "n": "-n",
    "total_steps": "--steps",  # train-task cooking
    "n_envs": "--envs",
    "n_steps": "--rollout",
    "formula_id": "--formula",  # eval tsne
}

# A setting of two values that the command line sets with one switch: the flag, and the value
# it selects (its absence leaves the default).
SWITCHES = {"alphabet": ("--one-hot", "one-hot")}  # compile-dfa --one-hot


def flag(setting: str) -> str:
    """The flag that sets the library's `setting` (``logic_loss`` → ``--logic-loss``)."""
    if setting in SWITCHES:
        return SWITCHES[setting][0]
    return FLAGS.get(setting, "--" + setting.replace("_", "-"))


@dataclass(frozen=True)
class SettingsCommand:
    """A command whose options are a settings class's fields, and the name docs/cli.md's
    table of them goes by (the command's words: "train-task cooking")."""

    cls: type
    name: str
    exclude: tuple[str, ...] = ()  # settings the command fixes itself (kb-extract's: one-hot)
    also: tuple[type, ...] = ()  # classes it also takes settings of (kb-extract: CompileSettings)

    def classes(self) -> tuple[type, ...]:
        return (self.cls, *self.also)

    def fields(self) -> list[Field]:
        return [f for cls in self.classes() for f in options(cls) if f.name not in self.exclude]

    def owner(self, f: Field) -> type:
        """The settings class that declares `f`."""
        return next(cls for cls in self.classes() if f in options(cls))

    def split(self, values: dict[str, Any]) -> list[dict[str, Any]]:
        """`values` (setting -> value) as one dict per class: `cls`' first, then `also`'s."""
        return [
            {f.name: values[f.name] for f in options(c) if f.name in values} for c in self.classes()
        ]


def _shown(value: Any) -> str:
    if isinstance(value, bool):
        return "on" if value else "off"
    if value == "":
        return "none"
    if isinstance(value, tuple):
        return ",".join(map(str, value))
    return str(value)


def default_text(f: Field, cls: type) -> str:
    """A setting's default as --help and the docs show it: the default preset's value, the
    other presets' where they differ, and what an automatic (None) default means."""
    value = default_of(f)
    if f.name in SWITCHES:
        value = value == SWITCHES[f.name][1]
    text = f.metadata["auto"] if value is None else _shown(value)
    if "{cls." in text:  # an automatic default that names the class's own value
        text = text.format(cls=cls)
    presets = getattr(cls, "PRESETS", {})
    others = [
        f"{name}: {_shown(values[f.name])}"
        for name, values in list(presets.items())[1:]
        if f.name in values and values[f.name] != value
    ]
    return "; ".join([text, *others])


def _types(f: Field, cls: type) -> tuple[Any, bool]:
    """A setting's type without None, and whether None is one of its values."""
    kind = typing.get_type_hints(cls)[f.name]
    args = [a for a in typing.get_args(kind) if a is not type(None)]
    return (args[0] if args else kind), type(None) in typing.get_args(kind)


def _cli_default(f: Field) -> Any:
    """A setting's default as its option's value: a switch off, a parsed value as its text."""
    value = default_of(f)
    if f.name in SWITCHES:
        return value == SWITCHES[f.name][1]
    if f.metadata["parse"] is not None and value is not None:
        return _shown(value)
    return value


def _number_type(f: Field, cls: type) -> type | None:
    """int or float for a setting that is a plain number (no choices, no parser of its own),
    else None: the command line takes such a value as text and reads it itself (`_number`)."""
    base, _ = _types(f, cls)
    plain = f.name not in SWITCHES and f.metadata["parse"] is None and not f.metadata["choices"]
    return base if plain and base in (int, float) else None


def _number(f: Field, kind: type, text: str) -> int | float:
    """The number an option's text names; SettingError otherwise, so that the call is refused
    in one `error:` line naming the flag (click would print its usage box)."""
    try:
        return kind(text.strip())
    except ValueError:
        what = "a whole number" if kind is int else "a number"
        raise SettingError(f.name, f"must be {what}, not {text!r}") from None


def _from_cli(f: Field, value: Any, cls: type | None = None) -> Any:
    """An option's value as the setting's: a switch's selected value, parsed text parsed, a
    number read from its text (`cls`: the settings class that declares `f`)."""
    if f.name in SWITCHES:
        return SWITCHES[f.name][1] if value else default_of(f)
    if f.metadata["parse"] is not None and isinstance(value, str):
        return f.metadata["parse"](value)
    kind = None if cls is None else _number_type(f, cls)
    if kind is not None and isinstance(value, str):
        return _number(f, kind, value)
    return value


def _annotation(f: Field, cls: type) -> Any:
    """The typed, annotated parameter typer turns into this setting's option."""
    base, optional = _types(f, cls)
    meta = f.metadata
    if f.name in SWITCHES:
        base, optional = bool, False
        option = typer.Option(
            SWITCHES[f.name][0],
            help=f"{meta['help']} \\[default: {default_text(f, cls)}]",
            show_default=False,
        )
        return Annotated[bool, option]
    metavar = None
    if meta["parse"] is not None:
        base = str
    if meta["choices"] is not None:
        base = Literal[meta["choices"]]
    if _number_type(f, cls) is not None:  # read by `_from_cli`, refused in one `error:` line
        metavar, base = f"<{base.__name__}>", str
    names = [flag(f.name)]
    if base is bool:
        names = [f"{flag(f.name)}/--no-{flag(f.name)[2:]}"]
    option = typer.Option(
        *names,
        help=f"{meta['help']} \\[default: {default_text(f, cls)}]",
        show_default=False,
        metavar=metavar,
    )  # bounds are checked by `check_value` (one `error:` line, NaN included), not by click
    return Annotated[base | None if optional else base, option]


# A command's own options on how a run goes, never what it makes: its settings come before them.
RUN_OPTIONS = ("jobs", "cluster", "cache_dir", "no_cache", "quiet")


def with_settings(command: SettingsCommand):
    """Decorate a command function that takes `**settings`: typer sees one keyword option per
    setting of `command` (before the function's own `RUN_OPTIONS`, if any), and the function
    receives their values in `settings` (a switch's as the value it selects, parsed text
    parsed)."""

    def decorate(func):
        own = inspect.signature(func)
        hints = typing.get_type_hints(func, include_extras=True)
        keyword = inspect.Parameter.KEYWORD_ONLY  # click passes every parameter by name
        params = [
            p.replace(annotation=hints.get(p.name, p.annotation), kind=keyword)
            for p in own.parameters.values()
            if p.kind is not inspect.Parameter.VAR_KEYWORD
        ]
        settings = command.fields()
        added = [
            inspect.Parameter(
                f.name,
                keyword,
                default=_cli_default(f),
                annotation=_annotation(f, command.owner(f)),
            )
            for f in settings
        ]
        at = next((i for i, p in enumerate(params) if p.name in RUN_OPTIONS), len(params))
        params[at:at] = added

        @functools.wraps(func)
        def wrapper(*args, **kwargs):
            for f in settings:
                if f.name in kwargs:
                    kwargs[f.name] = _from_cli(f, kwargs[f.name], command.owner(f))
                    check_value(f, kwargs[f.name])
            return func(*args, **kwargs)

        wrapper.__signature__ = own.replace(parameters=params)
        wrapper.__annotations__ = {p.name: p.annotation for p in params} | {"return": None}
        del wrapper.__wrapped__  # typer reads the signature above, not func's
        return wrapper

    return decorate


def setting_option(cls: type, name: str) -> Any:
    """One setting of `cls` as a command's own option (its type, flag, help and default text),
    for a command that takes that setting alone (cooking-kb's --domain is gen-demos')."""
    f = next(f for f in options(cls) if f.name == name)
    return _annotation(f, cls)


def given(ctx: typer.Context, values: dict[str, Any]) -> dict[str, Any]:
    """Of `values` (parameter name -> value), those the user gave on the command line."""
    out = {}
    for name, value in values.items():
        source = ctx.get_parameter_source(name)
        if source is not None and source.name in ("COMMANDLINE", "PROMPT", "ENVIRONMENT"):
            out[name] = value
    return out


# The commands whose options come from settings dataclasses: each command module decorates its
# function with `with_settings(ONE_OF_THESE)`, and docs/cli.md has a table for each.
EDGE = SettingsCommand(EdgeSettings, "train-edge")
META = SettingsCommand(MetaSettings, "train-meta")
TASK = SettingsCommand(TaskSettings, "train-task action-recognition")
GAIL = SettingsCommand(GailSettings, "train-task cooking")
NEXT = SettingsCommand(NextActivitySettings, "train-task next-activity")
SUFFIX = SettingsCommand(SuffixSettings, "eval next-activity")
PREDICT = SettingsCommand(PredictSettings, "predict")
EVAL = SettingsCommand(EvalSettings, "eval model-checking")
FIGURE = SettingsCommand(FigureSettings, "eval tsne")
ACTIVITIES = SettingsCommand(ActivitySettings, "gen-activities")
DEMOS = SettingsCommand(DemoSettings, "gen-demos")
COMPILE = SettingsCommand(CompileSettings, "compile-dfa")
FORMULAS = SettingsCommand(FormulaSettings, "gen-formulas")
TRACES = SettingsCommand(TraceSettings, "gen-traces")
READ_LOG = SettingsCommand(LogSettings, "read-log")
SPLIT_CASES = SettingsCommand(FoldSettings, "split-cases")
DECLARE = SettingsCommand(DeclareSettings, "mine-declare")
TASK_GRAPH = SettingsCommand(TaskGraphSettings, "task-graph")
STEP_FEATURES = SettingsCommand(
    StepFeatureSettings, "recording-activities", also=(TaskGraphSettings,)
)
# kb-extract: what it extracts, and how it compiles the rule sets (one-hot DFAs)
KB = SettingsCommand(ExtractSettings, "kb-extract", exclude=("alphabet",), also=(CompileSettings,))
# the data stages (compile-dfa and the generators), then the trainers and evaluations
LOG_COMMANDS = [READ_LOG, SPLIT_CASES, DECLARE]  # the event-log stages
PROCEDURE_COMMANDS = [TASK_GRAPH, STEP_FEATURES]  # the real-procedure stages
DATA_COMMANDS = [FORMULAS, COMPILE, TRACES, KB, ACTIVITIES, *LOG_COMMANDS, *PROCEDURE_COMMANDS]
SETTINGS_COMMANDS = [*DATA_COMMANDS, EDGE, META, TASK, GAIL, NEXT, EVAL, SUFFIX, PREDICT]
SETTINGS_COMMANDS += [FIGURE, DEMOS]
