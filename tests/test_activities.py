"""Activities: the synthetic generator (KB satisfied, seeds, format) and the reader's checks."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.artifacts import read_provenance, write_artifact
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.base import atom, read_knowledge_base, rules_for, sample_formula
from tleaf_cli.logic.formulas import atoms, parse
from tleaf_cli.logic.semantics import satisfies
from tleaf_cli.tasks.action_recognition import activity_gen
from tleaf_cli.tasks.action_recognition.activities import name_problem, read_activities

runner = CliRunner()
SMALL = ["--actions", 8, "--ingredients", 10, "--feature-dim", 6]
SMALL += ["--train", 20, "--val", 5, "--test", 5, "--min-steps", 3, "--max-steps", 9]


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def generated(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("act")
    paths = {"data": d / "act.parquet", "kb": d / "kb.ltl"}
    result = tleaf("gen-activities", "-o", paths["data"], "--kb-out", paths["kb"], *SMALL)
    assert result.exit_code == 0, result.output
    return paths


def test_every_generated_video_satisfies_the_knowledge_base(generated) -> None:
    """The paper's reading: a video satisfies K when it satisfies every rule that applies to it
    (all of the rule's atoms occur); the check runs the LTLf evaluator on the conjunction."""
    data = read_activities(generated["data"])
    kb = read_knowledge_base(generated["kb"])
    assert kb.of_kind("affordance") and kb.of_kind("ordering")
    forbidden = {r.atoms[0] for r in kb.of_kind("affordance")}
    applied = 0
    for video in data.videos:
        steps = data.atoms(video)
        rules = rules_for(kb, steps)
        assert not forbidden & set(steps)
        assert satisfies([{a} for a in steps], parse(sample_formula(rules))), video.video_id
        applied += len(rules)
    assert applied > len(data.videos)  # orderings are exercised, not vacuously true


def test_the_check_fails_on_a_broken_video(generated) -> None:
    """Not vacuous: a video with an unafforded step, or two ordered steps swapped, fails it."""
    data = read_activities(generated["data"])
    kb = read_knowledge_base(generated["kb"])

    def ok(steps: list[str]) -> bool:
        return satisfies([{a} for a in steps], parse(sample_formula(rules_for(kb, steps))))

    forbidden = kb.of_kind("affordance")[0].atoms[0]
    assert not ok([*data.atoms(data.videos[0]), forbidden])
    video = next(
        v for v in data.videos if any(r.kind == "ordering" for r in rules_for(kb, data.atoms(v)))
    )
    steps = data.atoms(video)
    rule = next(r for r in rules_for(kb, steps) if r.kind == "ordering")
    first, then = rule.name.split(".")[1:3]
    i, j = steps.index(first), steps.index(then)
    steps[i], steps[j] = steps[j], steps[i]
    assert ok(data.atoms(video)) and not ok(steps)


def test_format_schema_and_provenance(generated) -> None:
    table = pq.read_table(generated["data"])
    assert table.schema.field("step").type == pa.int32()
    assert table.schema.field("feature").type == pa.list_(pa.float32(), 6)
    assert table.column_names == ["video_id", "step", "action", "ingredient", "feature", "split"]
    rows = table.select(["video_id", "step"]).to_pylist()
    assert rows == sorted(rows, key=lambda r: (r["video_id"], r["step"]))
    prov = read_provenance(generated["data"])
    assert prov.kind == "activities" and prov.params["data"].startswith("synthetic")
    assert prov.params["seed"] == 0 and prov.params["actions"] == 8
    assert all(v.startswith("synthetic-") for v in table.column("video_id").to_pylist())
    data = read_activities(generated["data"])
    counts = {s: len(data.split(s)) for s in ("train", "val", "test")}
    assert counts == {"train": 20, "val": 5, "test": 5}
    lengths = [len(v) for v in data.videos]
    assert min(lengths) >= 3 and max(lengths) <= 9
    for v in data.videos:
        assert len({i for i in v.ingredients}) <= activity_gen.MAX_INGREDIENTS_PER_VIDEO
    assert "SYNTHETIC" in generated["kb"].read_text().splitlines()[0]


def test_same_seed_same_files_other_seed_other_files(tmp_path: Path) -> None:
    made = []
    for name, seed in [("a", 4), ("b", 4), ("c", 5)]:
        data, kb = tmp_path / f"{name}.parquet", tmp_path / f"{name}.ltl"
        assert (
            tleaf("gen-activities", "-o", data, "--kb-out", kb, *SMALL, "--seed", seed).exit_code
            == 0
        )
        made.append((pq.read_table(data), kb.read_text()))
    assert made[0][0].equals(made[1][0]) and made[0][1] == made[1][1]
    assert not made[0][0].equals(made[2][0])


def test_confusable_pulls_paired_means_together() -> None:
    rng = np.random.default_rng(0)
    pairs = activity_gen.confusable_pairs(np.array([0, 0, 1, 1, 2, 3]), rng)
    assert all(a != b for a, b in pairs)
    far = activity_gen.class_means(6, 32, pairs, 0.0, np.random.default_rng(1))
    near = activity_gen.class_means(6, 32, pairs, 0.75, np.random.default_rng(1))
    for a, b in pairs:
        assert np.linalg.norm(near[a] - near[b]) == pytest.approx(
            0.25 * np.linalg.norm(far[a] - far[b])
        )
    stage = np.array([0, 0, 1, 1, 2, 3])
    assert all(stage[a] != stage[b] for a, b in activity_gen.confusable_pairs(stage, rng))


def test_ingredient_scale_scales_only_the_ingredient_means(tmp_path: Path) -> None:
    """Same seed, --ingredient-scale 1 vs 3: same labels and knowledge base; per step the
    features differ by 2 x the step's ingredient mean, the same vector wherever the ingredient
    is the same, and different for different ingredients."""
    made = []
    for scale in (1, 3):
        data, kb = tmp_path / f"a{scale}.parquet", tmp_path / f"kb{scale}.ltl"
        argv = ("gen-activities", "-o", data, "--kb-out", kb, *SMALL, "--ingredient-scale", scale)
        assert tleaf(*argv).exit_code == 0
        made.append((read_activities(data), kb.read_text()))
    (one, kb1), (three, kb3) = made
    assert kb1 == kb3
    shift = {}
    for v1, v3 in zip(one.videos, three.videos, strict=True):
        assert (v1.actions == v3.actions).all() and (v1.ingredients == v3.ingredients).all()
        for i, d in zip(v1.ingredients, v3.features - v1.features, strict=True):
            np.testing.assert_allclose(d, shift.setdefault(int(i), d), atol=1e-4)
    vectors = list(shift.values())
    assert len(vectors) > 2 and np.linalg.norm(vectors[0] - vectors[1]) > 0.1


def test_every_vocabulary_name_makes_a_valid_atom() -> None:
    actions, stages, ingredients = activity_gen.vocabulary(
        activity_gen.MAX_ACTIONS, activity_gen.MAX_INGREDIENTS
    )
    assert len(set(actions)) == 64 and len(set(ingredients)) == 155
    assert set(stages[:5]) == set(range(len(activity_gen.STAGES)))  # small vocabularies span all
    for a, i in itertools.chain(
        ((a, ingredients[-1]) for a in actions), ((actions[0], i) for i in ingredients)
    ):
        assert name_problem(a, "action") is None and name_problem(i, "ingredient") is None
        assert atoms(parse(f"G !{atom(a, i)}")) == (atom(a, i),)


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("--actions", 65),
        ("--ingredients", 0),
        ("--confusable", 1.5),
        ("--ingredient-scale", 0),
        ("--min-steps", 0),
    ],
)
def test_impossible_settings_exit_2(tmp_path: Path, option: str, value) -> None:
    out = tmp_path / "a.parquet"
    result = tleaf("gen-activities", "-o", out, "--kb-out", tmp_path / "kb.ltl", option, value)
    assert result.exit_code == 2 and option in result.output and "Traceback" not in result.output
    assert not out.exists()


