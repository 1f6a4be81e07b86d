"""A setting's default is written once, in its settings dataclass (`tleaf_cli/settings/`): no
option of any command repeats it by hand.

For every command registered, each option named like a user setting of a settings class is
either built from that setting (`with_settings`, `setting_option`: its default and help are the
setting's) or is a different thing that shares the word (listed below, with what it is)."""

from __future__ import annotations

import dataclasses
import importlib
import pkgutil

import pytest
import typer

import tleaf_cli.settings
from tleaf_cli import cli
from tleaf_cli.cli.options import SETTINGS_COMMANDS, _cli_default, default_text
from tleaf_cli.settings import options
from tleaf_cli.settings.data import CompileSettings, TraceSettings, fractions

# (command, option name): an option that shares a setting's name but is not that setting ("*":
# in every command).
SAME_WORD_OTHER_THING = {
    ("*", "embedder"): "a trained q's folder (train-meta's --embedder is the kind of q)",
    ("eval violations", "split"): "the splits to count violations on",
    ("predict", "split"): "the split whose cases are predicted",
    ("inspect", "formula_id"): "the DFA to show",
    ("cooking-kb", "ingredients"): "the ingredient names whose rules are written",
}


def _settings_classes() -> list[type]:
    found = []
    for info in pkgutil.iter_modules(tleaf_cli.settings.__path__):
        module = importlib.import_module(f"tleaf_cli.settings.{info.name}")
        found += [
            obj
            for obj in vars(module).values()
            if isinstance(obj, type)
            and dataclasses.is_dataclass(obj)
            and obj.__module__ == module.__name__
            and options(obj)
        ]
    return found


def _commands() -> dict[str, object]:
    found, stack = {}, [([], typer.main.get_command(cli.app))]
    while stack:
        path, command = stack.pop()
        found[" ".join(path)] = command
        stack += [([*path, n], sub) for n, sub in getattr(command, "commands", {}).items()]
    return found


COMMANDS = _commands()
SETTINGS: dict[str, list[tuple[dataclasses.Field, type]]] = {}  # a name -> each class's setting
for _cls in _settings_classes():
    for _f in options(_cls):
        SETTINGS.setdefault(_f.name, []).append((_f, _cls))


@pytest.mark.parametrize("command", SETTINGS_COMMANDS, ids=lambda c: c.name)
def test_a_settings_command_takes_each_default_from_its_settings(command) -> None:
    params = {p.name: p for p in COMMANDS[command.name].params}
    for f in command.fields():
        assert params[f.name].default == _cli_default(f), (command.name, f.name)
        shown = default_text(f, command.owner(f))
        assert f"[default: {shown}]" in params[f.name].help.replace("\\[", "["), f.name


@pytest.mark.parametrize("name", sorted(n for n in COMMANDS if n), ids=str)
def test_no_option_repeats_a_settings_default_by_hand(name) -> None:
    declared = {f.name for c in SETTINGS_COMMANDS if c.name == name for f in c.fields()}
    for param in COMMANDS[name].params:
        if param.param_type_name != "option" or param.name not in SETTINGS:
            continue
        if param.name in declared or {(name, param.name), ("*", param.name)} & set(
            SAME_WORD_OTHER_THING
        ):
            continue
        # an option of its own: it must be one of the settings of that name
        ours = [s for s in SETTINGS[param.name] if param.help.startswith(s[0].metadata["help"])]
        assert ours, (name, param.name, param.help)
        f, cls = ours[0]
        assert param.default == _cli_default(f), (name, param.name)
        assert f"[default: {default_text(f, cls)}]" in param.help.replace("\\[", "["), name


def test_options_named_like_another_thing_still_exist() -> None:
    """The list above names real options (a renamed one leaves it)."""
    for name, option in SAME_WORD_OTHER_THING:
        if name == "*":
            assert any(option in {p.name for p in c.params} for c in COMMANDS.values()), option
            continue
        assert option in {p.name for p in COMMANDS[name].params}, (name, option)


def test_a_switch_and_a_parsed_setting_reach_the_library_as_its_values(tmp_path) -> None:
    """compile-dfa --one-hot is CompileSettings' alphabet 'one-hot'; gen-traces --split
    0.8,0.1,0.1 is TraceSettings' tuple (the text form parsed once, by the setting's parser)."""
    from tleaf_cli.cli.options import COMPILE, TRACES, _from_cli

    alphabet = next(f for f in COMPILE.fields() if f.name == "alphabet")
    assert _from_cli(alphabet, True) == "one-hot"
    assert _from_cli(alphabet, False) == CompileSettings().alphabet
    split = next(f for f in TRACES.fields() if f.name == "split")
    assert _from_cli(split, "0.8,0.1,0.1") == (0.8, 0.1, 0.1) == fractions("0.8,0.1,0.1")
    assert _from_cli(split, None) is TraceSettings().split is None


def test_the_compile_settings_choices_are_the_logic_layers() -> None:
    """settings/ cannot import logic/ (it is below it): its copies of the alphabets and engines
    name exactly what logic/ accepts."""
    from typing import get_args

    from tleaf_cli.logic.alphabet import AlphabetKind
    from tleaf_cli.logic.compile import ENGINES
    from tleaf_cli.settings.data import ALPHABETS
    from tleaf_cli.settings.data import ENGINES as SETTINGS_ENGINES

    assert get_args(AlphabetKind) == ALPHABETS
    assert SETTINGS_ENGINES == ENGINES
