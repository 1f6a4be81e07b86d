"""The `kb-extract` stage: every video's rule set from its labelled pairs, each distinct set
compiled once (one-hot DFAs), optionally a knowledge base mined from the train split first.

Writes OUT/samples.parquet (kind `kb-samples`: video_id, split, formula_id = the rule set's id,
num_rules, rules, ingredients) and OUT/dfas.parquet (one row per distinct rule set), and
OUT/kb.ltl when mining. With `rule_sets="ingredient"` a video's rule set is split per ingredient
(`knowledge.base.by_ingredient`): one samples row per (video, ingredient), the training formulas
of a q for `train-task --rule-sets ingredient`. The knowledge-base model itself (rules,
extraction, mining) is in `tleaf_cli/knowledge/base.py`.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import pyarrow as pa

from tleaf_cli.data.artifacts import (
    check_writable,
    describe_inputs,
    write_artifact,
)
from tleaf_cli.data.compile_dfas import CompileSettings, compile_sources
from tleaf_cli.data.dfa_table import KIND as DFA_KIND
from tleaf_cli.data.dfa_table import SCHEMA_VERSION as DFA_SCHEMA
from tleaf_cli.data.dfa_table import rows_to_table
from tleaf_cli.data.formula_files import FormulaSource, check_names
from tleaf_cli.errors import InputError, TleafError
from tleaf_cli.knowledge.base import (
    KnowledgeBase,
    Rule,
    by_ingredient,
    ingredient_of,
    mine_knowledge_base,
    read_knowledge_base,
    rule_set_id,
    rules_for,
    sample_formula,
    write_knowledge_base,
)
from tleaf_cli.logic.mona import MonaError, mona_binary
from tleaf_cli.settings import check_values
from tleaf_cli.settings.knowledge import ExtractSettings
from tleaf_cli.tasks.action_recognition.activities import UNLABELLED, Activities, read_activities

SAMPLES_KIND = "kb-samples"
SAMPLES_SCHEMA = 2  # 2: `ingredients` column; several rows per video with --rule-sets ingredient
SAMPLES_COLUMNS = pa.schema(
    [
        ("video_id", pa.string()),
        ("split", pa.string()),
        ("formula_id", pa.string()),  # the rule_set_id: a row of dfas.parquet
        ("num_rules", pa.int32()),
        ("rules", pa.list_(pa.string())),  # the rule names, sorted (added by tleaf)
        ("ingredients", pa.list_(pa.string())),  # the ingredients the rules name, sorted
    ]
)


def _mine_train_split(activities: Activities, min_support: int) -> KnowledgeBase:
    train = activities.split("train")
    if not train:
        raise InputError(f"{activities.path}: no train videos to mine a knowledge base from")
    return mine_knowledge_base(
        (activities.pairs(v) for v in train),
        (activities.actions, activities.ingredients),
        min_support,
    )


@dataclass
class ExtractReport:
    """What `kb-extract` did, for its summary line and exit status."""

    videos: int
    rule_sets: int
    compiled: int
    cache_hits: int
    rules_total: int
    rules_used: int
    mined: int | None  # rules mined from the train split; None when not mining
    failures: list[tuple[str, str]]
    seconds: float


def video_rule_sets(
    kb: KnowledgeBase, activities: Activities, rule_sets: str = "video"
) -> tuple[list[tuple[str, list[Rule]]], dict[str, list[Rule]]]:
    """Per labelled video (id, its rules from the labelled pairs) — with
    `rule_sets="ingredient"` one entry per ingredient that has rules instead — and each
    distinct rule set by id. Videos of the `unlabelled` split are left out: their
    labels are never read."""
    per_video = [
        (v.video_id, rules_for(kb, activities.atoms(v)))
        for v in activities.videos
        if v.split != UNLABELLED
    ]
    if rule_sets == "ingredient":
        per_video = [(vid, group) for vid, rules in per_video for group in by_ingredient(rules)]
    distinct: dict[str, list[Rule]] = {}
    for _, rules in per_video:
        known = distinct.setdefault(rule_set_id(rules), rules)
        if {r.name for r in known} != {r.name for r in rules}:  # a hash collision: never merge
            raise TleafError(f"two rule sets share the id {rule_set_id(rules)}")
    check_names(distinct, "rule set id")
    return per_video, distinct


def extract_knowledge(
    kb_path: str | os.PathLike | None,
    activities_path: str | os.PathLike,
    out_dir: str | os.PathLike,
    settings: CompileSettings,
    extract: ExtractSettings | None = None,
    on_progress: Callable[[int, int], None] | None = None,
) -> ExtractReport:
    """The `kb-extract` stage: OUT/samples.parquet, OUT/dfas.parquet (one-hot, one row per
    distinct rule set), and OUT/kb.ltl when mining (`extract`: which rules, mined or not;
    default `ExtractSettings()`). A TleafError when the call is unusable."""
    start = time.perf_counter()
    extract = extract or ExtractSettings()
    check_values(extract)
    mine, min_support = extract.mine, extract.min_support
    if kb_path is None and not mine:
        raise InputError("no knowledge base file: give one, or mine=True to mine the train split")
    try:
        mona_binary()
    except MonaError as e:
        raise TleafError(str(e)) from None
    out = Path(out_dir)
    for name in ("samples.parquet", "dfas.parquet", "kb.ltl"):
        check_writable(out / name)
    kb = read_knowledge_base(kb_path) if kb_path is not None else KnowledgeBase()
    activities = read_activities(activities_path)

    mined = None
    if mine:
        found = _mine_train_split(activities, min_support)
        read = f", merged after the {len(kb)} rules of {kb_path}" if kb_path else ""
        kb, mined = kb.merged(found), len(found)
        header = [
            f"knowledge base mined by tleaf kb-extract from the train split of {activities_path}",
            f"min support {min_support}: {mined} rules mined{read}; {len(kb)} rules in all",
        ]
        write_knowledge_base(kb, out / "kb.ltl", header)
    kb_source = str(kb_path) if kb_path is not None else str(out / "kb.ltl")

    per_video, distinct = video_rule_sets(kb, activities, extract.rule_sets)
    sources = [
        FormulaSource(rid, sample_formula(rules), kb_source, f"rule set {rid}")
        for rid, rules in distinct.items()
    ]
    report = compile_sources(sources, replace(settings, alphabet="one-hot"), on_progress)
    inputs = describe_inputs([p for p in (kb_path, activities_path) if p is not None])
    params = {
        "alphabet": "one-hot",
        "timeout": settings.timeout,
        "formula_from": extract.formula_from,
        "rule_sets": extract.rule_sets,
        "mine": mine,
        "min_support": min_support if mine else None,
    }
    write_artifact(
        rows_to_table(report.rows),
        out / "dfas.parquet",
        kind=DFA_KIND,
        schema=DFA_SCHEMA,
        params=params,
        inputs=inputs,
    )
    split_of = {v.video_id: v.split for v in activities.videos}
    samples = [
        {
            "video_id": vid,
            "split": split_of[vid],
            "formula_id": rule_set_id(rules),
            "num_rules": len(rules),
            "rules": sorted(r.name for r in rules),
            "ingredients": sorted({ingredient_of(a) for r in rules for a in r.atoms}),
        }
        for vid, rules in per_video
    ]
    write_artifact(
        pa.Table.from_pylist(samples, schema=SAMPLES_COLUMNS),
        out / "samples.parquet",
        kind=SAMPLES_KIND,
        schema=SAMPLES_SCHEMA,
        params=params,
        inputs=inputs,
    )
    used = {r.name for _, rules in per_video for r in rules}
    return ExtractReport(
        videos=sum(v.split != UNLABELLED for v in activities.videos),
        rule_sets=len(distinct),
        compiled=report.compiled,
        cache_hits=report.cache_hits,
        rules_total=len(kb),
        rules_used=len(used),
        mined=mined,
        failures=report.failures,
        seconds=time.perf_counter() - start,
    )