# The reader, on tiny hand-written files.


def _rows() -> list[dict]:
    return [
        {
            "video_id": "v1",
            "step": 0,
            "action": "wash",
            "ingredient": "onion",
            "feature": [1.0, 0.0],
        },
        {
            "video_id": "v1",
            "step": 1,
            "action": "cut",
            "ingredient": "onion",
            "feature": [0.0, 1.0],
        },
        {
            "video_id": "v2",
            "step": 0,
            "action": "pour",
            "ingredient": "olive_oil",
            "feature": [2, 2],
        },
    ]


def _write(path: Path, rows: list[dict]) -> Path:
    pq.write_table(pa.Table.from_pylist(rows), path)
    return path


def test_reads_real_data_without_split(tmp_path: Path) -> None:
    data = read_activities(_write(tmp_path / "real.parquet", _rows()))
    assert data.actions == ("cut", "pour", "wash") and data.ingredients == ("olive_oil", "onion")
    v1 = data.videos[0]
    assert v1.video_id == "v1" and v1.actions.tolist() == [2, 0]
    assert data.atoms(v1) == ["wash_onion", "cut_onion"]
    assert data.atom(1, 0) == "pour_olive_oil" and data.feature_dim == 2
    np.testing.assert_array_equal(v1.features, np.array([[1, 0], [0, 1]], dtype=np.float32))
    assert {v.split for v in data.videos} <= {"train", "val", "test"}
    assert [v.split for v in read_activities(tmp_path / "real.parquet").videos] == [
        v.split for v in data.videos
    ]


