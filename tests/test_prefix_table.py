"""The trivial baseline (`--model prefix-table`) and example leakage: the table predicts what
followed the same prefix in training, backs off to the longest seen suffix, is scored by the same
run as the trained models, and eval reports the share of test prefixes seen in training."""

from __future__ import annotations

import json

import numpy as np
import torch

from tests.test_next_activity import cases_artifact
from tleaf_cli.settings.next_activity import NextActivitySettings, SuffixSettings
from tleaf_cli.tasks.next_activity.evaluate import evaluate_next_activity
from tleaf_cli.tasks.next_activity.prefix_table import PrefixTable, seen_in_training
from tleaf_cli.tasks.next_activity.train import train_next_activity


def test_the_table_predicts_what_followed_the_prefix_and_backs_off() -> None:
    table = PrefixTable([[0, 1, 2], [0, 1, 2], [0, 1, 1], [2, 0]], num_activities=3)
    best = lambda prefix: int(np.argmax(table.log_probs(prefix)))  # noqa: E731
    assert best((0, 1)) == 2  # whole prefix: 2 twice, 1 once
    assert best((0, 1, 2)) == 3  # the end
    assert best((2, 2, 0, 1)) == 2  # unseen whole: its longest seen suffix (0, 1)
    assert best((1, 1, 1, 1)) == 3  # suffix (1, 1) was followed by the end
    logits = table(torch.tensor([[0, 1, 2]]), torch.zeros(1, 3, 5), torch.tensor([3]))
    assert logits.shape == (1, 3, 4) and logits.argmax(-1).tolist() == [[1, 2, 3]]


def test_leakage_is_the_share_of_prefixes_seen_with_their_next_token() -> None:
    seen = seen_in_training([[0, 1, 2]], [[0, 1, 2], [0, 2]], end=3)
    # prefixes (0)->1 seen, (0,1)->2 seen, (0,1,2)->end seen; (0)->2 not, (0,2)->end not
    assert seen.tolist() == [True, True, True, False, False]


def test_the_table_is_a_run_scored_like_the_models_with_its_leakage(tmp_path) -> None:
    data = cases_artifact(tmp_path)
    run = tmp_path / "table"
    metrics = train_next_activity(data, None, None, run, NextActivitySettings(model="prefix-table"))
    assert metrics["history"] == [] and metrics["test"]["accuracy"] > 0.6
    scored = evaluate_next_activity(
        run, data, tmp_path / "eval", SuffixSettings(prefix_lengths="2")
    )
    accuracy = scored["accuracy"]
    assert accuracy["accuracy"] == metrics["test"]["accuracy"]
    assert 0 < accuracy["leakage"] <= 1  # a process of four variants: most prefixes were seen
    saved = json.loads((tmp_path / "eval" / "metrics.json").read_text())
    assert saved["suffix"]["2"]["argmax"]["dl_similarity"] > 0.5
