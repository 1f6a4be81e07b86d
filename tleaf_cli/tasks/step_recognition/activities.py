"""CaptainCook4D's recordings as an `activities` artifact, and their recipes' task graphs as its
knowledge base (`tleaf recording-activities`), so that `train-task action-recognition` learns to
recognise the steps of real procedures unchanged.

The videos are out of reach (hundreds of GB), so each step's feature is drawn, but along the
REAL recordings: the steps, their order, their durations, the recipe's rules and which
recordings break them are the dataset's.

Labels. A step is the pair (action, ingredient) = (`s<node>`, recipe): the task graph's node
id of the step (`s3`, as task-graph names rules) and the recipe (`coffee`), so its atom is
`s3_coffee`; a step's text atom (`step_atom`, what read-recordings writes) is matched to its
graph's node by text. Two nodes with one text (three recipes repeat a step) are one step here,
the first node's, as in the rules. Action accuracy is then the step's, pair accuracy the step's
and its recipe's; the per-ingredient rule sets of train-task are the per-recipe rule sets.

Knowledge. The graph's rules as `task-graph` writes them (the same edges, options and skipped
duplicates: `graph_rules`), each atom renamed to its step's, each rule named
`ordering.<recipe>.<kind>.<nodes>` (the action-recognition knowledge base's naming).

Features (documented in docs/procedures.md). Each step class c = (step, recipe) has a mean
μ_c ~ N(0, I_D), drawn once for every node of every graph in sorted order. A step performed for
d seconds is seen as k = max(1, round(d / frame_s)) frames, each μ_c + N(0, σ² I); its feature is
their mean, μ_c + N(0, σ²/k · I). Long steps are therefore easier to recognise than short ones,
as in a video; σ sets how hard the task is (the default leaves the reference well below
perfect: docs/results/captaincook4d.md).

Order. Recordings are interleaved by recipe (each recipe's first recording in file order, then
each one's second, ...), so that the first N recordings of the train split, which
`--train-videos N` reads, span the recipes. The split is the recordings artifact's.
"""

from __future__ import annotations

import os
import re
import zlib
from collections import Counter
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from tleaf_cli.data.artifacts import check_writable, describe_inputs, write_artifact
from tleaf_cli.data.captaincook import Recording, load_recordings
from tleaf_cli.data.traces import SPLITS
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.base import KnowledgeBase, Rule, write_knowledge_base
from tleaf_cli.knowledge.task_graphs import TaskGraph, graph_files, graph_rules, read_task_graph
from tleaf_cli.logic.formulas import atoms, parse
from tleaf_cli.settings.procedures import StepFeatureSettings
from tleaf_cli.tasks.action_recognition.activities import (
    KIND,
    SCHEMA_VERSION,
    activities_table,
    name_problem,
)

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


@dataclass
class ConversionReport:
    """What `recording_activities` wrote and left out."""

    videos: dict[str, int] = field(default_factory=dict)  # per split
    steps: int = 0
    rules: int = 0
    skipped: Counter = field(default_factory=Counter)  # "no graph", "no split"
    not_in_graph: dict[str, dict[str, str]] = field(default_factory=dict)  # recipe: text -> atom


def step_names(graph: TaskGraph) -> dict[str, str]:
    """text atom -> step atom `s<node>_<recipe>` for each step of `graph` (a repeated text: its
    first node's); InputError when the recipe or a node cannot name an atom."""
    problem = name_problem(graph.recipe, "ingredient")
    if problem:
        raise InputError(f"{graph.path}: recipe {problem}")
    names: dict[str, str] = {}
    for k, node in enumerate(graph.step_nodes(), 1):
        action = graph.label[node]
        if name_problem(action, "action"):
            action = f"s{k}"  # an edge list's node: its position
        names.setdefault(graph.atoms[node], f"{action}_{graph.recipe}")
    return names


def step_rules(
    graph: TaskGraph,
    names: dict[str, str],
    at_most_once: bool = False,
    last_step_ends: bool = False,
) -> list[Rule]:
    """The graph's rules (`graph_rules`) over the step atoms `names`, named `ordering.<rule>`."""
    out = []
    for rule in graph_rules(graph, at_most_once, last_step_ends):
        formula = _NAME.sub(lambda m: names.get(m.group(0), m.group(0)), rule.formula)
        out.append(Rule(f"ordering.{rule.name}", "ordering", formula, atoms(parse(formula))))
    return out


def class_means(
    graphs: Sequence[TaskGraph], features: StepFeatureSettings
) -> dict[str, np.ndarray]:
    """μ per step atom, drawn for every step of every graph in sorted order (so a recording's
    means do not depend on which recordings are converted)."""
    rng = np.random.default_rng([features.seed, 1])
    steps = sorted({a for g in graphs for a in step_names(g).values()})
    return dict(zip(steps, rng.standard_normal((len(steps), features.feature_dim)), strict=True))


def interleaved(rows: Sequence[Recording]) -> list[Recording]:
    """Rows interleaved by recipe: every recipe's first row (recipes in order of first
    appearance), then every recipe's second, ..."""
    by_recipe: dict[str, list[Recording]] = {}
    for row in rows:
        by_recipe.setdefault(row.recipe, []).append(row)
    rounds = max((len(v) for v in by_recipe.values()), default=0)
    return [v[i] for i in range(rounds) for v in by_recipe.values() if i < len(v)]