def test_splits_without_a_column_are_by_video_and_seeded(tmp_path: Path) -> None:
    rows = [
        {"video_id": f"v{k}", "step": t, "action": "cut", "ingredient": "onion", "feature": [k, t]}
        for k in range(50)
        for t in range(2)
    ]
    path = _write(tmp_path / "many.parquet", rows)
    a = read_activities(path, (0.6, 0.2, 0.2), seed=1)
    assert [len(a.split(s)) for s in ("train", "val", "test")] == [30, 10, 10]
    assert [v.split for v in read_activities(path, (0.6, 0.2, 0.2), seed=1).videos] == [
        v.split for v in a.videos
    ]
    assert [v.split for v in read_activities(path, (0.6, 0.2, 0.2), seed=2).videos] != [
        v.split for v in a.videos
    ]


def _drop(rows, key):
    return [{k: v for k, v in r.items() if k != key} for r in rows]


def _set(index, **changes):
    def edit(rows):
        rows[index].update(changes)
        return rows

    return edit


@pytest.mark.parametrize(
    ("edit", "expected"),
    [
        (lambda rows: _drop(rows, "feature"), "missing column(s) feature"),
        (_set(1, step=2), "row 1: video 'v1' step 2 follows step 0"),
        (_set(1, feature=[1.0, 2.0, 3.0]), "row 1: feature has 3 values, expected 2"),
        (_set(0, action="cut_up"), "row 0: action 'cut_up' is not a valid name"),
        (_set(0, action="lastly"), "row 0: action 'lastly' starts with true/false/last"),
        (_set(2, ingredient="Olive Oil"), "row 2: ingredient 'Olive Oil' is not a valid name"),
        (_set(1, action=None), "row 1: action is empty"),
        (_set(2, feature=[float("nan"), 0.0]), "row 2: feature has a NaN"),
        (lambda rows: [], "no rows"),
    ],
)
def test_reader_errors_name_the_row(tmp_path: Path, edit, expected: str) -> None:
    rows = edit(_rows())
    if rows:
        path = _write(tmp_path / "bad.parquet", rows)
    else:
        path = tmp_path / "bad.parquet"
        pq.write_table(pa.Table.from_pylist([], schema=pa.Table.from_pylist(_rows()).schema), path)
    with pytest.raises(InputError, match=r"bad\.parquet: ") as e:
        read_activities(path)
    assert expected in str(e.value)


def test_video_rows_must_be_together(tmp_path: Path) -> None:
    rows = _rows()
    rows.append({**rows[0], "step": 2})  # v1 again after v2
    with pytest.raises(InputError, match="row 3: video 'v1' again after other videos"):
        read_activities(_write(tmp_path / "bad.parquet", rows))


def test_split_column_is_checked(tmp_path: Path) -> None:
    rows = [{**r, "split": "train"} for r in _rows()]
    rows[1]["split"] = "test"
    with pytest.raises(InputError, match="row 1: video 'v1' is in split 'test' here and 'train'"):
        read_activities(_write(tmp_path / "a.parquet", rows))
    rows[1]["split"] = "dev"
    with pytest.raises(InputError, match="row 1: split 'dev', expected one of train, val, test"):
        read_activities(_write(tmp_path / "b.parquet", rows))


def test_foreign_artifact_and_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "t.parquet"
    write_artifact(
        pa.Table.from_pylist(_rows()), path, kind="traces", schema=1, params={}, inputs=[]
    )
    with pytest.raises(InputError, match="a 'traces' artifact, expected 'activities'"):
        read_activities(path)
    with pytest.raises(InputError, match="no such file"):
        read_activities(tmp_path / "none.parquet")


def test_unlabelled_videos_come_last_and_leave_the_others_unchanged(tmp_path: Path) -> None:
    plain, extra = tmp_path / "plain.parquet", tmp_path / "extra.parquet"
    assert (
        tleaf("gen-activities", "-o", plain, "--kb-out", tmp_path / "a.ltl", *SMALL).exit_code == 0
    )
    result = tleaf(
        "gen-activities", "-o", extra, "--kb-out", tmp_path / "b.ltl", *SMALL, "--unlabelled", 7
    )
    assert result.exit_code == 0, result.output
    before, after = read_activities(plain), read_activities(extra)
    assert [v.split for v in after.videos[len(before.videos) :]] == ["unlabelled"] * 7
    assert len(after.split("unlabelled")) == 7
    for a, b in zip(before.videos, after.videos, strict=False):
        assert a.video_id == b.video_id and a.split == b.split
        assert np.array_equal(a.features, b.features) and np.array_equal(a.actions, b.actions)
    assert (tmp_path / "a.ltl").read_text() == (tmp_path / "b.ltl").read_text()
