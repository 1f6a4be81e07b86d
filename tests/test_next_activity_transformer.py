"""The next-activity Transformer (`--model transformer`): causal (step t's logits read events
1..t only, whatever follows or pads), trained by the same run as the LSTM, and learning the
synthetic process of tests/test_next_activity.py as the LSTM does."""

from __future__ import annotations

import pytest
import torch

from tests.test_next_activity import cases_artifact
from tleaf_cli.errors import SettingError
from tleaf_cli.settings.next_activity import NextActivitySettings
from tleaf_cli.tasks.next_activity.evaluate import load_run
from tleaf_cli.tasks.next_activity.train import train_next_activity
from tleaf_cli.tasks.next_activity.transformer import NextActivityTransformer


def test_the_transformer_is_causal_and_ignores_padding() -> None:
    torch.manual_seed(0)
    model = NextActivityTransformer(5, 3, width=16, layers=2, heads=4, dropout=0.0).eval()
    activities = torch.randint(0, 5, (2, 7))
    times = torch.randn(2, 7, 3)
    lengths = torch.tensor([7, 4])
    logits = model(activities, times, lengths)
    changed = activities.clone()
    changed[:, 4:] = (changed[:, 4:] + 1) % 5  # events after step 4 only
    again = model(changed, times, lengths)
    torch.testing.assert_close(logits[:, :4], again[:, :4])
    assert not torch.allclose(logits[0, 4:], again[0, 4:])
    alone = model(activities[1:, :4], times[1:, :4], lengths[1:])  # the short case unpadded
    torch.testing.assert_close(logits[1, :4], alone[0], atol=1e-5, rtol=1e-5)


def test_the_transformer_learns_the_process_and_reloads(tmp_path) -> None:
    data = cases_artifact(tmp_path)
    settings = NextActivitySettings(
        model="transformer", hidden=32, layers=1, heads=4, epochs=25, patience=None, lr=1e-2,
        dropout=0.0,
    )  # fmt: skip
    metrics = train_next_activity(data, None, None, tmp_path / "run", settings)
    assert metrics["test"]["accuracy"] > 0.6  # as the LSTM: past chance on the determined steps
    model, _, again = load_run(tmp_path / "run")
    assert isinstance(model, NextActivityTransformer) and again.model == "transformer"


def test_a_width_that_the_heads_do_not_divide_is_refused() -> None:
    with pytest.raises(SettingError, match="heads"):
        NextActivitySettings(model="transformer", hidden=30, heads=4).check()
