"""Conformance of an event log's cases to a knowledge base (`tleaf check-cases`): every case
checked against every rule, exactly, and a summary of who breaks what.

Input: a `cases` artifact (`read-log`, with or without kept attributes) and a knowledge base read
by `read_formulas` (`.ltl`, a formula table, or a Declare model `.decl` with its MP-Declare
conditions), each rule named. Each rule is compiled once to its minimal DFA (compile-dfa's
stage, `compile_sources`: formula progression, MONA past its limits, through the disk cache) and
the cases go through the batched exact checker (`PackedDFAs`, logic/checker.py), one event a
letter.

**Letters.** An event's letter is the set of atoms true at it (`Case.letters`): its activity's
atom and, for each attribute the artifact keeps, the atom of "attribute is value"
(`attribute_atom`). Where no rule names an atom other than an activity's, the DFAs are one-hot
(an event makes exactly one activity atom true: the shortcut every other stage takes); where a
rule names an attribute atom, every DFA is over the powerset of its atoms, so "Closed done by
Value 3" (`closed & org_resource__value_3`) is read as both atoms true at one event.

**Atoms the log never has.** A rule naming an activity or attribute value that no event of the
log has is still checked (a Response from an absent activity holds vacuously, an Existence of it
fails), and it is reported: counted, and the first few named with the atoms they miss
(`CaseChecks.unseen`), never silently true.

Output (`write_checks`): a `case_checks` Parquet artifact, one row per case and rule (`case_id`,
`rule`, `satisfied`, `split`), and beside it `<OUT stem>.summary.json`: the cases, rules and
alphabet; how many rules each case breaks (as a histogram, and the cases breaking most); per rule
how many cases break it; the rules naming unseen atoms. A rule that does not parse or compile, a
name used twice, or no rule at all is an InputError naming the file and line, nothing written.
"""

from __future__ import annotations

import json
import os
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from tleaf_cli.data.artifacts import describe_inputs, write_artifact, write_text_atomic
from tleaf_cli.data.cases import Cases
from tleaf_cli.data.compile_dfas import compile_sources
from tleaf_cli.data.dfa_table import dfa_from_row
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.data.formula_files import FormulaSource, read_formulas
from tleaf_cli.data.skip_report import EXAMPLES
from tleaf_cli.errors import InputError
from tleaf_cli.logic.checker import PackedDFAs
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.formulas import FormulaSyntaxError, atoms, parse
from tleaf_cli.settings.data import CompileSettings
from tleaf_cli.version import __version__

KIND = "case_checks"
SCHEMA_VERSION = 1
SUMMARY_SUFFIX = ".summary.json"
CELLS_PER_BATCH = 1 << 22  # (case, rule, step) letters checked at once: ~32 MB of int64
MOST_BROKEN = 10  # the cases breaking most rules the summary names


@dataclass(frozen=True)
class CaseRule:
    """One rule of the knowledge base: its name, formula, the atoms it names, where it is."""

    name: str
    formula: str
    atoms: tuple[str, ...]
    where: str


@dataclass
class CaseChecks:
    """Every case against every rule: `satisfied[i, j]` is case i (in the artifact's order)
    against rule j; `alphabet` the letters' kind; `unseen` rule name -> the atoms it names that
    no event of the log has."""

    case_ids: list[str]
    splits: list[str]
    rules: list[CaseRule]
    satisfied: np.ndarray
    alphabet: str
    unseen: dict[str, tuple[str, ...]]

    def broken_per_case(self) -> np.ndarray:
        """int [cases]: how many rules each case breaks."""
        return (~self.satisfied).sum(axis=1)

    def broken_per_rule(self) -> np.ndarray:
        """int [rules]: how many cases break each rule."""
        return (~self.satisfied).sum(axis=0)


def read_case_rules(path: str | os.PathLike) -> list[CaseRule]:
    """The rules of a knowledge base (`read_formulas`), in file order; InputError naming the file
    and line for a line with a problem or a formula that does not parse, and for no rule."""
    rules: list[CaseRule] = []
    seen: dict[str, str] = {}
    for source in read_formulas(path):
        where = f"{source.path}, {source.location}"
        if source.problem is not None:
            raise InputError(f"{where}: {source.problem}")
        if source.formula_id in seen:
            raise InputError(
                f"{where}: rule '{source.formula_id}' is also at {seen[source.formula_id]}"
            )
        seen[source.formula_id] = where
        try:
            named = atoms(parse(source.text))
        except FormulaSyntaxError as e:
            raise InputError(f"{where}: {e}") from None
        rules.append(CaseRule(source.formula_id, source.text, tuple(sorted(named)), where))
    if not rules:
        raise InputError(f"{path}: no rules (an empty file, or only comments)")
    return rules


