"""The training core every task shares (tleaf_cli/training/) as a careful user meets it: a resumed
run is the same run, settings that cannot train are refused before anything is written, options
that would do nothing are refused, knowledge that can never apply is refused, an interrupted or
diverged run names what it kept, a very long case does not stall an epoch, and evaluation reads
the run's own rules and refuses or flags cases the run was not trained on. Each test failed on
the code before the training core."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch
from typer.testing import CliRunner

from tests.test_next_activity import cases_artifact, rules_file, write_log
from tleaf_cli.cli import app
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.settings.next_activity import NextActivitySettings
from tleaf_cli.tasks.next_activity.train import NextActivityTrainer, train_next_activity
from tleaf_cli.training.loop import (
    LoopSettings,
    Step,
    TrainingDiverged,
    TrainingInterrupted,
    fit,
)
from tleaf_cli.training.task import RunInputs

runner = CliRunner()
SMALL = dict(epochs=2, hidden=8, layers=1)
SMALL_FLAGS = ["--epochs", "2", "--hidden", "8", "--layers", "1", "-q"]


def tleaf(*args) -> object:
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def log(tmp_path_factory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("log")
    return cases_artifact(folder), rules_file(folder)


def test_resume_refuses_a_checkpoint_of_other_settings_or_cases(log, tmp_path) -> None:
    """Before: resuming fold 0's checkpoint on fold 1 with another loss and lr exited 0."""
    data, kb = log
    run = tmp_path / "run"
    first = NextActivitySettings(logic_loss="exact", lam=0.1, **SMALL)
    train_next_activity(data, kb, None, run, first)
    other_lr = NextActivitySettings(logic_loss="exact", lam=0.1, lr=0.05, **SMALL)
    with pytest.raises(InputError, match=r"lr 0\.002 → 0\.05"):
        train_next_activity(data, kb, None, run, other_lr, resume=True)
    (tmp_path / "other").mkdir()
    other_cases = cases_artifact(tmp_path / "other", cases=60)
    with pytest.raises(InputError, match="the data"):
        train_next_activity(other_cases, kb, None, run, first, resume=True)
    none = NextActivitySettings(**SMALL)
    with pytest.raises(InputError, match="logic_loss exact → none"):
        train_next_activity(data, None, None, run, none, resume=True)
    # the same run, trained for longer: resumed from its 2 epochs
    longer = NextActivitySettings(logic_loss="exact", lam=0.1, **{**SMALL, "epochs": 3})
    metrics = train_next_activity(data, kb, None, run, longer, resume=True)
    assert [h["epoch"] for h in metrics["history"]] == [1, 2, 3]


@pytest.mark.parametrize(
    ("flags", "named"),
    [
        (["--lr", "inf"], "--lr"),
        (["--lr", "nan"], "--lr"),
        (["--lr", "-1"], "--lr"),
        (["--lr", "0"], "--lr"),
        (["--logic-loss", "exact", "--lambda", "inf"], "--lambda"),
        (["--logic-loss", "exact", "--lambda", "nan"], "--lambda"),
        (["--logic-loss", "exact", "--lambdas", "1,inf"], "--lambdas"),
        (["--dropout", "nan"], "--dropout"),
    ],
)
def test_settings_that_cannot_train_are_one_error_line_and_no_folder(
    log, tmp_path, flags, named
) -> None:
    """Before: --lr inf trained a NaN model with exit 0; --lr nan, -1 gave a traceback and an
    empty run folder; a NaN in a bounded option gave click's usage box."""
    data, kb = log
    out = tmp_path / "run"
    kb_flags = ["--kb", kb] if "--logic-loss" in flags else []
    result = tleaf("train-task", "next-activity", data, *kb_flags, *flags, *SMALL_FLAGS, "-o", out)
    assert result.exit_code == 2, result.output
    assert result.output.startswith("error:") and named in result.output
    assert "Traceback" not in result.output and "Usage" not in result.output
    assert not out.exists()


