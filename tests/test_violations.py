"""`tleaf eval violations`: the figures of two tiny runs agree with their metrics and with each
other, the train split is the run's own training videos, and unusable folders are refused."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
import torch
from typer.testing import CliRunner

from tests.conftest import tiny_activities
from tleaf_cli.cli import app
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.tasks.action_recognition.violations import violation_report

SHARES = ("affordance_violation_fraction", "ordering_violation_fraction", "violation_fraction")
PROBABILITIES = ("forbidden_probability_per_step", "p_own_rules", "p_whole_kb")


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Two tiny finished runs on one data set: no logic loss on the first 5 train videos, and
    the exact loss on all 8."""
    from tleaf_cli.tasks.action_recognition.train import TaskSettings, train_action_recognition

    folder = tmp_path_factory.mktemp("violations")
    data, kb = tiny_activities(folder)
    base = {"lam": 1.0, "hidden": 8, "head_hidden": 4, "epochs": 2}
    out = {"none": folder / "none", "exact": folder / "exact"}
    extra = {"none": {"train_videos": 5}, "exact": {}}
    for loss, path in out.items():
        settings = TaskSettings(**base, logic_loss=loss, **extra[loss])
        train_action_recognition(data, kb, None, path, settings)
    return out


@pytest.fixture(scope="module")
def sharp(runs: dict[str, Path]) -> Path:
    """A copy of the first run with every weight ×10: sharper outputs that vary from step to
    step, so that its argmax sequences break affordance and ordering rules (two epochs at
    lr 1e-4 leave h answering one allowed pair everywhere). Its metrics.json is the
    original's."""
    path = runs["none"].parent / "sharp"
    shutil.copytree(runs["none"], path)
    weights = torch.load(path / "weights.pt", weights_only=True)
    torch.save({k: 10 * v for k, v in weights.items()}, path / "weights.pt")
    return path


def _metrics(run: Path) -> dict:
    return json.loads((run / "metrics.json").read_text())


def _check_shares(row: dict) -> None:
    """What holds of every row: each kind's share at most the any-rule share, that at most
    their sum; shares and probabilities in [0, 1]."""
    affordance, ordering, any_rule = (row[k] for k in SHARES)
    assert max(affordance, ordering) <= any_rule <= affordance + ordering + 1e-12
    for key in (*SHARES, "forbidden_step_fraction", *PROBABILITIES):
        assert row[key] is None or 0.0 <= row[key] <= 1.0, key
    # every affordance rule of gen-activities forbids one pair: a video breaks one exactly
    # when one of its steps is on a forbidden pair
    assert (affordance > 0) == (row["forbidden_step_fraction"] > 0)
    assert row["mean_log_p_whole_kb"] <= 0.0


def test_the_figures_agree_with_the_runs_metrics_and_with_each_other(
    runs: dict[str, Path], tmp_path: Path
) -> None:
    report = violation_report(list(runs.values()), tmp_path / "report")
    rows = {(Path(r["run"]).name, r["split"]): r for r in report["rows"]}
    assert report["splits"] == ["train", "test"] and len(rows) == 4

    for name, run in runs.items():
        metrics = _metrics(run)
        test, train = rows[(name, "test")], rows[(name, "train")]
        # the "any rule" share is the violation metric the run wrote for its test videos
        assert test["violation_fraction"] == pytest.approx(metrics["test"]["violation_fraction"])
        assert test["videos"] == metrics["test"]["videos"]
        assert test["steps"] == metrics["test"]["steps"]
        # the train split is exactly the videos the run trained on
        assert train["videos"] == metrics["train_videos"] == train["train_videos"]
        _check_shares(test)
        _check_shares(train)
    assert rows[("none", "train")]["videos"] == 5 and rows[("exact", "train")]["videos"] == 8

    written = json.loads((tmp_path / "report" / "violations.json").read_text())
    assert written == json.loads(json.dumps(report))
    table = (tmp_path / "report" / "violations.md").read_text()
    assert sum(line.startswith(f"| {runs['none']} |") for line in table.splitlines()) == 2


