"""The one training loop (`embed.training.fit`): resume ends where an uninterrupted run ends,
patience and the best weights survive a resume, checkpoints are written atomically; and the
action recognizer, which trains through it, resumes exactly too."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch
from torch import nn

from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.training.loop import LoopSettings, Step, chunks, fit


class Stop(Exception):
    """Raised by a callback to interrupt a run after an epoch (as a crash or Ctrl-C would)."""


def _toy_run(out: Path, settings: LoopSettings, resume: bool = False, stop_after: int = 0):
    """A small regression net with dropout (so the RNG matters) through the loop; the trainer
    seeds torch and builds the model afresh, as a new process would."""
    torch.manual_seed(0)
    x = torch.randn(40, 3)
    y = x @ torch.tensor([1.0, -2.0, 0.5]) + 0.1 * torch.randn(40)
    model = nn.Sequential(nn.Linear(3, 8), nn.Dropout(0.3), nn.Linear(8, 1))
    trained: list[int] = []

    def step(rows: list[int]) -> Step:
        loss = (model(x[rows]).squeeze(1) - y[rows]).pow(2).mean()
        return Step(loss, {"loss": loss.item()}, len(rows))

    def on_epoch(record: dict) -> None:
        trained.append(record["epoch"])
        if record["epoch"] == stop_after:
            raise Stop

    metrics = fit(
        model,
        lambda epoch, generator: chunks(list(range(30)), 7, generator),
        step,
        lambda: -(model(x[30:]).squeeze(1) - y[30:]).pow(2).mean().item(),
        settings,
        out,
        score="val_score",
        resume=resume,
        on_epoch=on_epoch,
    )
    return metrics, trained


def _timeless(history: list[dict]) -> list[dict]:
    return [{k: v for k, v in h.items() if k != "seconds"} for h in history]


def _same_weights(a: Path, b: Path) -> bool:
    one, two = (torch.load(p / "weights.pt", weights_only=True) for p in (a, b))
    return one.keys() == two.keys() and all(torch.equal(one[k], two[k]) for k in one)


@pytest.mark.parametrize("stop_after", [1, 3, 5])
@pytest.mark.parametrize("schedule", ["constant", "cosine"])
def test_a_resumed_run_ends_as_an_uninterrupted_one(tmp_path: Path, stop_after, schedule) -> None:
    settings = LoopSettings(epochs=6, patience=6, lr=0.05, seed=3, schedule=schedule)
    whole, _ = _toy_run(tmp_path / "whole", settings)
    with pytest.raises(Stop):
        _toy_run(tmp_path / "cut", settings, stop_after=stop_after)
    assert not (tmp_path / "cut" / "weights.pt").exists()  # written when the run ends
    resumed, trained = _toy_run(tmp_path / "cut", settings, resume=True)
    assert trained == list(range(stop_after + 1, 7))  # only the epochs still to train
    assert _timeless(resumed["history"]) == _timeless(whole["history"])
    assert resumed["best"] == whole["best"]
    assert _same_weights(tmp_path / "whole", tmp_path / "cut")


def test_patience_and_the_best_weights_survive_a_resume(tmp_path: Path) -> None:
    """A run that stops on patience stops at the same epoch when resumed after any epoch, and
    keeps the best epoch's weights even when that epoch was before the interruption."""
    settings = LoopSettings(epochs=40, patience=2, lr=0.1, seed=0)  # lr high: the score wobbles
    whole, _ = _toy_run(tmp_path / "whole", settings)
    last, best = whole["history"][-1]["epoch"], whole["best"]["epoch"]
    assert last < 40 and last - best == 2  # stopped on patience
    for stop_after in (best, last - 1, last):
        out = tmp_path / f"cut{stop_after}"
        with pytest.raises(Stop):
            _toy_run(out, settings, stop_after=stop_after)
        resumed, trained = _toy_run(out, settings, resume=True)
        assert trained == list(range(stop_after + 1, last + 1))  # nothing past the stop
        assert _timeless(resumed["history"]) == _timeless(whole["history"])
        assert _same_weights(tmp_path / "whole", out)


def test_resume_without_a_checkpoint_starts_afresh(tmp_path: Path) -> None:
    settings = LoopSettings(epochs=2, patience=2, lr=0.05, seed=0)
    fresh, _ = _toy_run(tmp_path / "a", settings)
    resumed, trained = _toy_run(tmp_path / "b", settings, resume=True)
    assert trained == [1, 2] and _timeless(resumed["history"]) == _timeless(fresh["history"])


def test_a_failed_save_leaves_the_old_checkpoint_and_no_partial_file(
    tmp_path: Path, monkeypatch
) -> None:
    settings = LoopSettings(epochs=3, patience=3, lr=0.05, seed=0)
    out = tmp_path / "run"
    real_save = torch.save

    def half_then_fail(obj, path, *args, **kwargs):
        Path(path).write_bytes(b"PK\x03\x04 half a file")  # what a crash mid-write leaves
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(torch, "save", half_then_fail)
    with pytest.raises(OSError):
        _toy_run(out, settings)
    assert sorted(p.name for p in out.iterdir()) == []  # no checkpoint, no temporary file

    monkeypatch.setattr(torch, "save", real_save)
    with pytest.raises(Stop):
        _toy_run(out, settings, stop_after=1)
    monkeypatch.setattr(torch, "save", half_then_fail)
    with pytest.raises(OSError):
        _toy_run(out, settings, resume=True)  # epoch 2's checkpoint fails
    assert sorted(p.name for p in out.iterdir()) == ["checkpoint.pt"]
    assert torch.load(out / "checkpoint.pt", weights_only=True)["epoch"] == 1  # still whole