def test_nan_in_any_bounded_option_is_one_error_line(log, tmp_path) -> None:
    data, _ = log
    result = tleaf("mine-declare", data, "--min-support", "nan", "-o", tmp_path / "kb.ltl")
    assert result.exit_code == 2 and result.output.startswith("error: --min-support")
    assert "Usage" not in result.output


@pytest.mark.parametrize(
    ("flags", "named"),
    [
        (["--kb", "KB"], "--kb"),  # no logic loss: the rules weigh nothing
        (["--logic-loss", "exact", "--kb", "KB", "--embedder", "."], "--embedder"),
    ],
)
def test_options_that_would_do_nothing_are_refused(log, tmp_path, flags, named) -> None:
    data, kb = log
    flags = [kb if f == "KB" else f for f in flags]
    result = tleaf("train-task", "next-activity", data, *flags, *SMALL_FLAGS, "-o", tmp_path / "r")
    assert result.exit_code == 2 and named in result.output, result.output
    assert not (tmp_path / "r").exists()


def test_a_reference_of_another_run_is_refused_before_anything_trains(log, tmp_path) -> None:
    """Before: a λ candidate trained (and was left on disk) before --reference was checked."""
    data, kb = log
    reference = tmp_path / "none"
    train_next_activity(data, None, None, reference, NextActivitySettings(**SMALL))
    other = NextActivitySettings(logic_loss="exact", lambdas="1", **{**SMALL, "hidden": 16})
    out = tmp_path / "exact"
    with pytest.raises(SettingError, match="hidden"):
        train_next_activity(data, kb, None, out, other, reference=reference)
    assert not out.exists()


def test_rules_that_accept_no_case_are_refused_before_training(log, tmp_path) -> None:
    """Before: an unsatisfiable knowledge base trained with logic loss 0.0000 and decoded with
    every search failing, silently."""
    data, _ = log
    kb = tmp_path / "never.ltl"
    kb.write_text("always_a: G(a)\nnever_a: !F(a)\n")
    out = tmp_path / "run"
    result = tleaf("train-task", "next-activity", data, "--kb", kb, "--logic-loss", "exact",
                   *SMALL_FLAGS, "-o", out)  # fmt: skip
    assert result.exit_code == 2 and "unsatisfiable" in result.output, result.output
    assert not out.exists()


def test_an_interrupted_run_names_the_checkpoint_it_kept(log, tmp_path) -> None:
    """Before: Ctrl-C said "nothing was written" and left checkpoint.pt."""
    data, _ = log
    out = tmp_path / "run"

    def stop(record) -> None:
        if record.epoch == 2:
            raise KeyboardInterrupt

    settings = NextActivitySettings(**{**SMALL, "epochs": 5})
    with pytest.raises(TrainingInterrupted, match=r"checkpoint\.pt") as caught:
        train_next_activity(data, None, None, out, settings, on_epoch=stop)
    assert (out / "checkpoint.pt").is_file() and caught.value.exit_code == 130
    result = tleaf("train-task", "next-activity", data, "--epochs", "5", "--hidden", "8",
                   "--layers", "1", "--resume", "-o", out)  # fmt: skip
    assert result.exit_code == 0, result.output


def test_a_loss_that_is_not_finite_stops_the_run() -> None:
    model = torch.nn.Linear(2, 1)

    def step(batch) -> Step:
        return Step(model(batch).sum() * float("nan"), {})

    settings = LoopSettings(epochs=3, patience=None, lr=0.1, seed=0)
    with pytest.raises(TrainingDiverged, match="epoch 1"):
        fit(model, lambda e, g: [torch.ones(1, 2)], step, lambda: 0.0, settings,
            Path("/tmp/tleaf-diverged-test"), score="val")  # fmt: skip


