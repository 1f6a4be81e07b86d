"""Real recordings checked against their recipe's rules: which rules each recording breaks, and how
well "breaks a rule" finds the recordings with errors.

Input: a `recordings` artifact (`read-recordings`) and the recipes' rules, a `.ltl` knowledge base
or a folder of them (`task-graph`), each rule named `<recipe>.<kind>.<rest>` (the recipe as the
recordings' `recipe` column names it; the kind `before`, `once`, `ends` or any other word). Every
rule is compiled to its exact one-hot DFA (`RuleSet`) and every recording of its recipe is run
through it (`PackedDFAs`): a recording is one step a letter, its steps' atoms in time order.

The report (`summarise`):

- per recipe: its rules, its normal (no error) and error recordings, how many of each break at
  least one rule, and for every broken rule how many normal and error recordings break it;
- detection: "breaks a rule" as a prediction of `has_errors`, with precision, recall, F1 and
  accuracy, on every checked recording and per split, and per kind of rule (a recording "breaks"
  when it breaks a rule of that kind);
- per error category (the annotation's tags, e.g. Order Error, Missing Step): of the recordings
  that have it, how many break a rule (its recall), and the same on the recordings whose only
  category it is, so a category's recall is not borrowed from another error in the recording;
  and the same on the error recordings with an Order Error or a Missing Step (the categories
  about the steps' order and presence) against those with other errors only.

A recording whose recipe has no rule is not checked (counted per recipe); rules of recipes that
no recording has are counted, and so are the rules that name a step no recording of their recipe
has (`unseen_step_rules`, the first few named): such a rule holds on every recording whatever its
order (another recipe's rules under this recipe's name hold vacuously), so it is said, not
hidden in a recall of 0. A rule without a recipe in its name, a formula file line with a
problem, or two rules of one name stop with InputError naming the file and line.
"""

from __future__ import annotations

import json
import os
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from tleaf_cli.data.artifacts import describe_inputs, write_artifact, write_text_atomic
from tleaf_cli.data.captaincook import Recording, load_recordings
from tleaf_cli.data.formula_files import read_formulas
from tleaf_cli.data.skip_report import EXAMPLES
from tleaf_cli.errors import InputError
from tleaf_cli.logic.checker import PackedDFAs
from tleaf_cli.logic.formulas import FormulaSyntaxError, atoms, parse
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.version import __version__

KIND = "recording_checks"
SCHEMA_VERSION = 1
METRICS_FILE = "metrics.json"
CHECKS_FILE = "checks.parquet"
REPORT_FILE = "report.md"
ALL = "all"
# the error categories about which steps happen in which order: what precedence rules speak of
SEQUENCE_CATEGORIES = ("Order Error", "Missing Step")


@dataclass(frozen=True)
class RecipeRule:
    """One rule of a recipe: its name, kind (the name's second part) and formula."""

    name: str
    recipe: str
    kind: str
    formula: str
    atoms: tuple[str, ...]


def rule_files(knowledge: str | os.PathLike) -> list[Path]:
    """The `.ltl` files of `knowledge`: the file itself, or a folder's `*.ltl` in name order."""
    knowledge = Path(knowledge)
    if knowledge.is_dir():
        files = sorted(knowledge.glob("*.ltl"))
        if not files:
            raise InputError(f"{knowledge}: a folder without .ltl files")
        return files
    if not knowledge.exists():
        raise InputError(f"{knowledge}: no such file")
    return [knowledge]


def read_recipe_rules(files: Sequence[Path]) -> dict[str, list[RecipeRule]]:
    """recipe -> its rules, in file order, from `.ltl` files whose rules are named
    `<recipe>.<kind>.<rest>`; InputError for a line with a problem, a rule without a recipe in
    its name, or a name used twice."""
    by_recipe: dict[str, list[RecipeRule]] = {}
    seen: dict[str, str] = {}
    for path in files:
        for source in read_formulas(path):
            where = f"{source.path}, {source.location}"
            if source.problem is not None:
                raise InputError(f"{where}: {source.problem}")
            name = source.formula_id
            parts = name.split(".")
            if len(parts) < 2 or not parts[0] or not parts[1]:
                raise InputError(
                    f"{where}: rule '{name}' is not named <recipe>.<kind>... (as task-graph "
                    "names its rules), so its recipe is unknown"
                )
            if name in seen:
                raise InputError(f"{where}: rule '{name}' is also at {seen[name]}")
            seen[name] = where
            try:
                mentioned = atoms(parse(source.text))
            except FormulaSyntaxError as e:
                raise InputError(f"{where}: {e}") from None
            rule = RecipeRule(name, parts[0], parts[1], source.text, tuple(mentioned))
            by_recipe.setdefault(rule.recipe, []).append(rule)
    if not by_recipe:
        raise InputError(f"{', '.join(map(str, files))}: no rules")
    return by_recipe