def test_a_foreign_checkpoint_is_an_input_error_and_a_bad_schedule_a_setting_error(
    tmp_path: Path,
) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / "checkpoint.pt").write_bytes(b"not a checkpoint")
    settings = LoopSettings(epochs=2, patience=2, lr=0.05, seed=0)
    with pytest.raises(InputError, match=r"checkpoint\.pt: not a checkpoint"):
        _toy_run(out, settings, resume=True)
    torch.save({"model": {"w": torch.zeros(2)}}, out / "checkpoint.pt")
    with pytest.raises(InputError, match="train afresh"):
        _toy_run(out, settings, resume=True)
    with pytest.raises(SettingError) as error:
        LoopSettings(epochs=2, patience=2, lr=0.05, seed=0, schedule="linear")
    assert error.value.setting == "schedule" and "--" not in str(error.value)
    with pytest.raises(SettingError, match="patience"):
        LoopSettings(epochs=2, patience=0, lr=0.05, seed=0)


# ---- the action recognizer through the loop


@pytest.fixture(scope="module")
def activities(tmp_path_factory) -> tuple[Path, Path]:
    """Small activities with unlabelled videos (their stream runs across epochs) and their KB."""
    from typer.testing import CliRunner

    from tleaf_cli.cli import app

    d = tmp_path_factory.mktemp("loop-ar")
    data, kb = d / "act.parquet", d / "kb.ltl"
    args = ["--actions", 6, "--ingredients", 5, "--feature-dim", 8, "--train", 8, "--val", 4]
    args += ["--test", 4, "--unlabelled", 5, "--min-steps", 3, "--max-steps", 6]
    result = CliRunner().invoke(
        app, ["gen-activities", "-o", str(data), "--kb-out", str(kb), *map(str, args)]
    )
    assert result.exit_code == 0, result.output
    return data, kb


def _ar(activities, out: Path, epochs: int, resume: bool = False, stop_after: int = 0) -> dict:
    from tleaf_cli.tasks.action_recognition.train import TaskSettings, train_action_recognition

    settings = TaskSettings(
        logic_loss="exact", lam=1.0, hidden=8, head_hidden=4, batch_size=3, epochs=epochs,
        decode="argmax",  # constrained decoding's figures carry its time
    )  # fmt: skip

    def on_epoch(record) -> None:
        if record.epoch == stop_after:
            raise Stop

    data, kb = activities
    return train_action_recognition(data, kb, None, out, settings, on_epoch, resume=resume)


def _timeless_metrics(metrics: dict) -> dict:
    """The metrics but their timings."""
    kept = {k: v for k, v in metrics.items() if k not in ("mean_epoch_seconds", "setup_seconds")}
    return {**kept, "history": _timeless(metrics["history"])}


def test_a_resumed_action_recognizer_ends_as_an_uninterrupted_one(
    activities, tmp_path: Path
) -> None:
    whole = _ar(activities, tmp_path / "whole", epochs=5)
    assert len(whole["history"]) == 5
    # stopped by its epoch count, then resumed with more epochs
    _ar(activities, tmp_path / "short", epochs=2)
    longer = _ar(activities, tmp_path / "short", epochs=5, resume=True)
    # interrupted after epoch 3 (the callback raises), then resumed
    with pytest.raises(Stop):
        _ar(activities, tmp_path / "cut", epochs=5, stop_after=3)
    resumed = _ar(activities, tmp_path / "cut", epochs=5, resume=True)
    for run, metrics in (("short", longer), ("cut", resumed)):
        assert _timeless_metrics(metrics) == _timeless_metrics(whole)
        assert _same_weights(tmp_path / "whole", tmp_path / run)
        saved = json.loads((tmp_path / run / "metrics.json").read_text())
        assert _timeless_metrics(saved) == _timeless_metrics(whole)


def test_action_recognizer_checkpoint_is_atomic(activities, tmp_path: Path, monkeypatch) -> None:
    def fail(obj, path, *args, **kwargs):
        Path(path).write_bytes(b"half")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(torch, "save", fail)
    with pytest.raises(OSError):
        _ar(activities, tmp_path / "run", epochs=2)
    assert not [p.name for p in (tmp_path / "run").iterdir() if p.suffix in (".pt", ".tmp")]


def test_the_unlabelled_stream_read_from_a_batch_on_is_the_tail_of_the_whole_stream(
    activities,
) -> None:
    """An epoch reads the unlabelled stream from where the epochs before it left it."""
    from itertools import islice

    from tleaf_cli.tasks.action_recognition.activities import read_activities
    from tleaf_cli.tasks.action_recognition.train import TaskSettings, unlabelled_batches

    data = read_activities(activities[0])
    settings = TaskSettings(logic_loss="exact", batch_size=3)  # 5 videos: passes of 2 batches

    def ids(stream, n: int) -> list[list[str]]:
        return [[v.video_id for v in batch.videos] for batch in islice(stream, n)]

    whole = ids(unlabelled_batches(data, settings, torch.device("cpu")), 9)
    for skip in (1, 2, 5):
        tail = ids(unlabelled_batches(data, settings, torch.device("cpu"), skip=skip), 9 - skip)
        assert tail == whole[skip:]
    assert whole[0] != whole[2]  # each pass its own order
