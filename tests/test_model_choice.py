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
