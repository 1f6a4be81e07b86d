"""The rules a next-activity run or its evaluation uses: formulas of a `.ltl` file (mined
Declare constraints, a peer's a-priori formula), some or all of them, as one `RuleSet` over the
model's activities."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass

from tleaf_cli.data.formula_files import read_formulas
from tleaf_cli.errors import InputError
from tleaf_cli.rule_set import RuleSet


@dataclass(frozen=True)
class Rules:
    """The chosen rules' names and their conjunction over the model's vocabulary."""

    path: str
    names: tuple[str, ...]
    rule_set: RuleSet


def read_rules(
    path: str | os.PathLike, vocabulary: Sequence[str], names: Sequence[str] = ()
) -> Rules:
    """The rules of `path` named in `names` (all without), conjoined over `vocabulary`.

    Raises InputError naming the file and line of a formula that does not read, a name the
    file does not have, or a formula over an activity the model does not know."""
    sources = read_formulas(path)
    for src in sources:
        if src.problem is not None:
            raise InputError(f"{src.path}: {src.located(src.problem)}")
    if not sources:
        raise InputError(f"{path}: no rules in the file")
    chosen = sources
    if names:
        by_name = {s.formula_id: s for s in sources}
        unknown = [n for n in names if n not in by_name]
        if unknown:
            raise InputError(
                f"{path}: no rule named {', '.join(unknown)} (it has "
                f"{', '.join(list(by_name)[:8])}{', ...' if len(by_name) > 8 else ''})"
            )
        chosen = [by_name[n] for n in names]
    try:
        rule_set = RuleSet([s.text for s in chosen], list(vocabulary), name=os.fspath(path))
    except InputError as e:
        raise InputError(f"{path}: {e}") from None
    return Rules(os.fspath(path), tuple(s.formula_id for s in chosen), rule_set)
