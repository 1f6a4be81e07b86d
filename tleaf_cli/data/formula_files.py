"""Formula inputs: `.ltl` text files and Parquet tables with `formula_id, formula`. Declare
models (`.decl`) are read a floor up, by `knowledge/rule_files.py` (`read_rule_file`), into the
same `FormulaSource`s: each constraint one formula, named `<template key>.<activity atoms>`, with
the tests behind its condition atoms.

`.ltl` (docs/design.md): UTF-8 (a byte-order mark at the start is skipped), one formula per line,
`#` starts a comment, blank lines skipped, an optional `name:` prefix (`[A-Za-z0-9_.-]+`) names
the formula (ASCII only), otherwise its id is `L<line>`.
A line that is wrong in itself (bad name, repeated name) still yields an entry, with `problem`
set, so the stage reports it in its row and carries on with the others.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from tleaf_cli.data.artifacts import read_text_file
from tleaf_cli.errors import InputError

_NAMED = re.compile(r"^\s*([^\s:][^:]*?)\s*:(.*)$")
_VALID_NAME = re.compile(r"[A-Za-z0-9_.-]+")


@dataclass(frozen=True)
class FormulaSource:
    """One formula as read: its id, its text, where it came from, and any problem with it."""

    formula_id: str
    text: str
    path: str
    location: str  # "line 3" (.ltl) or "row 4" (Parquet, 0-based)
    offset: int = 0  # columns before the formula text on its line (a `name:` prefix)
    problem: str | None = None
    # condition atom -> the test on an event's attributes that makes it true (`cases.EventTest`;
    # MP-Declare conditions of a `.decl`); an `.ltl` formula has none
    conditions: Mapping[str, Any] = field(default_factory=dict)

    def located(self, message: str, column: int | None = None) -> str:
        """`message` prefixed with where it happened: line/row, and column when known."""
        if column is None:
            return f"{self.location}: {message}"
        return f"{self.location}, column {self.offset + column}: {message}"


# ASCII only (docs/design.md): ids join rows across artifacts, and a letter of another script can
# be written in two ways that look the same (é as one code point, or e and a combining mark)
NAME_CHARS = "ASCII letters, digits, _ . -"


def is_valid_name(name: str) -> bool:
    """True when `name` can be a formula's `name:` in a `.ltl` file (`[A-Za-z0-9_.-]+`)."""
    return bool(_VALID_NAME.fullmatch(name))


def check_names(names: Iterable[str], what: str) -> None:
    """InputError unless every generated name or id is valid and none repeats: checked where
    they are written, since a `.ltl` line with a bad name reads back as another formula, and
    ids that repeat merge rows that should stay apart."""
    seen: set[str] = set()
    for name in names:
        if not is_valid_name(name):
            raise InputError(f"{what} '{name}' is not a valid name (allowed: {NAME_CHARS})")
        if name in seen:
            raise InputError(f"{what} '{name}' is written twice")
        seen.add(name)


def read_formulas(path: str | Path) -> list[FormulaSource]:
    """Formulas from a `.ltl` file or a Parquet table (by suffix); InputError when the file is
    unusable. A `.decl` is refused here: `knowledge.rule_files.read_rule_file` reads it."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if path.suffix == ".parquet":
        return _read_parquet(path)
    if path.suffix.lower() == ".decl":
        raise InputError(
            f"{path}: a Declare model (.decl) is not read here: this input takes a .ltl file or "
            "a Parquet table of formula_id, formula"
        )
    text = read_text_file(path)
    return parse_ltl_text(text, str(path))


def parse_ltl_text(text: str, name: str = "<text>") -> list[FormulaSource]:
    out: list[FormulaSource] = []
    first_seen: dict[str, int] = {}
    # Only "\n" ends a line (not the other separators str.splitlines knows), so line numbers
    # match what editors show.
    for lineno, raw in enumerate(text.split("\n"), start=1):
        line = raw.split("#", 1)[0].strip()  # strip() also drops a CRLF's "\r"
        if not line:
            continue
        fid, body, problem = f"L{lineno}", line, None
        m = _NAMED.match(line)
        if m:
            label, body = m.group(1), m.group(2).strip()
            if not body:
                problem = "empty formula after the name"
            if not _VALID_NAME.fullmatch(label):
                problem = f"invalid formula name '{label}' (allowed: {NAME_CHARS})"
            elif label in first_seen:
                problem = f"name '{label}' already used on line {first_seen[label]}"
            else:
                fid = label
        if fid in first_seen and problem is None:
            problem = f"id '{fid}' already used on line {first_seen[fid]}"
            fid = f"L{lineno}"
        first_seen.setdefault(fid, lineno)
        offset = raw.find(body) if body else 0
        out.append(FormulaSource(fid, body, name, f"line {lineno}", offset, problem))
    return out


def _read_parquet(path: Path) -> list[FormulaSource]:
    try:
        table = pq.read_table(path)
    except (pa.ArrowException, OSError) as e:
        raise InputError(f"{path}: not a readable Parquet file ({e})") from None
    missing = {"formula_id", "formula"} - set(table.column_names)
    if missing:
        raise InputError(
            f"{path}: expected columns formula_id and formula, missing {', '.join(sorted(missing))}"
        )
    ids = table.column("formula_id").to_pylist()
    texts = table.column("formula").to_pylist()
    out: list[FormulaSource] = []
    first_seen: dict[str, int] = {}
    for row, (fid, text) in enumerate(zip(ids, texts, strict=True)):
        problem = None
        if fid is None or str(fid) == "":
            fid, problem = f"row{row}", "formula_id is empty"
        fid = str(fid)
        if not isinstance(text, str):
            text, problem = "", problem or "formula is not a string"
        if fid in first_seen and problem is None:
            problem = f"formula_id '{fid}' already used on row {first_seen[fid]}"
            fid = f"{fid}@row{row}"
        first_seen.setdefault(fid, row)
        out.append(FormulaSource(fid, text.strip(), str(path), f"row {row}", 0, problem))
    return out
