"""Every `--help` of every command says what its options take: hand-written defaults and
bracketed text survive rich markup, flags show no `<bool>`, and options with a fixed set of
values list them (typed with `Literal`, so typer also refuses any other value)."""

from __future__ import annotations

import re
from typing import get_args

import pytest
import typer
from typer.testing import CliRunner

from tleaf_cli import cli
from tleaf_cli.cli import action_recognition, generate
from tleaf_cli.cli.options import SETTINGS_COMMANDS, SWITCHES
from tleaf_cli.defaults import TIERS
from tleaf_cli.settings.action_recognition import DECODINGS

runner = CliRunner()
# Options that take one of a fixed set of values, by flag: every one must list its values.
CHOICE_OPTIONS = {
    "--tier",
    "--device",
    "--atom-features",
    "--embedder",
    "--readout",
    "--schedule",
    "--formula-from",
    "--rule-sets",
    "--pair-features",
    "--model",
    "--logic-loss",
    "--decode",
}
HAND_DEFAULT = re.compile(r"\\?\[default: ([^\]]*)\]")


def _commands() -> list[tuple[list[str], object]]:
    """(argument path, click command) of every command and sub-command, groups included."""
    found, stack = [], [([], typer.main.get_command(cli.app))]
    while stack:
        path, command = stack.pop()
        found.append((path, command))
        for name, sub in getattr(command, "commands", {}).items():
            stack.append(([*path, name], sub))
    return sorted(found, key=lambda item: item[0])


COMMANDS = _commands()


def _flat(text: str) -> str:
    """Help text without box drawing and line wrapping: words separated by single spaces."""
    return " ".join(re.sub(r"[│╭╮╰╯─]", " ", text).split())


@pytest.mark.parametrize(
    ("path", "command"), COMMANDS, ids=[" ".join(p) or "tleaf" for p, _ in COMMANDS]
)
def test_help_shows_defaults_brackets_choices_and_no_bool(path, command) -> None:
    result = runner.invoke(cli.app, [*path, "--help"], env={"COLUMNS": "400"})
    assert result.exit_code == 0, result.output
    shown = _flat(result.output)
    assert "<bool>" not in shown
    for param in command.params:
        help_text = _flat(param.help or "").replace("\\[", "[")
        for default in HAND_DEFAULT.findall(param.help or ""):
            assert _flat(f"[default: {default}]") in shown, (param.name, shown)
        if "[" in help_text:  # other bracketed text, e.g. tleaf[text]
            assert help_text in shown, (param.name, help_text)
        described = param.type_descriptor  # typer's own parameters: no click `type`
        choices = tuple(described.choices or ()) if described.is_choice else None
        names = set(param.opts)
        if names & CHOICE_OPTIONS and "Path" not in str(described.annotation):  # eval --embedder
            assert choices, f"{sorted(names)} of {path} is not typed with its choices"
        if choices:
            assert f"<{'|'.join(choices)}>" in shown, (param.name, shown)


def test_every_choice_option_is_typed_with_its_choices() -> None:
    typed = {
        name
        for _, command in COMMANDS
        for param in command.params
        if getattr(param, "type_descriptor", None) and param.type_descriptor.is_choice
        for name in param.opts
    }
    assert typed >= CHOICE_OPTIONS, CHOICE_OPTIONS - typed


def test_choice_types_match_the_library() -> None:
    """The CLI's Literal types name exactly the values the library accepts."""
    pairs = [
        (generate.Tier, tuple(TIERS)),
        (get_args(action_recognition.ReportDecoding)[0], DECODINGS),  # Annotated[Literal, ...]
    ]
    for literal, values in pairs:
        assert set(get_args(literal)) == set(values), (literal, values)


@pytest.mark.parametrize("command", SETTINGS_COMMANDS, ids=lambda c: c.name)
def test_a_settings_command_has_one_option_per_setting(command) -> None:
    """Each setting of a command's settings dataclass (trainers, evaluations, generators) is an
    option of its command, with the setting's help and its values: the option is written once,
    in the dataclass."""
    path = command.name.split()
    found = {" ".join(p): c for p, c in COMMANDS}[" ".join(path)]
    params = {p.name: p for p in found.params}
    for f in command.fields():
        assert f.name in params, f"{command.name} has no option for {f.name}"
        param = params[f.name]
        assert f.metadata["help"].split(".")[0] in _flat(param.help), (f.name, param.help)
        if f.name in SWITCHES:  # one flag that selects one of the values
            switch, value = SWITCHES[f.name]
            assert param.opts == [switch] and value in f.metadata["choices"], f.name
        elif f.metadata["choices"]:
            assert tuple(param.type_descriptor.choices) == f.metadata["choices"], f.name


def test_a_value_outside_the_choices_is_refused_by_the_parser(tmp_path) -> None:
    result = runner.invoke(cli.app, ["gen-formulas", "--tier", "extreme", "-o", tmp_path / "f"])
    assert result.exit_code == 2 and "extreme" in result.output
    assert not (tmp_path / "f").exists()


@pytest.mark.parametrize(
    ("path", "command"), COMMANDS, ids=[" ".join(p) or "tleaf" for p, _ in COMMANDS]
)
def test_help_at_80_columns_shows_every_option_name_whole(path, command) -> None:
    """At a common terminal's width the option names are shown in full (the help text wraps
    instead): `--unlabelled-loss`, never `--unlabelled-l…`; and no word of a help text is cut
    (a word longer than the help column is: `examples/creative_c…`)."""
    result = runner.invoke(cli.app, [*path, "--help"], env={"COLUMNS": "80"})
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert all(len(line) <= 80 for line in lines), max(lines, key=len)
    assert [line for line in lines if "…" in line] == [], result.output
    words = set(re.sub(r"[│╭╮╰╯─,]", " ", result.output).split())
    for param in command.params:
        for name in [*param.opts, *param.secondary_opts]:
            if name.startswith("-"):
                assert name in words, (name, result.output)


def test_help_paragraphs_flow_at_any_width_and_lists_keep_their_lines():
    from tleaf_cli.cli.formatting import reflowed

    text = "First line\nof the first.\n\nA second\nparagraph goes on.\n- an item\n- another\n  kept"
    assert reflowed(text) == (
        "First line of the first.\n\nA second paragraph goes on.\n- an item\n- another\n  kept"
    )