def test_a_model_that_breaks_rules_is_scored_as_score_does(sharp: Path, tmp_path: Path) -> None:
    from tleaf_cli.tasks.action_recognition.train import score
    from tleaf_cli.tasks.action_recognition.violations import CPU, load_run, split_videos

    report = violation_report([sharp], tmp_path / "out", ("train", "val", "test"))
    run = load_run(sharp)
    for row in report["rows"]:
        _check_shares(row)
        videos = split_videos(run, row["split"])
        scored = score(run.model, run.inputs.data, videos, run.batch_size, CPU, run.inputs.rules)
        assert row["violation_fraction"] == pytest.approx(scored["violation_fraction"])
        assert row["videos_with_rules"] == scored["videos_with_rules"]
    rows = report["rows"]
    # not vacuous: both kinds of rule are broken, and the model's own rules are neither sure
    # to hold nor sure to break
    assert any(r["affordance_violation_fraction"] > 0 for r in rows)
    assert any(r["ordering_violation_fraction"] > 0 for r in rows)
    assert any(0 < r["p_own_rules"] < 1 for r in rows if r["p_own_rules"] is not None)


def test_the_command_reads_the_splits_asked_for(runs: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "out"
    args = ["eval", "violations", *map(str, runs.values()), "-o", str(out)]
    result = CliRunner().invoke(app, [*args, "--split", "val", "--split", "test", "-q"])
    assert result.exit_code == 0, result.output
    report = json.loads((out / "violations.json").read_text())
    assert [(Path(r["run"]).name, r["split"]) for r in report["rows"]] == [
        ("none", "val"), ("none", "test"), ("exact", "val"), ("exact", "test"),
    ]  # fmt: skip
    assert {r["videos"] for r in report["rows"] if r["split"] == "val"} == {4}
    assert "| val |" in (out / "violations.md").read_text()

    result = CliRunner().invoke(app, [*args, "--split", "unlabelled"])
    assert result.exit_code == 2 and "--split" in result.output


def test_a_folder_that_is_not_a_finished_run_is_refused(
    runs: dict[str, Path], tmp_path: Path
) -> None:
    empty = tmp_path / "not-a-run"
    empty.mkdir()
    out = tmp_path / "out"
    result = CliRunner().invoke(
        app, ["eval", "violations", str(runs["none"]), str(empty), "-o", str(out)]
    )
    assert result.exit_code == 2
    assert str(empty) in result.output and "not a finished train-task run" in result.output
    assert not out.exists()  # refused before anything was written

    with pytest.raises(SettingError):
        violation_report([runs["none"]], out, splits=())


def test_a_run_whose_inputs_changed_is_refused(runs: dict[str, Path], tmp_path: Path) -> None:
    moved = tmp_path / "run"
    shutil.copytree(runs["none"], moved)
    config = json.loads((moved / "config.json").read_text())
    kb = tmp_path / "kb.ltl"
    kb.write_text(Path(config["trained_on"]["kb"]["path"]).read_text() + "\n")  # other bytes
    config["trained_on"]["kb"]["path"] = str(kb)
    (moved / "config.json").write_text(json.dumps(config))
    with pytest.raises(InputError, match=re.escape(f"{moved}: its knowledge base ") + ".* changed"):
        violation_report([moved], tmp_path / "out")

    (moved / "weights.pt").write_bytes(b"not weights")
    config["trained_on"]["kb"]["path"] = str(runs["none"].parent / "kb.ltl")
    (moved / "config.json").write_text(json.dumps(config))
    with pytest.raises(InputError, match=re.escape(f"{moved}: weights.pt does not load")):
        violation_report([moved], tmp_path / "out")


def test_runs_that_differ_in_seed_only_are_averaged() -> None:
    from tleaf_cli.tasks.action_recognition.violations import FIGURES, mean_over_seeds

    def row(seed: int, split: str, value: float) -> dict:
        figures = dict.fromkeys(FIGURES, value)
        return {"model": "lstm", "method": "exact", "train_videos": 20, "split": split,
                "seed": seed, "videos": 4, **figures}  # fmt: skip

    rows = [row(0, "test", 0.2), row(1, "test", 0.4), row(0, "train", 0.0)]
    rows[1]["p_own_rules"] = None  # no video with rules: left out of the mean
    merged = {g["split"]: g for g in mean_over_seeds(rows)}
    assert merged["test"]["seeds"] == [0, 1] and merged["train"]["seeds"] == [0]
    assert merged["test"]["violation_fraction"] == pytest.approx(0.3)
    assert merged["test"]["p_own_rules"] == pytest.approx(0.2)
