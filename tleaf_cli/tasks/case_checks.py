"""Conformance of an event log's cases to a knowledge base (`tleaf check-cases`): every case
checked against every rule, exactly, and a summary of who breaks what.

Input: a `cases` artifact (`read-log`, with or without kept attributes) and a knowledge base read
by `read_formulas` (`.ltl`, a formula table, or a Declare model `.decl` with its MP-Declare
conditions), each rule named. Each rule is compiled once to its minimal DFA (compile-dfa's
stage, `compile_sources`: formula progression, MONA past its limits, through the disk cache) and
the cases go through the batched exact checker (`PackedDFAs`, logic/checker.py), one event a
letter.

**Names.** A `.decl` model's activities are matched to the log's names exactly and read the
atoms the log's cases artifact gave them (`read_case_rules(path, cases.activity_atoms)`), so
"Check-in" never binds the log's "Check in".

**Letters.** An event's letter is the set of atoms true at it (`Case.letters`): its activity's
atom; for each attribute the artifact keeps, the atom of "attribute is value"
(`attribute_atom`); and each MP-Declare condition atom whose test holds on the event's values
(knowledge/decl_conditions.py: one atom per condition, whatever its attribute's domain size,
numbers compared as numbers). A rule naming activity atoms only is compiled one-hot (an event
makes exactly one activity atom true: the shortcut every other stage takes); a rule naming
another atom is compiled over the powerset of its own atoms, so "Closed done by someone other
than Value 3" (`closed & org_resource__is_not__value_3`) reads both atoms true at one event.
A condition on an attribute the artifact does not keep is refused (read the log with
`read-log --attributes`); an event value outside the model's declared domain is tested as it
is (Declare4Py's reading) and counted (`CaseChecks.outside`).

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
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from tleaf_cli.data.artifacts import describe_inputs, write_artifact, write_text_atomic
from tleaf_cli.data.cases import Cases
from tleaf_cli.data.compile_dfas import compile_sources
from tleaf_cli.data.dfa_table import dfa_from_row
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.data.formula_files import FormulaSource
from tleaf_cli.data.skip_report import EXAMPLES
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.decl_conditions import EventCondition
from tleaf_cli.knowledge.rule_files import read_rule_file
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
    """One rule of the knowledge base: its name, formula, the atoms it names, where it is, and
    the test behind each of its condition atoms (MP-Declare conditions)."""

    name: str
    formula: str
    atoms: tuple[str, ...]
    where: str
    conditions: dict[str, EventCondition] = field(default_factory=dict, compare=False)

    @property
    def one_hot(self) -> bool:
        """It names activity atoms only: its DFA reads the one-hot alphabet."""
        return not self.conditions and not any("__" in a for a in self.atoms)


@dataclass
class CaseChecks:
    """Every case against every rule: `satisfied[i, j]` is case i (in the artifact's order)
    against rule j; `alphabet` the letters' kind; `unseen` rule name -> the atoms it names that
    no event of the log has; `outside` attribute -> (events whose value of it lies outside the
    model's declared domain, a few such values), for the attributes conditions read."""

    case_ids: list[str]
    splits: list[str]
    rules: list[CaseRule]
    satisfied: np.ndarray
    alphabet: str
    unseen: dict[str, tuple[str, ...]]
    outside: dict[str, tuple[int, tuple[str, ...]]] = field(default_factory=dict)

    def broken_per_case(self) -> np.ndarray:
        """int [cases]: how many rules each case breaks."""
        return (~self.satisfied).sum(axis=1)

    def broken_per_rule(self) -> np.ndarray:
        """int [rules]: how many cases break each rule."""
        return (~self.satisfied).sum(axis=0)


def read_case_rules(
    path: str | os.PathLike, log_atoms: dict[str, str] | None = None
) -> list[CaseRule]:
    """The rules of a knowledge base (`read_rule_file`; a `.decl`'s activities bound to the
    log's atoms `log_atoms`), in file order; InputError naming the file and line for a line with
    a problem or a formula that does not parse, and for no rule."""
    rules: list[CaseRule] = []
    seen: dict[str, str] = {}
    for source in read_rule_file(path, log_atoms):
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
        rules.append(
            CaseRule(
                source.formula_id,
                source.text,
                tuple(sorted(named)),
                where,
                dict(source.conditions),
            )
        )
    if not rules:
        raise InputError(f"{path}: no rules (an empty file, or only comments)")
    return rules


def check_cases(
    cases: Cases,
    rules: Sequence[CaseRule],
    settings: CompileSettings | None = None,
    on_progress: Callable[[int, int], None] | None = None,
) -> CaseChecks:
    """Every case of `cases` against every rule (see the module docstring); InputError for a
    rule that does not compile (named with its file and line), a condition on an attribute the
    cases do not keep, or a case without events. `on_progress(done, total)`: the rules compiled,
    then the rules checked."""
    tests = rule_tests(rules, cases)
    letters = [case.letters(tests=tests) for case in cases.cases]
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
    kinds = {rule.one_hot for rule in rules}
    alphabet = {True: "one-hot", False: "powerset"}[kinds.pop()] if len(kinds) == 1 else "mixed"
    steps = 2 * len(rules)  # each rule compiled, then checked

    def compiled(done: int, _total: int) -> None:
        if on_progress is not None:
            on_progress(done, steps)

    dfas = compile_rules(rules, None, settings, compiled)
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
        if on_progress is not None:
            on_progress(len(rules) + ks.stop, steps)
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
        outside_domains(cases, tests),
    )


def rule_tests(rules: Sequence[CaseRule], cases: Cases) -> dict[str, EventCondition]:
    """Every condition atom of `rules` -> its test; InputError naming the rule for a condition
    on an event attribute the cases do not keep."""
    tests: dict[str, EventCondition] = {}
    for rule in rules:
        for atom, test in rule.conditions.items():
            missing = [a for a in test.attributes if a not in cases.attribute_names]
            if missing:
                kept = ", ".join(cases.attribute_names) or "none"
                raise InputError(
                    f"{rule.where}: rule {rule.name}'s condition reads the event attribute "
                    f"{missing[0]!r}, which {cases.path} does not keep (it keeps: {kept}): read "
                    "the log again keeping that event attribute (read-log's attributes)"
                )
            tests[atom] = test
    return tests


def outside_domains(
    cases: Cases, tests: dict[str, EventCondition]
) -> dict[str, tuple[int, tuple[str, ...]]]:
    """attribute -> (events whose value of it is outside the declared domain, up to EXAMPLES
    such values), for the attributes the conditions read."""
    domains = {a: d for test in tests.values() for a, d in test.domains.items()}
    out: dict[str, tuple[int, tuple[str, ...]]] = {}
    for attribute, domain in domains.items():
        counts: Counter[str] = Counter(
            v
            for case in cases.cases
            for v in case.attributes.get(attribute, ())
            if v is not None and not domain.holds(v)
        )
        if counts:
            out[attribute] = (
                sum(counts.values()),
                tuple(v for v, _ in counts.most_common(EXAMPLES)),
            )
    return out


def compile_rules(
    rules: Sequence[CaseRule],
    alphabet: str | None = None,
    settings: CompileSettings | None = None,
    on_progress: Callable[[int, int], None] | None = None,
) -> list[DFA]:
    """Each rule's minimal DFA over `alphabet` (one-hot or powerset of its own atoms; None: each
    rule its own, `CaseRule.one_hot`), through compile-dfa's stage; InputError naming the rule's
    file and line for one that fails."""
    base = settings or CompileSettings()
    kinds = [alphabet or ("one-hot" if r.one_hot else "powerset") for r in rules]
    dfas: list[DFA | None] = [None] * len(rules)
    done = 0
    for kind in dict.fromkeys(kinds):
        which = [k for k, rule_kind in enumerate(kinds) if rule_kind == kind]
        sources = [
            FormulaSource(rules[k].name, rules[k].formula, rules[k].where, "") for k in which
        ]

        def progress(n: int, _total: int, before: int = done) -> None:
            if on_progress is not None:
                on_progress(before + n, len(rules))

        report = compile_sources(sources, replace(base, alphabet=kind), progress)
        for k, row in zip(which, report.rows, strict=True):
            if row["error"] is not None:
                raise InputError(f"{rules[k].where}: rule {row['error']}")
            dfas[k] = dfa_from_row(row)
        done += len(which)
    return dfas


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
        "conditions": {
            atom: test.text()
            for rule in checks.rules
            for atom, test in sorted(rule.conditions.items())
        },
        "values_outside_declared_domains": {
            attribute: {"events": events, "examples": list(examples)}
            for attribute, (events, examples) in checks.outside.items()
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
    on_progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """`tleaf check-cases`: read the cases and the rules (a `.decl`'s names bound to the cases'
    atoms), check, write; the summary."""
    cases = read_cases(cases_path)
    rules = read_case_rules(knowledge, cases.activity_atoms)
    checks = check_cases(cases, rules, settings, on_progress)
    return write_checks(checks, out, [cases_path, knowledge])