def check_recordings(
    rows: Sequence[Recording], rules: dict[str, list[RecipeRule]]
) -> list[dict[str, Any]]:
    """Per recording (in `rows`' order): its id, recipe, split, has_errors, error categories,
    steps, whether its recipe has rules (`checked`) and the names of the rules it breaks."""
    out = []
    by_recipe: dict[str, list[int]] = {}
    for k, row in enumerate(rows):
        by_recipe.setdefault(row.recipe, []).append(k)
    broken: dict[int, list[str]] = {}
    for recipe, ks in by_recipe.items():
        recipe_rules = rules.get(recipe, [])
        ks = [k for k in ks if rows[k].atoms]  # the checker reads non-empty traces
        if not recipe_rules or not ks:
            continue
        traces = [[{a} for a in rows[k].atoms] for k in ks]
        mentioned = {a for r in recipe_rules for a in r.atoms}
        vocabulary = sorted(mentioned | {a for t in traces for letter in t for a in letter})
        sets = [RuleSet(r.formula, vocabulary, name=r.name) for r in recipe_rules]
        n = len(sets)
        which = np.tile(np.arange(n), len(ks))
        kept = PackedDFAs([s.dfa for s in sets]).check_traces(
            which, [t for t in traces for _ in range(n)]
        )
        for k, row_kept in zip(ks, kept.reshape(len(ks), n), strict=True):
            broken[k] = [r.name for r, ok in zip(recipe_rules, row_kept, strict=True) if not ok]
    for k, row in enumerate(rows):
        out.append(
            {
                "recording_id": row.case_id,
                "recipe": row.recipe,
                "split": row.split,
                "has_errors": bool(row.has_errors),
                "error_categories": list(row.error_categories),
                "steps": len(row.atoms),
                "checked": k in broken,
                "broken_rules": broken.get(k, []),
            }
        )
    return out


def unseen_step_rules(
    rows: Sequence[Recording], rules: dict[str, list[RecipeRule]]
) -> dict[str, Any]:
    """The rules, of recipes that have recordings, that name a step (atom) no recording of
    their recipe has: `count`, and the first few as 'name (atoms)' in file order."""
    seen: dict[str, set[str]] = {}
    for row in rows:
        seen.setdefault(row.recipe, set()).update(row.atoms)
    found = [
        f"{rule.name} ({', '.join(sorted(set(rule.atoms) - seen[recipe]))})"
        for recipe, recipe_rules in sorted(rules.items())
        if recipe in seen
        for rule in recipe_rules
        if set(rule.atoms) - seen[recipe]
    ]
    return {"count": len(found), "examples": found[:EXAMPLES]}


def detection(pairs: Sequence[tuple[bool, bool]]) -> dict[str, Any]:
    """(has_errors, predicted) pairs as counts and precision, recall, F1, accuracy (None where a
    ratio has nothing to divide by)."""
    tp = sum(1 for e, p in pairs if e and p)
    fp = sum(1 for e, p in pairs if not e and p)
    fn = sum(1 for e, p in pairs if e and not p)
    tn = len(pairs) - tp - fp - fn
    precision = _ratio(tp, tp + fp)
    recall = _ratio(tp, tp + fn)
    f1 = None
    if precision is not None and recall is not None:
        f1 = _ratio(2 * precision * recall, precision + recall) or 0.0
    return {
        "recordings": len(pairs),
        "tp": tp,
        "fp": fp,
        "fn": fn,
        "tn": tn,
        "precision": precision,
        "recall": recall,
        "f1": f1,
        "accuracy": _ratio(tp + tn, len(pairs)),
    }


def _ratio(a: float, b: float) -> float | None:
    return a / b if b else None


