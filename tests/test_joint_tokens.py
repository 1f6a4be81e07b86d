"""Suffix prediction of events with attributes: joint tokens (activity, resource), rules that name
attribute values (MP-Declare), the rules' product, the soft rule score, and the model that reads
and predicts the resource, end to end through train-task and eval."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from tests.conftest import resource_cases, resource_log
from tleaf_cli.cli.root import app
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.settings.next_activity import NextActivitySettings
from tleaf_cli.tasks.case_checks import compile_rules, read_case_rules
from tleaf_cli.tasks.next_activity.attribute_heads import AttributeHeads
from tleaf_cli.tasks.next_activity.encoding import Encoder
from tleaf_cli.tasks.next_activity.joint_tokens import JointTokens, joint_rules
from tleaf_cli.tasks.next_activity.rule_automaton import RuleAutomaton
from tleaf_cli.tasks.next_activity.similarity import jaccard_similarity
from tleaf_cli.tasks.next_activity.suffix_sampling import sample_suffixes
from tleaf_cli.tasks.next_activity.suffix_search import predict_suffixes
from tleaf_cli.tasks.next_activity.train import new_model

runner = CliRunner()

DECL = """activity a
activity b
activity c
bind c: org:resource
org:resource: r1, r2, r3, r4
Existence[c] |A.org:resource is r4 |
Chain Precedence[b, c] |A.org:resource is r4 | |
"""


def _log(path: Path, cases: int = 60, seed: int = 0) -> Path:
    return resource_log(path, cases, seed)


@pytest.fixture(scope="module")
def cases_path(tmp_path_factory) -> Path:
    return resource_cases(tmp_path_factory.mktemp("joint"), 60)


@pytest.fixture(scope="module")
def encoder(cases_path) -> Encoder:
    return Encoder.fit(read_cases(cases_path), attributes=("org:resource",))


def test_tokens_round_trip_and_name_their_atoms(encoder):
    tokens = JointTokens(encoder)
    assert tokens.size == 3 * 5  # 3 activities × (4 resources + none)
    activities, values = tokens.decode(np.arange(tokens.size))
    assert np.array_equal(tokens.encode(activities, values), np.arange(tokens.size))
    letters = tokens.letters()
    c = encoder.atoms.index("c")
    r4 = encoder.values[0].index("r4") + 1
    assert letters[tokens.encode(np.array([c]), np.array([[r4]]))[0]] == {
        "c",
        "org_resource__r4",
    }
    assert letters[tokens.encode(np.array([c]), np.array([[0]]))[0]] == {"c"}  # no resource


def test_joint_rules_read_attribute_conditions(tmp_path, encoder):
    kb = tmp_path / "kb.decl"
    kb.write_text(DECL, encoding="utf-8")
    tokens = JointTokens(encoder)
    rules = joint_rules(kb, tokens)
    assert not rules.activities_only and rules.unseen == ()
    t = {
        (a, r): int(tokens.encode(np.array([encoder.atoms.index(a)]), np.array([[r]]))[0])
        for a in encoder.atoms
        for r in range(5)
    }
    r3, r4 = encoder.values[0].index("r3") + 1, encoder.values[0].index("r4") + 1
    a1 = encoder.values[0].index("r1") + 1
    b2 = encoder.values[0].index("r2") + 1
    auto = rules.automaton
    assert auto.accepts((t["a", a1], t["b", b2], t["c", r4]))
    assert not auto.accepts((t["a", a1], t["b", b2], t["c", r3]))  # c by r4 never happens
    assert not auto.accepts((t["a", a1], t["c", r4]))  # c by r4 not right after b
    assert auto.accepts((t["a", a1], t["c", r3], t["b", b2], t["c", r4]))  # c by r3: no rule


def test_product_accepts_what_every_rule_accepts(tmp_path, encoder):
    kb = tmp_path / "kb.decl"
    kb.write_text(DECL, encoding="utf-8")
    tokens = JointTokens(encoder)
    rules = read_case_rules(kb, encoder.names())
    dfas = compile_rules(rules, "powerset")
    letters = tokens.letters({a: test for r in rules for a, test in r.conditions.items()})
    columns = [np.array([d.alphabet.index(ls) for ls in letters]) for d in dfas]
    joined = RuleAutomaton.of_letters(dfas, columns)
    apart = RuleAutomaton.of_letters(dfas, columns, max_states=1)  # too small: kept as parts
    assert len(joined.following) == 1 and len(apart.following) == 2
    rng = np.random.default_rng(0)
    for _ in range(300):
        word = tuple(rng.integers(0, tokens.size, rng.integers(1, 6)).tolist())
        assert joined.accepts(word) == apart.accepts(word)
    # the product's distance is exact: from the start, c by r4 needs a b right before it
    start = joined.run(())
    assert joined.distance[0][start[0]] == 2
    assert max(d[s] for d, s in zip(apart.distance, apart.run(()), strict=True)) == 1


def _model_preferring(order: list[int], size: int):
    """A fake next-event model: the tokens of `order` in turn, then the end, each with
    probability 0.9, the rest spread evenly."""

    def call(rows):
        out = np.full((len(rows), size + 1), np.log(0.1 / size))
        for i, row in enumerate(rows):
            step = len(row) - 1
            out[i, order[step] if step < len(order) else size] = np.log(0.9)
        return out

    return call


def test_soft_weight_ranks_by_the_rules(tmp_path, encoder):
    kb = tmp_path / "kb.decl"
    kb.write_text(DECL, encoding="utf-8")
    tokens = JointTokens(encoder)
    auto = joint_rules(kb, tokens).automaton

    def tok(a, r):
        value = encoder.values[0].index(r) + 1
        return int(tokens.encode(np.array([encoder.atoms.index(a)]), np.array([[value]]))[0])

    # the model: a, b, c by r3, end (breaks the rules: c by r4 is required)
    model = _model_preferring([tok("b", "r2"), tok("c", "r3")], tokens.size)
    prefix = [(tok("a", "r1"),)]
    free = predict_suffixes(model, prefix, tokens.size, beam_width=3, max_length=4)[0]
    assert free.activities == (tok("b", "r2"), tok("c", "r3"))
    zero = predict_suffixes(
        model, prefix, tokens.size, rules=auto, beam_width=3, max_length=4, rule_weight=0.0
    )[0]
    assert zero.activities == free.activities  # μ = 0: the rules weigh nothing
    soft = predict_suffixes(
        model, prefix, tokens.size, rules=auto, beam_width=3, max_length=4, rule_weight=20.0
    )[0]
    assert soft.satisfied and soft.activities == (tok("b", "r2"), tok("c", "r4"))
    hard = predict_suffixes(model, prefix, tokens.size, rules=auto, beam_width=3, max_length=4)[0]
    assert hard.satisfied and hard.found


def test_attribute_heads_score_every_activity_like_one():
    heads = AttributeHeads(hidden=6, num_activities=3, value_counts=(5, 2))
    h = torch.randn(4, 6)
    every = heads.every(h)
    for a in range(3):
        one = heads(h, torch.full((4,), a))
        for k in range(2):
            assert torch.allclose(every[k][:, a], torch.log_softmax(one[k], dim=-1), atol=1e-6)


@pytest.mark.parametrize("kind", ["lstm", "transformer"])
def test_models_read_values_and_predict_them(encoder, kind):
    settings = NextActivitySettings(model=kind, hidden=8, layers=1, heads=2)
    model = new_model(encoder, settings).eval()
    acts = torch.tensor([[0, 1, 2]])
    times = torch.zeros(1, 3, 5)
    lengths = torch.tensor([3])
    one = model(acts, times, lengths, torch.tensor([[[1], [2], [3]]]))
    other = model(acts, times, lengths, torch.tensor([[[1], [2], [4]]]))
    assert one.shape == (1, 3, 4)
    assert torch.allclose(one[:, :2], other[:, :2], atol=1e-5)  # causal: the past only
    assert not torch.allclose(one[:, 2], other[:, 2])  # the event's value is read


def test_jaccard_similarity():
    assert jaccard_similarity([1, 2, 2], [2, 1]) == 1.0
    assert jaccard_similarity([1, 2], [2, 3]) == pytest.approx(1 / 3)
    assert jaccard_similarity([], []) == 1.0
    assert jaccard_similarity([1], []) == 0.0


def test_train_and_eval_with_the_resource(tmp_path, cases_path):
    kb = tmp_path / "kb.decl"
    kb.write_text(DECL, encoding="utf-8")
    run = tmp_path / "run"
    result = runner.invoke(
        app,
        [
            "train-task", "next-activity", str(cases_path), "-o", str(run), "--hidden", "16",
            "--layers", "1", "--epochs", "15", "--attributes", "org:resource", "-q",
        ],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["test"]["accuracy_org:resource"] is not None
    out = tmp_path / "eval"
    result = runner.invoke(
        app,
        [
            "eval", "next-activity", str(run), str(cases_path), "--rules", str(kb),
            "--prefix-lengths", "1", "--beam-width", "3", "--rule-weight", "20", "-o", str(out),
            "-q",
        ],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    saved = json.loads((out / "metrics.json").read_text())
    assert saved["rules"]["attributes"] is True
    row = saved["suffix"]["1"]
    for way in ("argmax", "beam", "rules", "beam_soft", "argmax_soft"):
        assert 0 <= row[way]["dl_similarity_org:resource"] <= 1
        assert 0 <= row[way]["jaccard"] <= 1
    assert row["rules"]["satisfying"] == 1.0  # the filter keeps the rules
    assert row["beam_soft"]["satisfying"] == 1.0  # a heavy weight too, here
    assert row["beam"]["satisfying"] < 1.0  # the model alone closes by r3 mostly


def test_the_logic_loss_refuses_rules_on_attributes(tmp_path, cases_path):
    kb = tmp_path / "kb.decl"
    kb.write_text(DECL, encoding="utf-8")
    result = runner.invoke(
        app,
        [
            "train-task", "next-activity", str(cases_path), "-o", str(tmp_path / "run"),
            "--attributes", "org:resource", "--kb", str(kb), "--logic-loss", "exact", "-q",
        ],
    )  # fmt: skip
    assert result.exit_code == 2
    assert "org_resource__is__r4" in result.output and "apply at decoding" in result.output
    assert not (tmp_path / "run" / "weights.pt").exists()


def test_soft_sampling_follows_the_weight(tmp_path, encoder):
    kb = tmp_path / "kb.decl"
    kb.write_text(DECL, encoding="utf-8")
    tokens = JointTokens(encoder)
    auto = joint_rules(kb, tokens).automaton
    c = encoder.atoms.index("c")
    b = encoder.atoms.index("b")
    r2 = encoder.values[0].index("r2") + 1
    a = encoder.atoms.index("a")
    r1 = encoder.values[0].index("r1") + 1
    tok = lambda act, val: int(tokens.encode(np.array([act]), np.array([[val]]))[0])  # noqa: E731
    r3 = encoder.values[0].index("r3") + 1
    model = _model_preferring([tok(b, r2), tok(c, r3)], tokens.size)
    prefixes = [(tok(a, r1),)] * 200

    def kept(weight):
        drawn = sample_suffixes(
            model, prefixes, tokens.size, rules=auto, max_length=4, rule_weight=weight, seed=1
        )
        return np.mean(
            [auto.accepts(p + d.activities) for p, d in zip(prefixes, drawn, strict=True)]
        )

    assert kept(0.0) < 0.2  # the model alone: c by r3
    assert kept(20.0) > 0.9  # heavily weighted rules: c by r4 after b


def test_a_test_activity_training_never_saw_is_scored_where_it_can_be(tmp_path, cases_path):
    run = tmp_path / "run"
    result = runner.invoke(
        app,
        [
            "train-task", "next-activity", str(cases_path), "-o", str(run), "--hidden", "8",
            "--layers", "1", "--epochs", "1", "--attributes", "org:resource", "-q",
        ],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    log = tmp_path / "drift.csv"
    log.write_text(
        "case:concept:name,concept:name,time:timestamp,org:resource\n"
        "n1,a,2021-01-01T10:00:00,r1\nn1,b,2021-01-01T11:00:00,r2\n"
        "n1,d,2021-01-01T12:00:00,r2\nn1,c,2021-01-01T13:00:00,r4\n"
        "n2,a,2021-01-02T10:00:00,r1\nn2,b,2021-01-02T11:00:00,r2\n"
        "n2,c,2021-01-02T12:00:00,r4\n",
        encoding="utf-8",
    )
    drift = tmp_path / "drift.parquet"
    result = runner.invoke(
        app, ["read-log", str(log), "-o", str(drift), "--attributes", "org:resource",
              "--split", "0,0,1", "-q"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    out = tmp_path / "eval"
    result = runner.invoke(
        app,
        ["eval", "next-activity", str(run), str(drift), "--prefix-lengths", "1,3", "-o", str(out),
         "-q"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    saved = json.loads((out / "metrics.json").read_text())
    assert any("never saw in training" in w for w in saved["warnings"])
    assert saved["accuracy"]["cases"] == 1  # n1 left out of next-activity accuracy
    assert saved["suffix"]["1"]["cases"] == 2  # n1's prefix (a) is known: its suffix scored
    assert saved["suffix"]["1"]["unknown_prefixes"] == 0
    assert saved["suffix"]["3"]["cases"] == 1 and saved["suffix"]["3"]["unknown_prefixes"] == 1


def test_training_needs_no_test_split_when_the_test_is_another_file(tmp_path):
    log = _log(tmp_path / "log.csv", cases=30)
    train = tmp_path / "train.parquet"
    result = runner.invoke(
        app, ["read-log", str(log), "-o", str(train), "--split", "0.8,0.2,0", "-q"]
    )
    assert result.exit_code == 0, result.output
    result = runner.invoke(
        app,
        ["train-task", "next-activity", str(train), "-o", str(tmp_path / "run"), "--hidden", "8",
         "--layers", "1", "--epochs", "1"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "no test split" in result.output
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert metrics["test"] == {"cases": 0}


def test_rules_on_an_activity_the_log_never_has_are_read_and_reported(tmp_path, cases_path):
    kb = tmp_path / "kb.ltl"
    kb.write_text(
        "# z never happens in the log\nnever_z: !(F(a) & F(zed))\nmust_z: F(c) -> F(b)\n",
        encoding="utf-8",
    )
    run = tmp_path / "run"
    result = runner.invoke(
        app,
        ["train-task", "next-activity", str(cases_path), "-o", str(run), "--hidden", "8",
         "--layers", "1", "--epochs", "1", "--kb", str(kb), "--logic-loss", "exact",
         "--lambda", "0.1"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "never_z" in result.output and "never happening" in result.output
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["rules_unseen"] == {"never_z": ["zed"]}
    out = tmp_path / "eval"
    result = runner.invoke(
        app, ["eval", "next-activity", str(run), str(cases_path), "-o", str(out)]
    )
    assert result.exit_code == 0, result.output
    saved = json.loads((out / "metrics.json").read_text())
    assert any("zed" in w for w in saved["warnings"])
    # an Existence of the unknown activity can never hold: refused as unsatisfiable
    kb.write_text("need_z: F(zed)\n", encoding="utf-8")
    bad = runner.invoke(
        app,
        ["train-task", "next-activity", str(cases_path), "-o", str(tmp_path / "bad"), "--kb",
         str(kb), "--logic-loss", "exact", "--epochs", "1"],
    )  # fmt: skip
    assert bad.exit_code == 2 and "unsatisfiable" in bad.output
