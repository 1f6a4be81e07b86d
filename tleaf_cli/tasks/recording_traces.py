"""Real recordings as Table I traces: the paper's model-checking question asked of real step orders.

Table I asks whether q's vectors alone tell if a trace satisfies a formula, one formula per trace
label. Here a recipe is one formula, the conjunction of its rules (`recipe_formulas`, written by
`tleaf recipe-formulas`: one `.ltl` line per recipe, named by the recipe), and a recording is a
trace over its recipe's formula: one step a letter, its step's atom, in time order; its label is
the exact answer, "breaks none of its recipe's rules", from `check_recordings` (the same check as
`tleaf check-recordings`, one DFA per rule).

`recording_traces` writes a `traces` artifact that `tleaf eval model-checking` reads as it is:

- train and val: the synthetic traces of the train and val recipes (`gen-traces` on the compiled
  recipe formulas with `--split`), on which the evaluation fits and chooses its classifiers;
- test: every recording (of every dataset split) of the recipes that `gen-traces`' split held
  out, source `recorded`, so that q, its classifiers and the test recordings share no recipe.

The evaluation's `all_accuracy` is then the accuracy against the exact answer on real recordings;
its `accuracy` and `balanced_accuracy` read only satisfying and `uniform` traces (Table I's), and
so leave out the recordings that break a rule. A recording of a recipe without rules, without a
compiled formula in the synthetic traces, or without steps is left out and counted.
"""

from __future__ import annotations

import os
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import pyarrow as pa

from tleaf_cli.data.artifacts import (
    check_writable,
    describe_inputs,
    write_artifact,
    write_text_atomic,
)
from tleaf_cli.data.captaincook import load_recordings
from tleaf_cli.data.traces import COLUMNS, KIND, SCHEMA_VERSION, read_traces
from tleaf_cli.errors import InputError, MissingSplitError
from tleaf_cli.tasks.procedure_checks import check_recordings, read_recipe_rules, rule_files

RECORDED = "recorded"  # the `source` of a real recording's trace


def recipe_formulas(knowledge: str | os.PathLike) -> dict[str, str]:
    """recipe -> the conjunction of its rules (each parenthesised, in file order), from a `.ltl`
    knowledge base or a folder of them whose rules are named `<recipe>.<kind>...`."""
    rules = read_recipe_rules(rule_files(knowledge))
    return {r: " & ".join(f"({x.formula})" for x in rs) for r, rs in sorted(rules.items())}


def write_recipe_formulas(knowledge: str | os.PathLike, out: str | os.PathLike) -> dict[str, str]:
    """Write `recipe_formulas(knowledge)` to `out`, one `<recipe>: <formula>` line each."""
    check_writable(out)
    formulas = recipe_formulas(knowledge)
    lines = [
        f"# one formula per recipe: the conjunction of its rules in {Path(knowledge).name}",
        *(f"{recipe}: {formula}" for recipe, formula in formulas.items()),
    ]
    write_text_atomic(Path(out), "\n".join(lines) + "\n")
    return formulas


@dataclass
class RecordingTraces:
    """What `recording_traces` wrote: synthetic traces kept per split, recordings per label,
    the held-out recipes, and the recordings left out (why -> count)."""

    synthetic: dict[str, int]
    recorded: dict[str, int]  # "keeps" / "breaks" -> recordings
    test_recipes: list[str]
    left_out: dict[str, int] = field(default_factory=dict)


def recording_traces(
    recordings: str | os.PathLike,
    knowledge: str | os.PathLike,
    traces: str | os.PathLike,
    out: str | os.PathLike,
) -> RecordingTraces:
    """Write the traces artifact described in the module docstring to `out`: `traces`' train
    and val rows, and as test every recording of the recipes in `traces`' test split, labelled
    by the exact check against `knowledge`'s rules."""
    check_writable(out)
    synthetic = read_traces(traces)
    if "split" not in synthetic.column_names:
        raise MissingSplitError(traces)
    rows = synthetic.to_pylist()
    split_of = {r["formula_id"]: r["split"] for r in rows}
    held_out = sorted(f for f, s in split_of.items() if s == "test")
    if not held_out:
        raise InputError(f"{traces}: no test recipe (the split holds none out)")
    rules = read_recipe_rules(rule_files(knowledge))
    recorded = load_recordings(recordings).cases
    checks = check_recordings(recorded, rules)

    kept = [r | {"recording_id": None} for r in rows if r["split"] in ("train", "val")]
    left_out: Counter = Counter()
    labels: Counter = Counter()
    for k, (row, check) in enumerate(zip(recorded, checks, strict=True)):
        recipe = row.recipe
        if recipe not in split_of:
            left_out["recipe without a formula in the traces"] += 1
        elif split_of[recipe] != "test":
            continue  # a train or val recipe: q and the classifiers have seen it
        elif not check["checked"]:
            left_out["no steps, or a recipe without rules"] += 1
        else:
            keeps = not check["broken_rules"]
            labels["keeps" if keeps else "breaks"] += 1
            kept.append(
                {
                    "formula_id": recipe,
                    "trace_id": k,
                    "trace": [[a] for a in row.atoms],
                    "label": keeps,
                    "source": RECORDED,
                    "split": "test",
                    "recording_id": row.case_id,
                }
            )
    if not labels:
        raise InputError(f"{recordings}: no recording of the held-out recipes {held_out}")
    schema = pa.schema([*COLUMNS, ("split", pa.string()), ("recording_id", pa.string())])
    params = {
        "data": "train/val: synthetic traces of the train/val recipes; test: real recordings of "
        "the held-out recipes, labelled by the exact check of their recipe's rules",
        "test_recipes": held_out,
    }
    write_artifact(
        pa.Table.from_pylist(kept, schema=schema),
        out,
        kind=KIND,
        schema=SCHEMA_VERSION,
        params=params,
        inputs=describe_inputs([recordings, *rule_files(knowledge), traces]),
    )
    return RecordingTraces(
        synthetic=dict(
            sorted(Counter(r["split"] for r in kept if r["source"] != RECORDED).items())
        ),
        recorded=dict(sorted(labels.items())),
        test_recipes=held_out,
        left_out=dict(left_out),
    )