def summarise(checks: Sequence[dict[str, Any]], rules: dict[str, list[RecipeRule]]) -> dict:
    """The report of `check_recordings`' rows (see the module docstring)."""
    done = [c for c in checks if c["checked"]]
    if not done:
        recipes = sorted({c["recipe"] for c in checks})[:5]
        raise InputError(
            f"no recording's recipe has rules (recordings' recipes: {', '.join(recipes)}, ...; "
            f"rules' recipes: {', '.join(sorted(rules)[:5])}, ...)"
        )
    kind_of = {r.name: r.kind for rs in rules.values() for r in rs}
    kinds = list(dict.fromkeys(r.kind for rs in rules.values() for r in rs))
    known = {"train": 0, "val": 1, "test": 2}  # the dataset's order, then any other name
    splits = sorted({c["split"] for c in done}, key=lambda s: (known.get(s, 3), s))
    by_split = {
        s: detection(
            [(c["has_errors"], bool(c["broken_rules"])) for c in done if s in (ALL, c["split"])]
        )
        for s in [ALL, *splits]
    }
    by_kind = {
        kind: detection(
            [(c["has_errors"], any(kind_of[r] == kind for r in c["broken_rules"])) for c in done]
        )
        | {"rules": sum(1 for k in kind_of.values() if k == kind)}
        for kind in kinds
    }
    categories = sorted({t for c in done for t in c["error_categories"]})
    by_category = {t: _category(done, t) for t in categories}
    errors = [c for c in done if c["has_errors"]]
    sequence = [c for c in errors if set(SEQUENCE_CATEGORIES) & set(c["error_categories"])]
    others = [c for c in errors if c not in sequence]
    by_sequence = {
        " or ".join(SEQUENCE_CATEGORIES): _caught(sequence),
        "other errors only": _caught(others),
    }
    unchecked = Counter(c["recipe"] for c in checks if not c["checked"])
    return {
        "recordings": len(checks),
        "checked": len(done),
        "unchecked_by_recipe": dict(sorted(unchecked.items())),
        "rules": len(kind_of),
        "rules_without_recordings": {
            r: len(rs) for r, rs in sorted(rules.items()) if r not in {c["recipe"] for c in checks}
        },
        "detection": by_split,
        "detection_by_kind": by_kind,
        "by_category": by_category,
        "by_sequence_errors": by_sequence,
        "by_recipe": [_recipe(done, r, rules[r]) for r in sorted({c["recipe"] for c in done})],
    }


def _category(done: Sequence[dict[str, Any]], tag: str) -> dict[str, Any]:
    having = [c for c in done if tag in c["error_categories"]]
    only = [c for c in having if len(set(c["error_categories"])) == 1]
    caught = sum(1 for c in having if c["broken_rules"])
    caught_only = sum(1 for c in only if c["broken_rules"])
    return {
        "recordings": len(having),
        "breaking": caught,
        "recall": _ratio(caught, len(having)),
        "only_recordings": len(only),
        "only_breaking": caught_only,
        "only_recall": _ratio(caught_only, len(only)),
    }


def _caught(recordings: Sequence[dict[str, Any]]) -> dict[str, Any]:
    caught = sum(1 for c in recordings if c["broken_rules"])
    return {
        "recordings": len(recordings),
        "breaking": caught,
        "recall": _ratio(caught, len(recordings)),
    }


def _recipe(done: Sequence[dict[str, Any]], recipe: str, rules: list[RecipeRule]) -> dict:
    mine = [c for c in done if c["recipe"] == recipe]
    per_rule: dict[str, dict[str, int]] = {}
    for c in mine:
        for name in c["broken_rules"]:
            counts = per_rule.setdefault(name, {"normal": 0, "error": 0})
            counts["error" if c["has_errors"] else "normal"] += 1
    order = {r.name: k for k, r in enumerate(rules)}
    ranked = sorted(per_rule.items(), key=lambda kv: (-sum(kv[1].values()), order[kv[0]]))
    return {
        "recipe": recipe,
        "rules": len(rules),
        "normal": sum(1 for c in mine if not c["has_errors"]),
        "normal_breaking": sum(1 for c in mine if not c["has_errors"] and c["broken_rules"]),
        "error": sum(1 for c in mine if c["has_errors"]),
        "error_breaking": sum(1 for c in mine if c["has_errors"] and c["broken_rules"]),
        "broken_rules": dict(ranked),
    }


_TYPES = {
    "recording_id": pa.string(),
    "recipe": pa.string(),
    "split": pa.string(),
    "has_errors": pa.bool_(),
    "error_categories": pa.list_(pa.string()),
    "steps": pa.int64(),
    "checked": pa.bool_(),
    "broken_rules": pa.list_(pa.string()),
}


