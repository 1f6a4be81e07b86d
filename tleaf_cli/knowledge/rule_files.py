"""Every file of rules tleaf reads, one way: `.ltl` text, a Parquet formula table, or a Declare
model `.decl` (by suffix), as `FormulaSource`s.

A `.decl` names activities as a log writes them; given the log's map (`log_atoms`, activity name
-> atom, kept with its cases artifact), each name is matched to the log's names exactly and reads
the log's atom (`activity_names.bind_atoms`), so a rule binds the activity it names and no
other. Its MP-Declare conditions come with their tests (`FormulaSource.conditions`). `.ltl` and
Parquet formulas name atoms already (data/formula_files.py).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from tleaf_cli.data.formula_files import FormulaSource, read_formulas
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.decl import decl_path, read_decl

RULE_FILES = "a .ltl file, a .decl Declare model or a Parquet table of formula_id, formula"


def read_rule_file(
    path: str | os.PathLike, log_atoms: Mapping[str, str] | None = None
) -> list[FormulaSource]:
    """The rules of `path` in file order (module docstring); InputError when the file is
    unusable (for `.decl`: the first line it cannot read or refuses, with its number)."""
    path = Path(path)
    if not decl_path(path):
        return read_formulas(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    rules = read_decl(path).rules(log_atoms)
    return [
        FormulaSource(r.name, r.formula, str(path), f"line {r.line}", conditions=r.conditions)
        for r in rules
    ]
