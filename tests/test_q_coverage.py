"""The tleaf loss's q against the knowledge base it is to read: a q that can read none of a run's
rules is a usage error before training; one that reads some says how many it leaves out; and
`eval action-recognition` does not list a run whose loss read no rule as a tleaf run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.conftest import tiny_activities
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.knowledge.base import read_knowledge_base
from tleaf_cli.settings.action_recognition import TaskSettings
from tleaf_cli.settings.meta import MetaSettings
from tleaf_cli.training.q_coverage import q_coverage

TINY = {"logic_loss": "tleaf", "hidden": 8, "head_hidden": 4, "epochs": 1, "decode": "argmax"}


def _small_q(dfas: Path, traces: Path, edge: Path, out: Path) -> Path:
    from tleaf_cli.embed.train_meta import train_meta

    settings = MetaSettings.preset("paper", hidden=16, layers=2, out_dim=8, epochs=1)
    train_meta(dfas, traces, edge, out, settings)
    return out


@pytest.fixture(scope="module")
def abc_q(chain, tmp_path_factory) -> Path:
    """A tiny q trained on the Low tier's formulas over a, b and c only."""
    return _small_q(chain["dfas"], chain["traces"], chain["edge"], tmp_path_factory.mktemp("q"))


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> tuple[Path, Path]:
    return tiny_activities(tmp_path_factory.mktemp("act"))


def test_coverage_counts_the_rules_and_atoms_q_does_not_know(tiny) -> None:
    kb = read_knowledge_base(tiny[1])
    atoms = sorted({a for r in kb for a in r.atoms})
    known = atoms[: len(atoms) // 2]
    coverage = q_coverage(kb, known)
    unread = [r for r in kb if not set(r.atoms) <= set(known)]
    assert 0 < coverage.left_out == len(unread) < len(kb) == coverage.rules
    assert coverage.missing_atoms == tuple(sorted(set(atoms) - set(known)))
    assert q_coverage(kb, atoms).left_out == 0
    assert q_coverage(kb, ["a", "b", "c"]).left_out == len(kb)
    text = q_coverage(kb, []).missing_text()
    assert text.startswith(atoms[0]) and text.endswith(f"and {len(atoms) - 5} more")


def test_a_q_that_reads_none_of_the_rules_is_refused(abc_q: Path, tiny, tmp_path: Path) -> None:
    """Before the fix the run trained for its epochs with a logic loss of 0 and exited 0."""
    from tleaf_cli.tasks.action_recognition.train import train_action_recognition

    data, kb = tiny
    with pytest.raises(SettingError) as refused:
        train_action_recognition(data, kb, abc_q, tmp_path / "r", TaskSettings(**TINY))
    message = str(refused.value)
    first = sorted({a for r in read_knowledge_base(kb) for a in r.atoms})[0]
    assert refused.value.setting == "embedder"
    assert first in message and "more" in message and "train q on this knowledge base" in message
    assert not (tmp_path / "r" / "metrics.json").exists()


def test_the_cli_says_so_in_one_line_and_exits_2(
    chain_cli, abc_q: Path, tiny, tmp_path: Path
) -> None:
    data, kb = tiny
    args = ["--logic-loss", "tleaf", "--embedder", abc_q, "--epochs", 1, "-o", tmp_path / "r"]
    result = chain_cli("train-task", "action-recognition", data, "--kb", kb, *args)
    assert result.exit_code == 2, result.output
    assert len(result.output.strip().splitlines()) == 1 and "--embedder" in result.output
    assert "none of the knowledge base's" in result.output and "Traceback" not in result.output


@pytest.fixture(scope="module")
def half_q(chain, chain_cli, tiny, tmp_path_factory) -> tuple[Path, set[str]]:
    """A q whose q_e knows a, b, c and the atoms of the first half of the tiny KB's rules (its
    q_m trained on the Low tier's formulas), and the KB atoms it knows."""
    from tleaf_cli.embed.train_edge import EdgeSettings, train_edge

    root = tmp_path_factory.mktemp("half")
    rules = [r for r in read_knowledge_base(tiny[1]) if r.atoms]
    kept = rules[: len(rules) // 2]
    formulas, dfas = root / "f.ltl", root / "dfas.parquet"
    low = chain["ltl"].read_text()
    formulas.write_text(low + "".join(f"kb{k}: {r.formula}\n" for k, r in enumerate(kept)))
    result = chain_cli("compile-dfa", formulas, "--one-hot", "-o", dfas, "-q")
    assert result.exit_code == 0, result.output
    train_edge(dfas, root / "edge", EdgeSettings(hidden=32, out_dim=16, epochs=1))
    q = _small_q(chain["dfas"], chain["traces"], root / "edge", root / "q")
    return q, {a for r in kept for a in r.atoms}


def test_a_q_that_reads_some_rules_says_how_many_it_leaves_out(
    chain_cli, half_q, tiny, tmp_path: Path
) -> None:
    q, known = half_q
    data, kb = tiny
    rules = list(read_knowledge_base(kb))
    left_out = sum(not set(r.atoms) <= known for r in rules)
    assert 0 < left_out < len(rules)
    result = chain_cli("train-task", "action-recognition", data, "--kb", kb, "--logic-loss",
                       "tleaf", "--embedder", q, "--epochs", 1, "--hidden", 8,
                       "-o", tmp_path / "r")  # fmt: skip
    assert result.exit_code == 0, result.output
    assert f"leaves out {left_out} of the knowledge base's {len(rules)} rules" in result.output
    rule_sets = json.loads((tmp_path / "r/metrics.json").read_text())["rule_sets"]
    assert rule_sets["kb_rules_unknown_to_q"] == left_out and rule_sets["kb_rules"] == len(rules)
    quiet = chain_cli("train-task", "action-recognition", data, "--kb", kb, "--logic-loss",
                      "tleaf", "--embedder", q, "--epochs", 1, "--hidden", 8,
                      "-o", tmp_path / "quiet", "-q")  # fmt: skip
    assert quiet.exit_code == 0 and "leaves out" not in quiet.output


def test_eval_does_not_list_a_run_that_read_no_rule_as_tleaf(tiny, tmp_path: Path) -> None:
    """A tleaf run written before the refusal, whose loss compiled no rule (the defect's
    metrics.json: compiled 0, rules left out), is refused with the reason."""
    from tleaf_cli.tasks.action_recognition.evaluate import evaluate_runs, read_run
    from tleaf_cli.tasks.action_recognition.train import train_action_recognition

    data, kb = tiny
    run = tmp_path / "run"
    train_action_recognition(data, kb, None, run, TaskSettings(**{**TINY, "logic_loss": "none"}))
    config = json.loads((run / "config.json").read_text())
    config["settings"]["logic_loss"] = "tleaf"
    (run / "config.json").write_text(json.dumps(config))
    assert read_run(run)["logic_loss"] == "tleaf"  # a tleaf run whose loss read rules
    metrics = json.loads((run / "metrics.json").read_text())
    metrics["rule_sets"] = {"compiled": 0, "rules_left_out_unknown_to_q": 10120}
    (run / "metrics.json").write_text(json.dumps(metrics))
    with pytest.raises(InputError, match="none of the knowledge base's rules"):
        evaluate_runs([run], tmp_path / "report")
