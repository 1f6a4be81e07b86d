"""Mined Declare constraints as a Declare model in RuM's `.decl` format (Declare4Py reads it too):
what `tleaf mine-declare -o kb.decl` writes, for the field's tools and tleaf's `.decl` reader.

The file, as RuM writes it (and as the models NeSy4PPM and Mezini et al. publish are):

    activity Assign seriousness
    activity Closed
    Init[Assign seriousness] | |
    Exactly1[Closed] | |
    Response[Assign seriousness, Closed] | | |

one `activity NAME` line for each activity of the log, then one line a constraint: the template's
Declare name (templates.py's `Template.name`; a counting template with its count, as RuM names
them at count 1: `Existence`, `Absence`, `Exactly1`), its activities by their original names
in brackets, and empty condition fields: two `|` for a unary template (activation, time), three
for a relational one (activation, correlation, time). No measures: a `.decl` has no comments; the
support table beside it has them.

An activity name the format cannot hold (a `[`, `]`, `|` or `,` in it, a line break, or blanks
at either end) is an InputError naming it, before anything is written: the line would read back
as other activities.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.declare import Measured
from tleaf_cli.knowledge.templates import TEMPLATES

_UNWRITABLE = set("[]|,\n\r")


def decl_name(key: str) -> str:
    """A mined template's name in a `.decl`: Declare's name, the counting ones at count 1 as RuM
    writes them (Existence, Absence, Exactly1)."""
    template = TEMPLATES[key]
    return f"{template.name}1" if key == "exactly" else template.name


def decl_text(
    mined: Sequence[Measured], activity_of: Mapping[str, str], activities: Iterable[str]
) -> str:
    """The `.decl` text of `mined`: `activities` (original names, each once, in their order)
    declared, then each constraint with its atoms named by `activity_of` (atom -> original name;
    an atom not in it keeps its own name)."""
    names = list(dict.fromkeys(activities))
    lines = []
    for m in mined:
        c = m.constraint
        acts = [activity_of.get(a, a) for a in c.activities]
        names += [a for a in acts if a not in names]
        fields = " |" * (c.declare.arity + 1)
        lines.append(f"{decl_name(c.template)}[{', '.join(acts)}]{fields}")
    bad = [n for n in names if _UNWRITABLE & set(n) or n != n.strip() or not n]
    if bad:
        raise InputError(
            f"activity {bad[0]!r} cannot be written in a .decl (a name there has no [ ] | , or "
            "line break, and no blank at either end); write a .ltl instead"
        )
    return "\n".join([*(f"activity {n}" for n in names), *lines]) + "\n"
