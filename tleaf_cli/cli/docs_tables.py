"""docs/cli.md's option tables, written from the settings dataclasses the commands take.

`python -m tleaf_cli.cli.docs_tables docs/cli.md` rewrites every table between its
`<!-- settings: NAME -->` and `<!-- /settings -->` markers; a test checks that docs/cli.md is up
to date.
"""

from __future__ import annotations

import sys
from pathlib import Path

from tleaf_cli.cli.options import (
    SETTINGS_COMMANDS,
    SWITCHES,
    SettingsCommand,
    _types,
    default_text,
    flag,
)


def settings_table(command: SettingsCommand) -> str:
    """The Markdown table of a command's settings: option, default, what it does."""
    rows = ["| option | default | what it does |", "|---|---|---|"]
    for f in command.fields():
        name = flag(f.name)
        if f.name in SWITCHES:
            pass
        elif f.metadata["choices"] is not None:
            name += " " + "\\|".join(f.metadata["choices"])
        elif _types(f, command.owner(f))[0] is bool:
            name = f"{flag(f.name)}/--no-{flag(f.name)[2:]}"
        help_text = f.metadata["help"].replace("|", "\\|")
        rows.append(f"| `{name}` | {default_text(f, command.owner(f))} | {help_text} |")
    presets = getattr(command.cls, "PRESET_HELP", {})
    if presets:
        rows.append("")
        rows.append("Presets (`--preset NAME`; options given on the command line override it):")
        rows.append("")
        rows += [f"- `{name}`: {text}" for name, text in presets.items()]
    return "\n".join(rows)


def render_docs(text: str) -> str:
    """`text` (docs/cli.md) with each table between `<!-- settings: NAME -->` and
    `<!-- /settings -->` rewritten from the settings."""
    out = text
    for command in SETTINGS_COMMANDS:
        begin, end = f"<!-- settings: {command.name} -->", "<!-- /settings -->"
        if begin not in out:
            raise ValueError(f"no '{begin}' marker")
        head, rest = out.split(begin, 1)
        _, tail = rest.split(end, 1)
        out = f"{head}{begin}\n{settings_table(command)}\n{end}{tail}"
    return out


if __name__ == "__main__":  # python -m tleaf_cli.cli.docs_tables docs/cli.md
    path = Path(sys.argv[1])
    path.write_text(render_docs(path.read_text()))
