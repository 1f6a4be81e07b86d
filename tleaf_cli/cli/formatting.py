"""How tleaf's commands show themselves: the click command and group classes behind --help and
usage lines, and the plain wording of a refused value."""

from __future__ import annotations

import functools

import typer
import typer.rich_utils
from rich.table import Table


class _OptionsTable(Table):
    """typer's options table, whose columns before the last two (the type and the help) never
    wrap or shorten: at 80 columns rich would otherwise cut option names (`--unlabelled-l…`)
    before wrapping the help text beside them."""

    def add_row(self, *renderables, **kwargs) -> None:
        fresh = not self.columns  # typer's options table makes its columns on the first row
        super().add_row(*renderables, **kwargs)
        if fresh and len(self.columns) > 2:
            for column in self.columns[:-2]:
                column.no_wrap = True


typer.rich_utils.Table = _OptionsTable  # the one table typer's help makes without columns


def _shown_params(params: list) -> list:
    """`params` as --help and usage lines should show them: every on/off flag with an empty
    metavar (typer's help would show a flag as taking a `<bool>` value, which it does not), and
    every positional argument named in upper case, `FORMULAS` (typer writes its name as it is,
    and `{formulas}` in usage lines); `REPORTS...` for one that takes several."""
    for param in params:
        if getattr(param, "is_flag", False) and param.metavar is None:
            param.metavar = ""
        elif isinstance(param, typer.core.TyperArgument) and param.metavar is None:
            param.metavar = param.name.upper() + ("..." if param.nargs != 1 else "")
    return params


def _usage_pieces(command: typer.core.TyperCommand | typer.core.TyperGroup, ctx) -> list[str]:
    """The usage line after the command's name, as click writes it: `[OPTIONS] FORMULAS`, an
    optional argument in brackets (typer wraps a required one in braces, `{formulas}`)."""
    pieces = [command.options_metavar] if command.options_metavar else []
    for param in command.get_params(ctx):
        if isinstance(param, typer.core.TyperArgument):
            pieces.append(param.metavar if param.required else f"[{param.metavar}]")
        else:
            pieces.extend(param.get_usage_pieces(ctx))
    return pieces


def _plain_errors(parse_args):
    """`parse_args` whose refusal of a value reads as click's own: typer checks a `Literal`'s
    values through pydantic, whose message for the ValueError it raises starts with "Value
    error, " ("Invalid value for '--tier': Value error, 'extreme' is not one of ...")."""

    @functools.wraps(parse_args)
    def wrapper(self, ctx, args):
        try:
            return parse_args(self, ctx, args)
        except typer.BadParameter as e:  # typer's own click, not the click package
            e.message = e.message.removeprefix("Value error, ")
            raise

    return wrapper


def reflowed(help_text: str) -> str:
    """A docstring's paragraphs as --help should flow them: typer's rich help keeps the line
    breaks of every paragraph after the first, which at another width break lines mid-sentence
    ("metrics.json (per" / "epoch: ..."). Lines of a paragraph are joined with spaces, except a
    line that starts a list item (-, *, 1.) or is indented, which keeps its own line."""
    out = []
    for paragraph in help_text.split("\n\n"):
        lines: list[str] = []
        for line in paragraph.split("\n"):
            item = line.startswith((" ", "\t", "- ", "* ")) or line.split(". ")[0].isdigit()
            if lines and not item:
                lines[-1] += " " + line.strip()
            else:
                lines.append(line.rstrip())
        out.append("\n".join(lines))
    return "\n\n".join(out)


class Command(typer.core.TyperCommand):
    """A tleaf command: its help's paragraphs reflowed, its flags show no type in --help, its
    arguments upper-case names, its refusals of a value no pydantic prefix."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        if self.help:
            self.help = reflowed(self.help)

    def get_params(self, ctx) -> list:
        return _shown_params(super().get_params(ctx))

    def collect_usage_pieces(self, ctx) -> list[str]:
        return _usage_pieces(self, ctx)

    parse_args = _plain_errors(typer.core.TyperCommand.parse_args)


class Group(typer.core.TyperGroup):
    """tleaf and its sub-apps (eval, train-task): their flags show no type in --help, their
    refusals of a value no pydantic prefix."""

    def get_params(self, ctx) -> list:
        return _shown_params(super().get_params(ctx))

    def collect_usage_pieces(self, ctx) -> list[str]:
        return [*_usage_pieces(self, ctx), self.subcommand_metavar]

    parse_args = _plain_errors(typer.core.TyperGroup.parse_args)