def test_a_very_long_case_is_cut_for_training(tmp_path) -> None:
    """Before: one case of 100,000 events made an epoch take minutes and gigabytes."""
    path = write_log(tmp_path / "log.csv", cases=40)
    lines = path.read_text().splitlines()
    lines += [
        f"long,{'a' if t == 0 else 'd'},2025-01-01T{t // 3600:02d}:{t // 60 % 60:02d}:"
        f"{t % 60:02d}+00:00"
        for t in range(5000)
    ]
    path.write_text("\n".join(lines) + "\n")
    data = tmp_path / "cases.parquet"
    assert tleaf("read-log", path, "--split", "0.9,0.05,0.05", "-o", data, "-q").exit_code == 0
    settings = NextActivitySettings(max_events=100, batch_size=64, **SMALL)
    trainer = NextActivityTrainer(RunInputs(data), settings, torch.device("cpu"))
    assert any(len(c) == 5000 for c in trainer.splits["train"] + trainer.splits["val"])
    lengths = [int(b.lengths.max()) for b in trainer.batches(1, torch.Generator().manual_seed(0))]
    assert max(lengths) <= 100


def test_eval_reads_the_runs_rules_and_refuses_another_preprocessing(log, tmp_path) -> None:
    """Before: eval took the rules again as --rules; evaluating on another preprocessing of the
    log (other activity ids) exited 0 with a meaningless accuracy, and on another file said
    nothing."""
    data, kb = log
    run = tmp_path / "run"
    train_next_activity(data, kb, None, run, NextActivitySettings(logic_loss="exact", **SMALL))
    result = tleaf("eval", "next-activity", run, data, "-o", tmp_path / "e1")
    assert result.exit_code == 0, result.output
    metrics = json.loads((tmp_path / "e1" / "metrics.json").read_text())
    assert metrics["rules"]["source"] == "run" and "accuracy_rules" in metrics["accuracy"]
    assert "under the run's rules" in result.output and not metrics["warnings"]
    # the same log, its activities renamed: the run's atoms now name other activities
    log_path = tmp_path / "renamed.csv"
    text = write_log(tmp_path / "plain.csv").read_text()
    log_path.write_text(text.replace(",b,", ",x,").replace(",a,", ",b,").replace(",x,", ",a,"))
    renamed = tmp_path / "renamed.parquet"
    assert tleaf("read-log", log_path, "-o", renamed, "-q").exit_code == 0
    result = tleaf("eval", "next-activity", run, renamed, "-o", tmp_path / "e2")
    assert result.exit_code == 2 and "another preprocessing" in result.output, result.output
    # another split of the same log: scored, with a warning
    other = tmp_path / "other.parquet"
    assert tleaf("split-cases", data, "--fold", "0", "--seed", "7", "-o", other).exit_code == 0
    result = tleaf("eval", "next-activity", run, other, "-o", tmp_path / "e3")
    assert result.exit_code == 0 and "were training or validation cases" in result.output
    beam = tleaf("eval", "next-activity", run, data, "--beam-width", "3", "-o", tmp_path / "e4")
    assert beam.exit_code == 2 and "--prefix-lengths" in beam.output


def test_a_new_run_over_a_finished_one_says_so(log, tmp_path) -> None:
    data, _ = log
    out = tmp_path / "run"
    assert tleaf("train-task", "next-activity", data, *SMALL_FLAGS[:-1], "-o", out).exit_code == 0
    again = tleaf("train-task", "next-activity", data, *SMALL_FLAGS[:-1], "-o", out)
    assert again.exit_code == 0 and "replaces it" in again.output


def test_eval_counts_the_predictions_the_rules_changed(log, tmp_path) -> None:
    """Equal accuracies under the rules and without did not show whether any prediction
    changed; eval now counts them."""
    data, kb = log
    run = tmp_path / "run"
    settings = NextActivitySettings(epochs=8, hidden=16, layers=1, lr=1e-2)
    train_next_activity(data, None, None, run, settings)
    # half the cases end without d: the model predicts their end, which these rules forbid
    rules = tmp_path / "some_d.ltl"
    rules.write_text("eventually_d: F(d)\n")
    result = tleaf("eval", "next-activity", run, data, "--rules", rules, "-o", tmp_path / "e")
    assert result.exit_code == 0 and "under other rules" in result.output, result.output
    accuracy = json.loads((tmp_path / "e" / "metrics.json").read_text())["accuracy"]
    assert accuracy["changed_by_rules"] > 0
    same = tleaf("eval", "next-activity", run, data, "--rules", kb, "-o", tmp_path / "f")
    assert same.exit_code == 0, same.output
