"""The LSTM advancing each row of a suffix search by one event (lstm_calls.py) answers exactly as
reading every row from its first event: over consecutive calls where rows grow, branch, repeat
and come back unheld, with attribute values as joint tokens and with attributes read as inputs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from tests.conftest import resource_cases
from tests.test_next_activity_inputs import cases_path as inputs_cases_path  # noqa: F401
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.settings.next_activity import NextActivitySettings
from tleaf_cli.tasks.next_activity.encoding import Encoder
from tleaf_cli.tasks.next_activity.joint_tokens import JointTokens, joint_log_probs
from tleaf_cli.tasks.next_activity.lstm_calls import LSTMCalls
from tleaf_cli.tasks.next_activity.suffix_search import Rows
from tleaf_cli.tasks.next_activity.train import new_model


def _whole(model, encoder, tokens, stamps, inputs):
    """joint_log_probs reading every row whole: the model seen as training while the caller is
    made (the cache is for eval mode only), then evaluated in eval mode."""
    model.train()
    call = joint_log_probs(model, encoder, tokens, stamps, inputs)
    model.eval()
    assert not isinstance(call, LSTMCalls)
    return call


def _compare(encoder: Encoder, cases, seed: int) -> int:
    torch.manual_seed(seed)
    settings = NextActivitySettings(model="lstm", hidden=12, layers=2, dropout=0.3)
    model = new_model(encoder, settings).eval()
    tokens = JointTokens(encoder)
    rng = np.random.default_rng(seed)
    k = 2
    sequences = [tokens.of_case(c) for c in cases if len(c) > k]
    chosen = [c for c in cases if len(c) > k]
    stamps = [c.timestamps[:k] for c in chosen]
    inputs = [encoder.input_columns(c)[:k] for c in chosen] if encoder.inputs else None
    fast = joint_log_probs(model, encoder, tokens, stamps, inputs)
    assert isinstance(fast, LSTMCalls)
    slow = _whole(model, encoder, tokens, stamps, inputs)
    rows = [tuple(s[:k].tolist()) for s in sequences]
    owners = list(range(len(rows)))
    stepped = 0
    for step in range(6):
        call = Rows(rows, owners)
        assert np.abs(fast(call) - slow(call)).max() < 1e-5, step
        stepped += sum(1 for r, o in zip(rows, owners, strict=True) if len(r) > k)
        # the next call: each row grows by a random token, some twice (branches), some drop out,
        # and one row is a prefix again (not held: read whole)
        grown, grown_owners = [], []
        for r, o in zip(rows, owners, strict=True):
            for _ in range(int(rng.integers(0, 3))):
                grown.append((*r, int(rng.integers(0, tokens.size))))
                grown_owners.append(o)
        grown.append(tuple(sequences[0][:k].tolist()))
        grown_owners.append(0)
        rows, owners = grown, grown_owners
    return stepped


def test_activities_only(tmp_path: Path) -> None:
    cases = read_cases(resource_cases(tmp_path, 30)).cases
    encoder = Encoder.fit(read_cases(tmp_path / "cases.parquet"))
    assert _compare(encoder, cases, seed=0) > 50


def test_joint_tokens_with_the_resource(tmp_path: Path) -> None:
    cases = read_cases(resource_cases(tmp_path, 30)).cases
    encoder = Encoder.fit(read_cases(tmp_path / "cases.parquet"), attributes=("org:resource",))
    assert _compare(encoder, cases, seed=1) > 50


def test_attributes_read_as_inputs(inputs_cases_path) -> None:  # noqa: F811
    read = read_cases(inputs_cases_path)
    encoder = Encoder.fit(read, inputs=["case:kind", "unit"], numeric_inputs=["lab"])
    assert encoder.inputs
    assert _compare(encoder, read.cases[:40], seed=2) > 50


@pytest.mark.parametrize("kind", ["transformer", "prefix-table"])
def test_other_models_are_read_whole(tmp_path: Path, kind: str) -> None:
    cases = read_cases(resource_cases(tmp_path, 10))
    encoder = Encoder.fit(cases)
    model = new_model(encoder, NextActivitySettings(model=kind, hidden=8, layers=1))
    call = joint_log_probs(model.eval(), encoder, JointTokens(encoder), [cases.cases[0].timestamps])
    assert not isinstance(call, LSTMCalls)