def recording_activities(
    recordings: str | os.PathLike,
    graphs: str | os.PathLike,
    out: str | os.PathLike,
    kb_out: str | os.PathLike,
    features: StepFeatureSettings | None = None,
    at_most_once: bool = False,
    last_step_ends: bool = False,
) -> ConversionReport:
    """Write the activities artifact `out` and its knowledge base `kb_out` (module docstring).

    Recordings whose recipe has no graph, or in no split, are left out and counted; a step that
    is not a node of its recipe's graph gets an atom of its own (`_step_atoms`)."""
    features = features or StepFeatureSettings()
    features.check()
    for target in (out, kb_out):
        check_writable(target)
    rows = load_recordings(recordings).cases
    read = [read_task_graph(p) for p in graph_files(graphs)]
    by_recipe = {g.recipe: g for g in read}
    names = {g.recipe: step_names(g) for g in read}
    means = class_means(read, features)
    report = ConversionReport()
    kept = []
    for row in interleaved(rows):
        if row.recipe not in by_recipe:
            report.skipped["no graph"] += 1
        elif row.split not in SPLITS:
            report.skipped["no split"] += 1
        else:
            kept.append((row, _step_atoms(row, names[row.recipe], report)))
    if not kept:
        raise InputError(f"{recordings}: no recording of a recipe in {graphs} has a split")
    for recipe, unknown in report.not_in_graph.items():
        for text_atom, step in unknown.items():
            means[step] = _unknown_mean(step, features)
            names[recipe][text_atom] = step
    rng = np.random.default_rng([features.seed, 2])
    columns: dict[str, list] = {k: [] for k in ("ids", "steps", "actions", "ingredients", "splits")}
    drawn: list[np.ndarray] = []
    for row, text_atoms in kept:
        step_atoms = [names[row.recipe].get(a, a) for a in text_atoms]
        seconds = np.subtract(row.end_s, row.start_s)
        frames = np.maximum(1, np.round(seconds / features.frame_seconds))
        noise = rng.standard_normal((len(step_atoms), features.feature_dim))
        drawn.append(
            np.stack([means[a] for a in step_atoms])
            + noise * (features.noise / np.sqrt(frames))[:, None]
        )
        for k, a in enumerate(step_atoms):
            action, ingredient = a.split("_", 1)
            columns["actions"].append(action)
            columns["ingredients"].append(ingredient)
            columns["steps"].append(k)
            columns["ids"].append(row.recording_id)
            columns["splits"].append(row.split)
        report.videos[row.split] = report.videos.get(row.split, 0) + 1
        report.steps += len(step_atoms)
    kb = KnowledgeBase(
        tuple(
            r
            for g in read
            if g.recipe in {row.recipe for row in rows}
            for r in step_rules(g, names[g.recipe], at_most_once, last_step_ends)
        )
    )
    report.rules = len(kb)
    table = activities_table(
        columns["ids"],
        np.asarray(columns["steps"]),
        columns["actions"],
        columns["ingredients"],
        np.concatenate(drawn),
        columns["splits"],
    )
    params = {
        "data": "CaptainCook4D recordings (real step orders, durations, splits and rules) with "
        "drawn features: each step's the mean of its frames, each frame its step class's mean "
        "plus Gaussian noise (tleaf recording-activities)",
        "features": asdict(features),
        "at_most_once": at_most_once,
        "last_step_ends": last_step_ends,
        "videos": report.videos,
        "skipped": dict(report.skipped),
    }
    options = [
        o
        for o, on in (("--at-most-once", at_most_once), ("--last-step-ends", last_step_ends))
        if on
    ]
    write_knowledge_base(
        kb,
        kb_out,
        [
            f"the task graphs of {Path(graphs).name} over steps s<node>_<recipe>, written by "
            f"tleaf recording-activities {' '.join(options)}".rstrip(),
            "an edge a -> b as (!b U a) | G !b (b not before the first a, nor without a)",
        ],
    )
    inputs = describe_inputs([recordings, *graph_files(graphs)])
    write_artifact(table, out, kind=KIND, schema=SCHEMA_VERSION, params=params, inputs=inputs)
    return report


def _step_atoms(row: Recording, names: dict[str, str], report: ConversionReport) -> list[str]:
    """The recording's steps as step atoms, in its order; a step that is not a node of its
    recipe's graph (two in CaptainCook4D) is `u<k>_<recipe>`, k numbering those texts of the
    recipe in sorted order (no rule names it), and counted."""
    out = []
    for text_atom in row.atoms:
        if text_atom not in names:
            unknown = report.not_in_graph.setdefault(row.recipe, {})
            unknown[text_atom] = ""
            for k, t in enumerate(sorted(unknown), 1):
                unknown[t] = f"u{k}_{row.recipe}"
        out.append(text_atom)  # a step atom once every recording is read
    return out


def _unknown_mean(step: str, features: StepFeatureSettings) -> np.ndarray:
    """μ of a step that is not in its graph: drawn from its name (the same in every conversion)."""
    return np.random.default_rng([features.seed, 3, zlib.crc32(step.encode())]).standard_normal(
        features.feature_dim
    )
