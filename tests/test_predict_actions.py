"""`tleaf predict` on an action-recognition run: new videos decoded by argmax and under the rules
(tasks/action_recognition/predict.py), on tiny synthetic activities and a 2-epoch run."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import torch
from typer.testing import CliRunner

from tests.conftest import tiny_activities
from tleaf_cli.cli import app
from tleaf_cli.data.artifacts import read_provenance
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.base import read_knowledge_base, rules_for
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.semantics import satisfies
from tleaf_cli.tasks.action_recognition.activities import Video, read_activities
from tleaf_cli.tasks.action_recognition.batch import Batch
from tleaf_cli.tasks.action_recognition.predict import ActionPredictor
from tleaf_cli.tasks.action_recognition.train import predict as run_predict

runner = CliRunner()


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> dict[str, Path]:
    from tleaf_cli.tasks.action_recognition.train import TaskSettings, train_action_recognition

    folder = tmp_path_factory.mktemp("predict-actions")
    data, kb = tiny_activities(folder)
    run = folder / "run"
    settings = TaskSettings(logic_loss="none", hidden=8, head_hidden=4, epochs=2)
    train_action_recognition(data, kb, None, run, settings)
    return {"data": data, "kb": kb, "run": run}


def _predict(*args) -> tuple[int, str]:
    result = runner.invoke(app, ["predict", *map(str, args)])
    return result.exit_code, result.output


def _broken(kb, atoms: list[str]) -> list[str]:
    """The rules that apply to a labelled sequence and that it breaks, by the LTLf evaluator."""
    trace = [{a} for a in atoms]
    return sorted(r.name for r in rules_for(kb, atoms) if not satisfies(trace, parse(r.formula)))


def test_the_test_split_reads_as_the_runs_own_test_figures(made, tmp_path) -> None:
    """On the run's own test videos, the argmax labels are the model's argmax per head and the
    accuracies of both decodings are train-task's test figures (metrics.json), which `eval
    action-recognition` reports."""
    out = tmp_path / "p.parquet"
    code, output = _predict(made["run"], made["data"], "--split", "test", "-o", out)
    assert code == 0, output
    assert "first 4 videos" in output and "4 videos" in output
    prov = read_provenance(out)
    assert (prov.kind, prov.schema) == ("action_predictions", 1)
    assert prov.params["rules"] == str(made["kb"].resolve())
    rows = pq.read_table(out).to_pylist()
    test = json.loads((made["run"] / "metrics.json").read_text())["test"]
    assert len(rows) == test["steps"]

    def accuracy(prefix: str, what: str = "action") -> float:
        return float(np.mean([r[f"{prefix}{what}"] == r[f"true_{what}"] for r in rows]))

    assert accuracy("") == pytest.approx(test["action_accuracy"])
    assert accuracy("", "ingredient") == pytest.approx(test["ingredient_accuracy"])
    assert accuracy("constrained_") == pytest.approx(test["constrained"]["action_accuracy"])

    predictor = ActionPredictor.load(made["run"])
    videos = read_activities(made["data"]).split("test")
    batch = Batch.of(videos, torch.device("cpu"))
    with torch.no_grad():
        a, i = predictor.model(batch.features, batch.lengths)
    pa_, pi_ = torch.softmax(a, -1), torch.softmax(i, -1)
    k = 0
    for b, video in enumerate(videos):
        for t in range(len(video)):
            row = rows[k]
            assert (row["video_id"], row["step"]) == (video.video_id, t)
            assert row["action"] == predictor.actions[int(a[b, t].argmax())]
            assert row["ingredient"] == predictor.ingredients[int(i[b, t].argmax())]
            assert row["action_probability"] == pytest.approx(float(pa_[b, t].max()), rel=1e-5)
            assert row["ingredient_probability"] == pytest.approx(float(pi_[b, t].max()), rel=1e-5)
            top = row["top_pairs"]
            assert len(top) == 3 and (top[0]["action"], top[0]["ingredient"]) == (
                row["action"], row["ingredient"]
            )  # fmt: skip
            k += 1

    shown = runner.invoke(app, ["inspect", str(out)])
    assert shown.exit_code == 0 and "action_predictions artifact" in shown.output


def test_constrained_labels_keep_every_rule_and_are_the_runs_constrained_decoding(made) -> None:
    """With weights drawn at random (outputs that vary from step to step and break rules), the
    labels under the rules are `train.predict`'s constrained decoding (train-task's test and
    eval's figures) and keep every rule that applies to them, checked by the LTLf evaluator;
    the argmax labels break exactly the rules named, and some video breaks one."""
    predictor = ActionPredictor.load(made["run"])
    torch.manual_seed(0)
    with torch.no_grad():
        for p in predictor.model.parameters():
            p.normal_(0.0, 1.0)
    kb = read_knowledge_base(made["kb"])
    videos = read_activities(made["data"]).videos
    predictions = predictor.predict(videos, top_pairs=2)
    expected, _ = run_predict(
        predictor.model, videos, predictor.batch_size, torch.device("cpu"), predictor.rules,
        top_k=predictor.top_k,
    )  # fmt: skip
    argmax, _ = run_predict(predictor.model, videos, predictor.batch_size, torch.device("cpu"))
    breaking = 0
    for p, (ca, ci), (aa, ai) in zip(predictions, expected, argmax, strict=True):
        assert p.constrained_actions == [predictor.actions[x] for x in ca]
        assert p.constrained_ingredients == [predictor.ingredients[x] for x in ci]
        assert p.actions == [predictor.actions[x] for x in aa]
        assert p.ingredients == [predictor.ingredients[x] for x in ai]
        atoms = [f"{a}_{i}" for a, i in zip(p.actions, p.ingredients, strict=True)]
        assert sorted(p.argmax_broken) == _broken(kb, atoms)
        assert p.argmax_rules == len(rules_for(kb, atoms))
        kept = [f"{a}_{i}" for a, i in
                zip(p.constrained_actions, p.constrained_ingredients, strict=True)]  # fmt: skip
        assert p.constrained_broken == [] and _broken(kb, kept) == []
        assert p.constrained_rules == len(rules_for(kb, kept))
        # no sequence is more probable than the argmax; the rules decoded under are those of
        # the model's top candidate pairs, so the labels may change where the argmax breaks none
        assert p.constrained_log_prob <= p.argmax_log_prob + 1e-9
        breaking += bool(p.argmax_broken)
    assert breaking > 0  # the rules are exercised


def _features_only(source: Path, out: Path, keep: tuple[str, ...] = ()) -> Path:
    """Plain Parquet of `source`'s test videos with video_id, step, feature and `keep`."""
    table = pq.read_table(source)
    table = table.filter(pa.compute.equal(table["split"], "test"))
    pq.write_table(table.select(["video_id", "step", "feature", *keep]), out)
    return out


def test_rows_without_labels_are_read_and_predicted_alike(made, tmp_path) -> None:
    labelled = tmp_path / "labelled.parquet"
    code, output = _predict(made["run"], made["data"], "--split", "test", "-o", labelled)
    assert code == 0, output
    bare = _features_only(made["data"], tmp_path / "bare.parquet")
    with pytest.raises(InputError, match="missing column"):
        read_activities(bare)  # training still needs labels
    data = read_activities(bare, labels=False)
    assert data.actions == () and all((v.actions == -1).all() for v in data.videos)
    out = tmp_path / "bare-p.parquet"
    code, output = _predict(made["run"], bare, "-o", out)  # no split column: every video
    assert code == 0, output
    assert "against the file's labels" not in output
    rows, want = pq.read_table(out), pq.read_table(labelled)
    assert rows.column("true_action").null_count == rows.num_rows
    for column in ("video_id", "step", "action", "constrained_action", "argmax_broken"):
        assert rows.column(column).to_pylist() == want.column(column).to_pylist()

    # labels on some rows only: empty cells read as no label
    table = pq.read_table(made["data"])
    actions = table["action"].to_pylist()
    actions[1] = None
    partial = tmp_path / "partial.parquet"
    pq.write_table(table.set_column(table.schema.get_field_index("action"), "action",
                                    pa.array(actions, pa.string())), partial)  # fmt: skip
    assert read_activities(partial, labels=False).videos[0].actions[1] == -1
    code, output = _predict(made["run"], partial, "-o", tmp_path / "partial-p.parquet")
    assert code == 0, output


def test_bad_inputs_exit_2_with_one_line_and_write_nothing(made, tmp_path) -> None:
    out = tmp_path / "p.parquet"
    other = tmp_path / "meta"
    other.mkdir()
    (other / "config.json").write_text('{"kind": "meta-embedder"}', encoding="utf-8")
    table = pq.read_table(made["data"])
    narrow = tmp_path / "narrow.parquet"
    cut = pa.array([f[:3] for f in table["feature"].to_pylist()], pa.list_(pa.float32()))
    pq.write_table(table.set_column(table.schema.get_field_index("feature"), "feature", cut),
                   narrow)  # fmt: skip
    empty = tmp_path / "empty.parquet"
    features = table["feature"].to_pylist()
    features[-1] = []  # the last video's last step has no feature
    pq.write_table(
        table.set_column(table.schema.get_field_index("feature"), "feature",
                         pa.array(features, pa.list_(pa.float32()))), empty
    )  # fmt: skip
    decl = tmp_path / "rules.decl"
    decl.write_text("activity a\nInit[a] | |\n", encoding="utf-8")
    run, data = made["run"], made["data"]
    cases = [
        ((other, data), "action-recognition runs"),
        ((run, narrow), "features have 3 values per step, the run reads 8"),
        ((run, empty), "feature has 0 values"),
        ((run, data, "--split", "nope"), "no videos in the split 'nope'"),
        ((run, data, "--samples", "10"), "--samples: only for a next-activity run"),
        ((run, data, "--rules", decl), "a .ltl knowledge base"),
        ((run, data, "--rule", "no.such"), "no rule named 'no.such'"),
        ((run, tmp_path / "missing.parquet"), "missing.parquet"),
    ]
    for args, says in cases:
        code, output = _predict(*args, "-o", out)
        assert code == 2, (args, output)
        assert says in output and len(output.strip().splitlines()) == 1, (args, output)
        assert not out.exists()

    predictor = ActionPredictor.load(run)
    video = read_activities(data).videos[0]
    hollow = Video("v0", "test", video.actions[:0], video.ingredients[:0], video.features[:0])
    with pytest.raises(InputError, match="video 'v0' has no steps"):
        predictor.predict([hollow])


def test_one_named_rule(made, tmp_path) -> None:
    kb = read_knowledge_base(made["kb"])
    name = kb.of_kind("ordering")[0].name
    out = tmp_path / "p.parquet"
    code, output = _predict(made["run"], made["data"], "--rule", name, "--top-k", "1", "-o", out)
    assert code == 0, output
    params = read_provenance(out).params
    assert params["rule_names"] == [name] and params["rules_in_force"] == 1
    rows = pq.read_table(out).to_pylist()
    assert all(len(r["top_pairs"]) == 1 for r in rows)
    assert all(set(r["argmax_broken"]) <= {name} for r in rows)