def check_recordings_report(
    recordings: str | os.PathLike, knowledge: str | os.PathLike, out_dir: str | os.PathLike
) -> dict:
    """Check every recording of `recordings` against its recipe's rules in `knowledge` (a `.ltl`
    or a folder of them); write `metrics.json` (the report, with version and inputs) and
    `checks.parquet` (one row per recording) in `out_dir`, and return the report."""
    files = rule_files(knowledge)
    rules = read_recipe_rules(files)
    rows = load_recordings(recordings).cases
    checks = check_recordings(rows, rules)
    report = summarise(checks, rules)
    inputs = describe_inputs([Path(recordings), *files])
    unseen = unseen_step_rules(rows, rules)
    report = {
        "version": __version__,
        "inputs": inputs,
        **report,
        "rules_naming_unseen_steps": unseen,
    }
    out_dir = Path(out_dir)
    table = pa.table({c: pa.array([r[c] for r in checks], t) for c, t in _TYPES.items()})
    params = {"knowledge": str(knowledge), "rules": report["rules"], "checked": report["checked"]}
    write_artifact(
        table, out_dir / CHECKS_FILE, kind=KIND, schema=SCHEMA_VERSION, params=params, inputs=inputs
    )
    write_text_atomic(out_dir / METRICS_FILE, json.dumps(report, indent=2))
    write_text_atomic(out_dir / REPORT_FILE, markdown(report_tables(report)))
    return report


Table = tuple[str, list[str], list[list[str]]]  # title, columns, rows of cells


def report_tables(report: dict) -> list[Table]:
    """The report as three tables: per recipe, detection (per split and per kind of rule), and
    per error category."""
    recipes = [
        [
            r["recipe"],
            str(r["rules"]),
            f"{r['normal_breaking']} / {r['normal']}",
            f"{r['error_breaking']} / {r['error']}",
            _top_rule(r["broken_rules"]),
        ]
        for r in report["by_recipe"]
    ]
    d = report["detection"]
    total = report["by_recipe"]
    recipes.append(
        [
            "all",
            str(sum(r["rules"] for r in total)),
            f"{sum(r['normal_breaking'] for r in total)} / {sum(r['normal'] for r in total)}",
            f"{sum(r['error_breaking'] for r in total)} / {sum(r['error'] for r in total)}",
            "",
        ]
    )
    rows = [["any rule", split, *_scores(m)] for split, m in d.items()]
    rows += [[f"a '{k}' rule", ALL, *_scores(m)] for k, m in report["detection_by_kind"].items()]
    categories = [
        [
            tag,
            f"{c['breaking']} / {c['recordings']}",
            _pct(c["recall"]),
            f"{c['only_breaking']} / {c['only_recordings']}",
            _pct(c["only_recall"]),
        ]
        for tag, c in report["by_category"].items()
    ]
    categories += [
        [name, f"{c['breaking']} / {c['recordings']}", _pct(c["recall"]), "", ""]
        for name, c in report["by_sequence_errors"].items()
    ]
    return [
        (
            "recordings breaking at least one rule of their recipe",
            ["recipe", "rules", "normal", "with errors", "most broken (normal / error)"],
            recipes,
        ),
        (
            "'breaks a rule' as a detector of recordings with errors",
            ["breaks", "split", "recordings", "TP", "FP", "FN", "TN", "precision", "recall", "F1"],
            rows,
        ),
        (
            "error categories: recordings with the category that break a rule",
            ["category", "breaking", "recall", "only this category", "recall (only)"],
            categories,
        ),
    ]


def _scores(m: dict[str, Any]) -> list[str]:
    counts = [str(m[k]) for k in ("recordings", "tp", "fp", "fn", "tn")]
    return counts + [_pct(m[k]) for k in ("precision", "recall", "f1")]


def _pct(value: float | None) -> str:
    return "—" if value is None else f"{100 * value:.1f}"


def score_text(value: float | None) -> str:
    """A score as the summary line says it: '66.7 %', or '—' where it is undefined (nothing to
    divide by), as the tables show it."""
    return "—" if value is None else f"{_pct(value)} %"


def _top_rule(broken: dict[str, dict[str, int]]) -> str:
    if not broken:
        return ""
    name, counts = next(iter(broken.items()))
    return f"{name.split('.', 1)[1]} ({counts['normal']} / {counts['error']})"


def markdown(tables: Sequence[Table]) -> str:
    """The tables as markdown, each under its title in bold."""
    parts = []
    for title, columns, rows in tables:
        lines = [f"**{title}**", "", "| " + " | ".join(columns) + " |"]
        lines.append("|" + "---|" * len(columns))
        lines += ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |" for row in rows]
        parts.append("\n".join(lines))
    return "\n\n".join(parts) + "\n"
