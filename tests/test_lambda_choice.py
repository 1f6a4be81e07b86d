"""The λ of a train-task action-recognition run: its value and source printed and stored, and λ
chosen on validation with 0 ("no logic loss") always among the choices, where it can win."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import pytest
import torch

from tests.conftest import tiny_activities
from tleaf_cli.errors import SettingError
from tleaf_cli.settings.action_recognition import TaskSettings
from tleaf_cli.settings.training import lambda_candidates
from tleaf_cli.tasks.action_recognition.learning_curve import choose_lambda
from tleaf_cli.training.lambdas import (
    LambdaChoice,
    RunSetup,
    resolve_lambda,
    train_choosing_lambda,
)

TINY = ["--epochs", "2", "--hidden", "8", "--decode", "argmax"]


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> tuple[Path, Path]:
    return tiny_activities(tmp_path_factory.mktemp("act"))


def test_each_source_of_lambda() -> None:
    assert resolve_lambda(TaskSettings(logic_loss="exact", lam=0.3), 0.002) == LambdaChoice(
        0.3, "given"
    )
    assert resolve_lambda(TaskSettings(logic_loss="tleaf"), 0.002) == LambdaChoice(
        0.002, "recommended"
    )
    assert resolve_lambda(TaskSettings(logic_loss="exact"), None).source == "default"
    assert resolve_lambda(TaskSettings(), None).source == "unused"
    decoded = TaskSettings(unlabelled_loss="decoded")  # λ weighs self-training
    assert resolve_lambda(decoded, None).source == "default"
    assert "recommended for this q" in LambdaChoice(0.002, "recommended").text()


def test_the_cli_prints_the_lambda_and_its_source(chain_cli, tiny, tmp_path: Path) -> None:
    """Before the fix a run without --lambda never said which λ it used."""
    data, kb = tiny
    for extra, line in (([], "λ 1 (the loss's default)"), (["--lambda", "0.5"], "λ 0.5 (given")):
        out = tmp_path / f"r{len(extra)}"
        result = chain_cli("train-task", "action-recognition", data, "--kb", kb,
                           "--logic-loss", "exact", *TINY, *extra, "-o", out)  # fmt: skip
        assert result.exit_code == 0, result.output
        assert line in result.output
        lam = json.loads((out / "metrics.json").read_text())["lambda"]
        assert lam["source"] == ("given" if extra else "default")
    quiet = chain_cli("train-task", "action-recognition", data, "--kb", kb, "--logic-loss",
                      "exact", *TINY, "-o", tmp_path / "q", "-q")  # fmt: skip
    assert quiet.exit_code == 0 and "λ" not in quiet.output
    # without a logic loss λ weighs self-training on unlabelled videos: --lambda is not ignored
    own = ["--logic-loss", "none", "--unlabelled-loss", "decoded", "--lambda", "0.03"]
    result = chain_cli("train-task", "action-recognition", data, "--kb", kb, *own, *TINY,
                       "-o", tmp_path / "own")  # fmt: skip
    assert result.exit_code == 0 and "λ 0.03 (given" in result.output, result.output


def _fake_train(val: dict[float, float]):
    """A stand-in for train_action_recognition: writes a run whose best val accuracy is
    val[λ]."""

    def train(out_dir: Path, settings: TaskSettings, on_setup) -> dict:
        out_dir.mkdir(parents=True)
        if on_setup is not None:
            on_setup(RunSetup(resolve_lambda(settings, None)))
        metrics = {"best": {"val_action_accuracy": val[settings.lam]}, "lam": settings.lam}
        (out_dir / "metrics.json").write_text(json.dumps(metrics))
        config = {"settings": {"lam": settings.lam}, "embedder": None}
        (out_dir / "config.json").write_text(json.dumps(config))
        (out_dir / "weights.pt").write_bytes(str(settings.lam).encode())
        return metrics

    return train


@pytest.mark.parametrize(
    ("val", "chosen"),
    [
        ({0.0: 0.60, 1.0: 0.55, 3.0: 0.50}, 0.0),  # the loss hurts: no logic loss wins
        ({0.0: 0.55, 1.0: 0.55, 3.0: 0.50}, 0.0),  # a tie goes to the smaller λ, 0
        ({0.0: 0.50, 1.0: 0.52, 3.0: 0.60}, 3.0),
    ],
)
def test_lambda_on_validation_has_no_logic_loss_among_the_choices(
    tmp_path: Path, val: dict, chosen: float
) -> None:
    settings = TaskSettings(logic_loss="exact", lambdas="1, 3")
    heard = []
    metrics = train_choosing_lambda(
        _fake_train(val), tmp_path, settings, heard.append, "val_action_accuracy"
    )
    assert metrics["lambda"]["value"] == chosen and metrics["lambda"]["source"] == "validation"
    assert [c["lambda"] for c in metrics["lambda"]["candidates"]] == [0.0, 1.0, 3.0]
    assert (tmp_path / "weights.pt").read_bytes() == str(chosen).encode()
    assert json.loads((tmp_path / "config.json").read_text())["settings"]["lambdas"] == "1, 3"
    assert [s.lam.source for s in heard] == ["candidate"] * 3


def test_lambda_lists_are_checked() -> None:
    assert lambda_candidates("1,0.3 3") == (0.0, 0.3, 1.0, 3.0)
    assert lambda_candidates("0") == (0.0,)
    for bad in ("x", "-1", "nan", "inf"):
        with pytest.raises(SettingError, match="lambdas"):
            lambda_candidates(bad)
    with pytest.raises(SettingError, match="not with lam"):
        TaskSettings(logic_loss="exact", lam=1.0, lambdas="1").check()
    with pytest.raises(SettingError, match="weighs nothing"):
        TaskSettings(lambdas="1").check()


def test_a_run_chooses_lambda_on_validation(chain_cli, tiny, tmp_path: Path) -> None:
    """--lambdas 2: runs at λ 0 and 2 from the same seed; the chosen one's weights are the run's."""
    data, kb = tiny
    out = tmp_path / "r"
    result = chain_cli("train-task", "action-recognition", data, "--kb", kb, "--logic-loss",
                       "exact", *TINY, "--lambdas", "2", "-o", out)  # fmt: skip
    assert result.exit_code == 0, result.output
    lam = json.loads((out / "metrics.json").read_text())["lambda"]
    assert [c["lambda"] for c in lam["candidates"]] == [0.0, 2.0]
    best = max(lam["candidates"], key=lambda c: (c["val_action_accuracy"], -c["lambda"]))
    assert lam["value"] == best["lambda"] and "chosen on validation among 0 (" in result.output
    chosen = torch.load(out / best["run"] / "weights.pt", weights_only=True)
    kept = torch.load(out / "weights.pt", weights_only=True)
    assert all(torch.equal(kept[k], chosen[k]) for k in kept)
    config = json.loads((out / "config.json").read_text())
    assert config["settings"]["lam"] == lam["value"] and config["settings"]["lambdas"] == "2"
    both = ["--logic-loss", "exact", "--lambda", "1", "--lambdas", "2", "-o", tmp_path / "x"]
    refused = chain_cli("train-task", "action-recognition", data, "--kb", kb, *both)
    assert refused.exit_code == 2 and "--lambdas" in refused.output


def _row(method: str, lam: float, seed: int, val: float) -> dict:
    return {"run": f"{method}-{lam}-{seed}", "model": "lstm", "method": method, "lambda": lam,
            "seed": seed, "train_videos": 20, "val_action_accuracy": val}  # fmt: skip


def test_the_learning_curves_choice_counts_the_reference_as_lambda_0() -> None:
    """The learning curve chose among λ > 0 only (λ 3 where the loss cost 8 % on another
    configuration); the reference runs of the same seeds now count as λ 0."""
    runs = [_row("exact", 1, 0, 0.50), _row("exact", 1, 1, 0.52)]
    runs += [_row("exact", 3, 0, 0.53), _row("exact", 3, 1, 0.51)]
    refs = [_row("none", 1, 0, 0.56), _row("none", 1, 1, 0.55)]  # a none run records λ 1
    choice = choose_lambda(runs + refs)
    assert choice["lambda"] == 0 and [v["lambda"] for v in choice["val"]] == [0, 1, 3]
    assert choice["method"] == "exact"
    assert choose_lambda(runs)["lambda"] == 3


def test_a_run_without_a_logic_loss_is_the_lambda_0_candidate(tmp_path: Path) -> None:
    """--reference: the run of no logic loss is taken as λ 0; where it wins, the run still
    names its own loss at λ 0 (its copied config said `none`, λ 1: the learning curve counted it
    as a second reference run)."""
    reference = tmp_path / "none"
    reference.mkdir()
    (reference / "config.json").write_text(
        json.dumps({"settings": asdict(TaskSettings(logic_loss="none", lam=1.0))})
    )
    metrics = {"logic_loss": "none", "best": {"val_action_accuracy": 0.6}}
    (reference / "metrics.json").write_text(json.dumps(metrics))
    (reference / "weights.pt").write_bytes(b"none")
    settings = TaskSettings(logic_loss="exact", lambdas="1")
    out = tmp_path / "exact"
    metrics = train_choosing_lambda(
        _fake_train({1.0: 0.55}), out, settings, None, "val_action_accuracy", reference
    )
    assert metrics["lambda"]["value"] == 0.0 and metrics["logic_loss"] == "exact"
    assert [c["lambda"] for c in metrics["lambda"]["candidates"]] == [0.0, 1.0]
    assert (out / "weights.pt").read_bytes() == b"none"
    config = json.loads((out / "config.json").read_text())["settings"]
    assert (config["logic_loss"], config["lam"]) == ("exact", 0.0)


def test_the_cli_takes_the_reference_run_as_lambda_0(chain_cli, tiny, tmp_path: Path) -> None:
    data, kb = tiny
    none = tmp_path / "none"
    result = chain_cli("train-task", "action-recognition", data, "--kb", kb, *TINY, "-o", none)
    assert result.exit_code == 0, result.output
    out = tmp_path / "exact"
    exact = ["--logic-loss", "exact", *TINY, "--lambdas", "2", "--reference", none]
    result = chain_cli("train-task", "action-recognition", data, "--kb", kb, *exact, "-o", out)
    assert result.exit_code == 0, result.output
    lam = json.loads((out / "metrics.json").read_text())["lambda"]
    assert [c["lambda"] for c in lam["candidates"]] == [0.0, 2.0]
    taken = out / "lambda-choice" / "lambda-0" / "weights.pt"
    assert taken.read_bytes() == (none / "weights.pt").read_bytes()  # not trained again
    alone = chain_cli("train-task", "action-recognition", data, "--kb", kb, "--logic-loss",
                      "exact", *TINY, "--reference", none, "-o", tmp_path / "x")  # fmt: skip
    assert alone.exit_code != 0 and "lambdas" in alone.output
