"""Model selection on validation (`--grid`): the grid's combinations in order, its refusals, one
run per candidate from the same seed, the best val score kept with its settings in config.json,
so that eval rebuilds the chosen model."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from tests.test_next_activity import cases_artifact
from tleaf_cli.cli.root import app
from tleaf_cli.errors import SettingError
from tleaf_cli.settings.next_activity import NextActivitySettings, SuffixSettings
from tleaf_cli.settings.training import grid_candidates
from tleaf_cli.tasks.next_activity.evaluate import evaluate_next_activity, load_run
from tleaf_cli.tasks.next_activity.train import train_next_activity

runner = CliRunner()


def test_the_grid_is_every_combination_in_order():
    settings = NextActivitySettings(grid="hidden=8,16 dropout=0,0.1 model=lstm")
    combos = [(s.hidden, s.dropout, s.model, s.grid) for s in grid_candidates(settings)]
    assert combos == [
        (8, 0.0, "lstm", None),
        (8, 0.1, "lstm", None),
        (16, 0.0, "lstm", None),
        (16, 0.1, "lstm", None),
    ]


@pytest.mark.parametrize(
    ("grid", "says"),
    [
        ("hidden", "is not field=value"),
        ("width=8,16", "'width' is not a setting"),
        ("seed=0,1", "how the choice is made"),
        ("hidden=8 hidden=16", "named twice"),
        ("hidden=8,big", "are not int values"),
        ("dropout=0,1.5", "dropout"),  # each candidate is checked: dropout must be < 1
        ("attributes=org:resource", "takes no list"),  # a field that is None here
        ("hidden=4,4", "4 is named twice"),  # the same candidate twice
        ("lr=0.001,1e-3", "0.001 is named twice"),
        ("heads=2,4", "an LSTM reads no heads"),  # every candidate the same model
    ],
)
def test_a_grid_that_does_not_read_is_refused(grid, says):
    with pytest.raises(SettingError, match=says):
        NextActivitySettings(grid=grid).check()


def test_not_with_a_lambda_choice():
    with pytest.raises(SettingError, match="choose the model first"):
        NextActivitySettings(grid="hidden=8,16", logic_loss="exact", lambdas="0.1").check()


def test_the_best_candidate_on_val_is_the_run(tmp_path):
    data = cases_artifact(tmp_path)
    run = tmp_path / "run"
    settings = NextActivitySettings(grid="hidden=4,32 lr=0.01", epochs=3, layers=1)
    metrics = train_next_activity(data, None, None, run, settings)
    choice = metrics["grid"]
    assert [c["settings"] for c in choice["candidates"]] == [
        {"hidden": 4, "lr": 0.01},
        {"hidden": 32, "lr": 0.01},
    ]
    scores = [c["val_accuracy"] for c in choice["candidates"]]
    best = choice["candidates"][scores.index(max(scores))]
    assert choice["chosen"] == best["settings"]
    assert metrics["best"]["val_accuracy"] == max(scores)
    for c in choice["candidates"]:
        assert (run / c["run"] / "weights.pt").is_file()
    config = json.loads((run / "config.json").read_text())
    assert config["settings"]["hidden"] == best["settings"]["hidden"]
    assert config["settings"]["grid"] == "hidden=4,32 lr=0.01"
    model, _, loaded = load_run(run)  # the chosen model's shape, from config.json
    assert model.lstm.hidden_size == best["settings"]["hidden"] and loaded.lr == 0.01
    saved = evaluate_next_activity(run, data, tmp_path / "eval", SuffixSettings())
    assert saved["accuracy"]["accuracy"] == pytest.approx(metrics["test"]["accuracy"])


def test_the_command_line_takes_a_grid(tmp_path):
    data = cases_artifact(tmp_path)
    result = runner.invoke(
        app,
        [
            "train-task", "next-activity", str(data), "-o", str(tmp_path / "run"),
            "--grid", "hidden=4,8", "--epochs", "1", "--layers", "1", "-q",
        ],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in (tmp_path / "run" / "grid").iterdir()) == ["hidden-4", "hidden-8"]
    bad = runner.invoke(
        app, ["train-task", "next-activity", str(data), "-o", str(tmp_path / "x"), "--grid", "oops"]
    )
    assert bad.exit_code == 2 and "--grid" in bad.output


def test_the_command_line_says_the_candidates_and_the_choice(tmp_path):
    """Before: --grid printed neither the candidates nor the one chosen."""
    data = cases_artifact(tmp_path, cases=40)
    args = ["train-task", "next-activity", str(data), "-o", str(tmp_path / "run"), "--grid",
            "hidden=4,8", "--epochs", "1", "--layers", "1"]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    said = result.stderr
    assert f"grid: 2 candidates into {tmp_path / 'run' / 'grid'}: hidden-4, hidden-8" in said
    assert said.index("hidden-4, hidden-8") < said.index("epoch 1")  # before training
    chosen = json.loads((tmp_path / "run" / "metrics.json").read_text())["grid"]["chosen"]
    assert f"grid: chose hidden={chosen['hidden']} on validation (val accuracy " in said
    quiet = runner.invoke(app, [*args, "-q"])
    assert quiet.exit_code == 0 and "grid" not in quiet.stderr, quiet.output


def test_resuming_with_another_grid_is_refused(tmp_path):
    """Before: the old grid's candidate folder was left beside the new ones, unlisted."""
    data = cases_artifact(tmp_path, cases=40)
    out = tmp_path / "run"
    args = ["train-task", "next-activity", str(data), "-o", str(out), "--epochs", "1",
            "--layers", "1", "-q"]  # fmt: skip
    assert runner.invoke(app, [*args, "--grid", "hidden=4,8"]).exit_code == 0
    result = runner.invoke(app, [*args, "--grid", "hidden=4", "--resume"])
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and str(out / "grid") in lines[0] and "hidden-8" in lines[0], lines
    more = runner.invoke(app, [*args, "--grid", "hidden=4,8,16", "--resume"])  # adds one
    assert more.exit_code == 0, more.output
    assert sorted(p.name for p in (out / "grid").iterdir()) == ["hidden-16", "hidden-4", "hidden-8"]