def check_cases(
    cases: Cases, rules: Sequence[CaseRule], settings: CompileSettings | None = None
) -> CaseChecks:
    """Every case of `cases` against every rule (see the module docstring); InputError for a
    rule that does not compile (named with its file and line) or a case without events."""
    letters = [case.letters() for case in cases.cases]
    if any(not case_letters for case_letters in letters):
        empty = next(c.case_id for c, ls in zip(cases.cases, letters, strict=True) if not ls)
        raise InputError(f"{cases.path}: case {empty} has no events")
    distinct: dict[frozenset[str], int] = {}
    lengths = np.array([len(ls) for ls in letters], dtype=np.int64)
    events = np.zeros((len(letters), int(lengths.max(initial=1))), dtype=np.int64)
    for i, case_letters in enumerate(letters):
        events[i, : len(case_letters)] = [
            distinct.setdefault(ls, len(distinct)) for ls in case_letters
        ]
    log_atoms = set().union(*distinct) if distinct else set()
    activity_atoms = set(cases.activity_atoms.values())
    one_hot = all(a in activity_atoms for rule in rules for a in rule.atoms)
    alphabet = "one-hot" if one_hot else "powerset"
    dfas = compile_rules(rules, alphabet, settings)
    satisfied = np.zeros((len(letters), len(rules)), dtype=bool)
    packed = PackedDFAs(dfas)
    order = list(distinct)  # distinct letter id -> its atoms
    codes = [np.array([d.alphabet.index(ls) for ls in order], dtype=np.int64) for d in dfas]
    per_rule = max(1, len(letters) * events.shape[1])
    step = max(1, CELLS_PER_BATCH // per_rule)
    for start in range(0, len(rules), step):
        ks = range(start, min(start + step, len(rules)))
        which = np.repeat(np.array(ks, dtype=np.int64), len(letters))
        batch = np.concatenate([codes[k][events] for k in ks])
        kept = packed.check(which, batch, np.tile(lengths, len(ks)))
        satisfied[:, ks.start : ks.stop] = kept.reshape(len(ks), len(letters)).T
    unseen = {
        rule.name: tuple(a for a in rule.atoms if a not in log_atoms)
        for rule in rules
        if any(a not in log_atoms for a in rule.atoms)
    }
    return CaseChecks(
        [c.case_id for c in cases.cases],
        [c.split for c in cases.cases],
        list(rules),
        satisfied,
        alphabet,
        unseen,
    )


def compile_rules(
    rules: Sequence[CaseRule], alphabet: str, settings: CompileSettings | None = None
) -> list[DFA]:
    """Each rule's minimal DFA over `alphabet` (one-hot or powerset of its own atoms), through
    compile-dfa's stage; InputError naming the rule's file and line for one that fails."""
    chosen = replace(settings or CompileSettings(), alphabet=alphabet)
    sources = [FormulaSource(r.name, r.formula, r.where, r.name) for r in rules]
    report = compile_sources(sources, chosen)
    for rule, row in zip(rules, report.rows, strict=True):
        if row["error"] is not None:
            raise InputError(f"{rule.where}: rule {row['error']}")
    return [dfa_from_row(row) for row in report.rows]


def summarise(checks: CaseChecks) -> dict[str, Any]:
    """The figures of a check: rules broken per case (histogram, mean, the cases breaking most),
    cases breaking each rule, and the rules that name atoms the log never has."""
    per_case = checks.broken_per_case()
    per_rule = checks.broken_per_rule()
    n = len(checks.case_ids)
    most = np.argsort(-per_case, kind="stable")[:MOST_BROKEN]
    return {
        "cases": n,
        "rules": len(checks.rules),
        "alphabet": checks.alphabet,
        "cases_keeping_every_rule": int((per_case == 0).sum()),
        "rules_broken_per_case": {
            "mean": float(per_case.mean()) if n else 0.0,
            "histogram": {str(k): v for k, v in sorted(Counter(per_case.tolist()).items())},
            "most": [
                {"case_id": checks.case_ids[i], "broken": int(per_case[i])}
                for i in most
                if per_case[i] > 0
            ],
        },
        "rules_kept_by_every_case": int((per_rule == 0).sum()),
        "cases_per_rule": [
            {"rule": r.name, "broken": int(b), "satisfied": n - int(b)}
            for r, b in zip(checks.rules, per_rule, strict=True)
        ],
        "rules_naming_unseen_atoms": {
            "count": len(checks.unseen),
            "examples": [
                f"{k} ({', '.join(v)})" for k, v in list(checks.unseen.items())[:EXAMPLES]
            ],
        },
    }


def summary_path(out: str | os.PathLike) -> Path:
    """Where the summary of OUT.parquet goes: OUT.summary.json beside it."""
    out = Path(out)
    return out.with_name(out.stem + SUMMARY_SUFFIX)


def write_checks(
    checks: CaseChecks, out: str | os.PathLike, inputs: Sequence[str | os.PathLike]
) -> dict[str, Any]:
    """The `case_checks` artifact at `out` (one row per case and rule) and its summary beside
    it, each written atomically; the summary."""
    n_cases, n_rules = checks.satisfied.shape
    table = pa.table(
        {
            "case_id": pa.array(
                np.repeat(np.array(checks.case_ids, dtype=object), n_rules), pa.string()
            ),
            "rule": pa.array(
                np.tile(np.array([r.name for r in checks.rules], dtype=object), n_cases),
                pa.string(),
            ),
            "satisfied": pa.array(checks.satisfied.ravel(), pa.bool_()),
            "split": pa.array(
                np.repeat(np.array(checks.splits, dtype=object), n_rules), pa.string()
            ),
        }
    )
    summary = summarise(checks)
    described = describe_inputs(inputs)
    params = {
        "alphabet": checks.alphabet,
        "rules_naming_unseen_atoms": summary["rules_naming_unseen_atoms"],
    }
    write_artifact(table, out, kind=KIND, schema=SCHEMA_VERSION, params=params, inputs=described)
    record = {"tleaf": __version__, "inputs": described, **summary}
    write_text_atomic(summary_path(out), json.dumps(record, indent=2) + "\n")
    return summary


def check_case_file(
    cases_path: str | os.PathLike,
    knowledge: str | os.PathLike,
    out: str | os.PathLike,
    settings: CompileSettings | None = None,
) -> dict[str, Any]:
    """`tleaf check-cases`: read the cases and the rules, check, write; the summary."""
    rules = read_case_rules(knowledge)
    cases = read_cases(cases_path)
    checks = check_cases(cases, rules, settings)
    return write_checks(checks, out, [cases_path, knowledge])
