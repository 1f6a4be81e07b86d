"""recording-activities on the shipped CaptainCook4D files: the activities keep every
recording's real steps, order, split and rule violations, and train-task reads them unchanged."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.captaincook import load_recordings
from tleaf_cli.knowledge.base import read_knowledge_base
from tleaf_cli.knowledge.task_graphs import graph_files, read_task_graph
from tleaf_cli.tasks.action_recognition.activities import read_activities
from tleaf_cli.tasks.procedure_checks import check_recordings, read_recipe_rules
from tleaf_cli.tasks.step_recognition.activities import interleaved, step_names

DATA = Path(__file__).parent.parent / "examples" / "captaincook4d"


def invoke(*args: object) -> None:
    result = CliRunner().invoke(app, [str(a) for a in args])
    assert result.exit_code == 0, result.output


@pytest.fixture(scope="module")
def converted(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("captaincook")
    paths = {k: folder / f for k, f in (
        ("recordings", "recordings.parquet"), ("edges", "edges.ltl"),
        ("activities", "activities.parquet"), ("kb", "kb.ltl"),
    )}  # fmt: skip
    invoke("read-recordings", DATA / "annotation_json", "--splits",
           DATA / "data_splits" / "recordings_data_split_combined.json",
           "-o", paths["recordings"])  # fmt: skip
    invoke("task-graph", DATA / "task_graphs", "-o", paths["edges"])
    invoke("recording-activities", paths["recordings"], DATA / "task_graphs",
           "-o", paths["activities"], "--kb-out", paths["kb"])  # fmt: skip
    return paths


def test_every_recording_keeps_its_steps_order_and_split(converted) -> None:
    rows = load_recordings(converted["recordings"]).cases
    data = read_activities(converted["activities"])
    graphs = {g.recipe: g for g in map(read_task_graph, graph_files(DATA / "task_graphs"))}
    videos = {v.video_id: v for v in data.videos}
    assert len(videos) == len(rows) == 384
    assert [v.video_id for v in data.videos] == [r.recording_id for r in interleaved(rows)]
    for row in rows:
        video = videos[row.recording_id]
        assert video.split == row.split
        names = step_names(graphs[row.recipe])
        expected = [names.get(a, "u") for a in row.atoms]
        got = data.atoms(video)
        assert len(got) == len(expected)
        for step, want in zip(got, expected, strict=True):
            assert step.endswith(f"_{row.recipe}")
            assert (want == "u" and step.startswith("u")) or step == want
    assert data.feature_dim == 32 and all(np.isfinite(v.features).all() for v in data.videos)


def test_the_first_train_recordings_span_the_recipes(converted) -> None:
    train = read_activities(converted["activities"]).split("train")
    recipes = {v.video_id: r.recipe for r in load_recordings(converted["recordings"]).cases
               for v in train if v.video_id == r.recording_id}  # fmt: skip
    assert len({recipes[v.video_id] for v in train[:24]}) >= 20


def test_the_step_rules_break_where_the_text_rules_do(converted, tmp_path) -> None:
    """Checking the step atoms against the step knowledge base finds, recording by recording,
    the same broken rules as check-recordings on the text atoms."""
    rows = load_recordings(converted["recordings"]).cases
    data = read_activities(converted["activities"])
    steps = {v.video_id: data.atoms(v) for v in data.videos}
    kb = read_knowledge_base(converted["kb"])
    assert len(kb) == 356 and all(r.kind == "ordering" for r in kb)
    plain = tmp_path / "steps.ltl"  # check-recordings reads <recipe>.<kind>... names
    plain.write_text("".join(f"{r.name.removeprefix('ordering.')}: {r.formula}\n" for r in kb))
    text_checks = check_recordings(rows, read_recipe_rules([converted["edges"]]))
    step_rows = [replace(r, atoms=tuple(steps[r.recording_id])) for r in rows]
    step_checks = check_recordings(step_rows, read_recipe_rules([plain]))
    assert [c["broken_rules"] for c in step_checks] == [c["broken_rules"] for c in text_checks]
    assert sum(bool(c["broken_rules"]) for c in text_checks) == 198  # 16 normal + 182 with errors


def test_longer_steps_get_less_noise(converted) -> None:
    """A step's feature averages its frames: its distance to the class mean shrinks with its
    duration (the same step class, drawn many times)."""
    rows = {r.recording_id: r for r in load_recordings(converted["recordings"]).cases}
    data = read_activities(converted["activities"])
    spread: dict[str, list[tuple[float, np.ndarray]]] = {}
    for v in data.videos:
        row = rows[v.video_id]
        for atom, f, s, e in zip(data.atoms(v), v.features, row.start_s, row.end_s,
                                 strict=True):  # fmt: skip
            spread.setdefault(atom, []).append((e - s, f))
    short, long = [], []
    for items in spread.values():
        if len(items) < 8:
            continue
        mean = np.mean([f for _, f in items], axis=0)
        cut = np.median([d for d, _ in items])
        short += [np.linalg.norm(f - mean) for d, f in items if d < cut]
        long += [np.linalg.norm(f - mean) for d, f in items if d > cut]
    assert np.mean(long) < np.mean(short)


def test_refusals_exit_2_with_nothing_written(converted, tmp_path) -> None:
    """Not a recordings artifact; a folder that is not a run; a split with no recording."""
    runner = CliRunner()
    out = tmp_path / "a.parquet"
    result = runner.invoke(app, ["recording-activities", str(converted["activities"]),
                                 str(DATA / "task_graphs"), "-o", str(out),
                                 "--kb-out", str(tmp_path / "kb.ltl")])  # fmt: skip
    assert result.exit_code == 2 and "recordings" in result.output and not out.exists()
    args = ["eval", "step-recognition", tmp_path, "--checks", converted["activities"]]
    result = runner.invoke(app, [*map(str, args), "-o", str(tmp_path / "e")])
    assert result.exit_code == 2 and not (tmp_path / "e").exists()
