"""tleaf predict: a next-activity run on running cases. The verdicts are the rules' own DFAs'
(state_verdicts over the prefix), the sampled probability that a rule holds at the end covers the
exact one (dynamic programming over DFA states on a fake Markov model) as a 95 % interval should,
the recommendation keeps every rule and is there only where the forecast breaks one, and the
command writes its artifact and table or refuses in one line, writing nothing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from tests.conftest import resource_cases
from tleaf_cli.cli.root import app
from tleaf_cli.data.artifacts import read_provenance
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.logic.verdicts import Verdict, state_verdicts
from tleaf_cli.settings.next_activity import PredictSettings
from tleaf_cli.tasks.case_checks import compile_rules, read_case_rules
from tleaf_cli.tasks.next_activity.encoding import Encoder
from tleaf_cli.tasks.next_activity.joint_tokens import JointTokens
from tleaf_cli.tasks.next_activity.monitoring import monitored_rules, sample_holds, wilson
from tleaf_cli.tasks.next_activity.predictions import predict_cases

runner = CliRunner()

KB = """resp: G(a -> F c)
once_b: F b
no_bb: !F(b & X b)
c_after_b: (!c U b) | G !c
"""
DECL = """activity a
activity c
bind c: org:resource
org:resource: r1, r2, r3, r4
Existence[c] |A.org:resource is r4 |
"""


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> dict[str, Path]:
    """A cases artifact, an activity-only run trained one epoch, and the rules."""
    folder = tmp_path_factory.mktemp("predict")
    cases = resource_cases(folder)
    run = folder / "run"
    result = runner.invoke(
        app,
        ["train-task", "next-activity", str(cases), "-o", str(run), "--hidden", "8",
         "--layers", "1", "--epochs", "1", "-q"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    kb = folder / "kb.ltl"
    kb.write_text(KB, encoding="utf-8")
    decl = folder / "kb.decl"
    decl.write_text(DECL, encoding="utf-8")
    return {"folder": folder, "cases": cases, "run": run, "kb": kb, "decl": decl}


@pytest.fixture(scope="module")
def predicted(made) -> list[dict]:
    out = made["folder"] / "predictions.parquet"
    settings = PredictSettings(prefix_lengths="1-4", max_suffix=6, samples=20)
    predict_cases(made["run"], made["cases"], out, settings, made["kb"])
    assert read_provenance(out).kind == "predictions"
    return pq.read_table(out).to_pylist()


def test_the_verdicts_are_each_rules_dfa_state_verdict(made, predicted):
    rules = read_case_rules(made["kb"])
    dfas = compile_rules(rules)
    atoms = read_cases(made["cases"]).activity_atoms
    assert {len(r["prefix"]) for r in predicted} == {1, 2, 3, 4}
    for row in predicted:
        assert [r["rule"] for r in row["rules"]] == [r.name for r in rules]
        for rule, dfa, got in zip(rules, dfas, row["rules"], strict=True):
            state = dfa.initial
            for name in row["prefix"]:
                state = int(dfa.table[state, dfa.alphabet.index({atoms[name]})])
            verdict = Verdict(int(state_verdicts(dfa)[state]))
            assert got["verdict"] == str(verdict), (rule.name, row["prefix"])
            if verdict.final:
                assert got["method"] == "exact"
                assert got["probability"] == (1.0 if verdict.satisfied else 0.0)
            else:
                assert (
                    got["method"] == "sampled" and got["low"] <= got["probability"] <= got["high"]
                )


def test_the_recommendation_keeps_every_rule_and_only_where_needed(made, predicted):
    rules = read_case_rules(made["kb"])
    dfas = compile_rules(rules)
    atoms = read_cases(made["cases"]).activity_atoms

    def keeps(names) -> bool:
        ok = True
        for dfa in dfas:
            state = dfa.initial
            for name in names:
                state = int(dfa.table[state, dfa.alphabet.index({atoms[name]})])
            ok &= bool(dfa.accepting[state])
        return ok

    statuses = {r["recommendation_status"] for r in predicted}
    assert {"found", "not needed"} <= statuses  # neither side vacuous
    for row in predicted:
        forecast = row["prefix"] + row["suffix"]  # --way beam, no rules: the forecast
        if row["recommendation_status"] == "not needed":
            assert keeps(forecast) and row["recommendation"] is None
        elif row["recommendation_status"] == "found":
            assert not keeps(forecast)
            assert keeps(row["prefix"] + row["recommendation"])
            assert row["recommendation_relative"] == pytest.approx(
                np.exp(row["recommendation_log_prob"] - row["suffix_log_prob"])
            )
        else:  # "none": some rule is broken for good here (no continuation keeps them all)
            assert row["recommendation"] is None
        if row["true_next"] is not None:
            assert row["true_suffix"][:1] == (
                [] if row["true_next"] == "<end>" else [row["true_next"]]
            )


# the fake model: a Markov chain over a, b, c and the end (rows: the last activity)
MARKOV = np.array([[0.2, 0.4, 0.2, 0.2], [0.1, 0.3, 0.3, 0.3], [0.3, 0.1, 0.2, 0.4]])


def _markov(rows):
    return np.log(MARKOV[[row[-1] for row in rows]])


def _exact(dfa_table: np.ndarray, accepting: np.ndarray, start: int, last: int, cap: int) -> float:
    """P(the rule accepts when the case ends), by dynamic programming over (DFA state, last
    activity) up to `cap` more activities (at the cap the case ends, as sampling ends it)."""
    v = MARKOV.shape[0]
    mass = np.zeros((dfa_table.shape[0], v))
    mass[start, last] = 1.0
    holds = 0.0
    for step in range(cap + 1):
        if step == cap:
            return holds + float(mass[accepting].sum())
        ending = mass * MARKOV[:, v][None, :]
        holds += float(ending[accepting].sum())
        moved = np.zeros_like(mass)
        for s, a in zip(*np.nonzero(mass), strict=True):
            for b in range(v):
                moved[dfa_table[s, b], b] += mass[s, a] * MARKOV[a, b]
        mass = moved
    return holds


def test_the_sampled_probability_covers_the_exact_one(made):
    encoder = Encoder.fit(read_cases(made["cases"]))
    assert encoder.atoms == ("a", "b", "c")
    rules = monitored_rules(made["kb"], JointTokens(encoder))
    rng = np.random.default_rng(0)
    prefixes = [tuple(rng.integers(0, 3, rng.integers(1, 4)).tolist()) for _ in range(25)]
    starts = np.array(
        [[r.initial for r in rules.dfas] for _ in prefixes], dtype=np.int64
    )  # the initial states, then each prefix run through each rule's token table
    for i, prefix in enumerate(prefixes):
        for k, table in enumerate(rules.tables):
            for a in prefix:
                starts[i, k] = table[starts[i, k], a]
    cap, samples = 5, 200
    exact = np.array(
        [
            [_exact(t, d.accepting, starts[i, k], p[-1], cap) for k, (t, d) in
             enumerate(zip(rules.tables, rules.dfas, strict=True))]
            for i, p in enumerate(prefixes)
        ]
    )  # fmt: skip
    inner = (exact > 0) & (exact < 1)  # the pairs whose answer is not certain at token level
    assert inner.mean() > 0.5
    covered, covered_inner, shifted, pairs = 0, 0, 0, 0
    for seed in range(8):
        kept, at_cap = sample_holds(_markov, prefixes, starts, rules, 3, samples, cap, seed=seed)
        low, high = wilson(kept, samples)
        inside = (low <= exact + 1e-12) & (exact <= high + 1e-12)
        covered += int(inside.sum())
        covered_inner += int(inside[inner].sum())
        wrong = np.clip(exact + 0.15, 0, 1)
        shifted += int(((low <= wrong) & (wrong <= high)).sum())
        pairs += exact.size
        assert (at_cap <= samples).all() and at_cap.sum() > 0  # some reach the cap of 5
    assert pairs == 8 * 25 * 4
    assert covered_inner / (8 * inner.sum()) >= 0.93  # and where it is not
    assert covered / pairs >= 0.95, covered / pairs  # 0.969 of 800 pairs
    assert shifted / pairs < 0.5  # the interval is narrow enough to tell a wrong answer


def test_wilson_interval():
    low, high = wilson(np.array([0, 10, 20]), 20)
    assert low[0] == 0 and high[2] == 1
    assert low[1] < 0.5 < high[1] and high[1] - low[1] == pytest.approx(0.4, abs=0.02)


def test_the_command_writes_and_shows_its_predictions(made, tmp_path):
    out = tmp_path / "p.parquet"
    result = runner.invoke(
        app,
        ["predict", str(made["run"]), str(made["cases"]), "--rules", str(made["kb"]),
         "--prefix-lengths", "2", "--samples", "10", "--max-suffix", "4", "-o", str(out)],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "first" in result.output and "recommendation" in result.output
    table = pq.read_table(out)
    assert table.num_rows == 40 and set(table.column("prefix_length").to_pylist()) == {2}
    shown = runner.invoke(app, ["inspect", str(out), "--rows", "2"])
    assert shown.exit_code == 0 and "predictions artifact" in shown.output


def test_an_activity_the_run_never_saw_gets_a_reason(made, tmp_path):
    log = tmp_path / "drift.csv"
    log.write_text(
        "case:concept:name,concept:name,time:timestamp,org:resource\n"
        "n1,a,2021-01-01T10:00:00,r1\nn1,d,2021-01-01T11:00:00,r2\n"
        "n2,a,2021-01-02T10:00:00,r1\nn2,b,2021-01-02T11:00:00,r2\n",
        encoding="utf-8",
    )
    drift = tmp_path / "drift.parquet"
    result = runner.invoke(app, ["read-log", str(log), "-o", str(drift), "-q"])
    assert result.exit_code == 0, result.output
    out = tmp_path / "p.parquet"
    settings = PredictSettings(samples=10, max_suffix=4)
    predict_cases(made["run"], drift, out, settings, made["kb"])
    rows = {r["case_id"]: r for r in pq.read_table(out).to_pylist()}
    assert "'d' was never seen" in rows["n1"]["reason"] and rows["n1"]["next_activities"] == []
    assert [r["verdict"] for r in rows["n1"]["rules"]]  # the verdicts are still given
    assert rows["n2"]["reason"] is None and len(rows["n2"]["next_activities"]) == 3


@pytest.mark.parametrize(
    ("extra", "says"),
    [
        (["--rule", "nope"], "no rule named nope"),
        (["--rule", "resp", "--split", "nosuch"], "no cases in the split 'nosuch'"),
        (["--mbr-samples", "8"], "--mbr-samples: only with --way mbr"),
        (["--temperature", "0.5"], "--temperature: only with --way sample"),
    ],
)
def test_bad_calls_exit_2_in_one_line_and_write_nothing(made, tmp_path, extra, says):
    out = tmp_path / "p.parquet"
    result = runner.invoke(
        app,
        ["predict", str(made["run"]), str(made["cases"]), "--rules", str(made["kb"]), "-o",
         str(out), *extra],
    )  # fmt: skip
    assert result.exit_code == 2, result.output
    assert says in result.output and len(result.output.strip().splitlines()) == 1
    assert not out.exists()


def test_a_folder_that_is_no_next_activity_run_and_a_condition_it_cannot_read(made, tmp_path):
    out = tmp_path / "p.parquet"
    folder = tmp_path / "edge"
    folder.mkdir()
    (folder / "config.json").write_text('{"kind": "edge-embedder"}', encoding="utf-8")
    result = runner.invoke(app, ["predict", str(folder), str(made["cases"]), "-o", str(out)])
    assert result.exit_code == 2 and "not a next-activity run" in result.output
    assert len(result.output.strip().splitlines()) == 1 and not out.exists()
    result = runner.invoke(
        app,
        ["predict", str(made["run"]), str(made["cases"]), "--rules", str(made["decl"]), "-o",
         str(out)],
    )  # fmt: skip
    assert result.exit_code == 2 and "MP-Declare condition on org:resource" in result.output
    assert len(result.output.strip().splitlines()) == 1 and not out.exists()


def test_a_run_that_predicts_the_resource_reads_conditions_and_names_values(made, tmp_path):
    run = tmp_path / "joint"
    result = runner.invoke(
        app,
        ["train-task", "next-activity", str(made["cases"]), "-o", str(run), "--hidden", "8",
         "--layers", "1", "--epochs", "1", "--attributes", "org:resource", "-q"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    out = tmp_path / "p.parquet"
    settings = PredictSettings(prefix_lengths="2", samples=10, max_suffix=4)
    predict_cases(run, made["cases"], out, settings, made["decl"])
    rows = pq.read_table(out).to_pylist()
    assert rows and all(r["rules"][0]["rule"] == "existence.c" for r in rows)
    for row in rows:
        (attribute,) = row["next_attributes"]
        assert attribute["attribute"] == "org:resource" and 0 < attribute["probability"] <= 1
        assert attribute["value"] in {"r1", "r2", "r3", "r4", None}
        assert all(len(values) == 1 for values in row["suffix_values"])
        total = sum(a["probability"] for a in row["next_activities"]) + row["end_probability"]
        assert total == pytest.approx(1.0)  # three activities: the marginal sums to one


def test_the_mbr_way_under_the_rules_keeps_them(made, tmp_path):
    out = tmp_path / "p.parquet"
    settings = PredictSettings(
        prefix_lengths="1-2", max_suffix=6, samples=0, way="mbr", mbr_samples=12,
        suffix_rules="filter",
    )  # fmt: skip
    predict_cases(made["run"], made["cases"], out, settings, made["kb"])
    rows = pq.read_table(out).to_pylist()
    dfas = compile_rules(read_case_rules(made["kb"]))
    atoms = read_cases(made["cases"]).activity_atoms

    def keeps(names) -> bool:
        states = [dfa.initial for dfa in dfas]
        for name in names:
            states = [
                int(d.table[s, d.alphabet.index({atoms[name]})])
                for d, s in zip(dfas, states, strict=True)
            ]
        return all(bool(d.accepting[s]) for d, s in zip(dfas, states, strict=True))

    found = [r for r in rows if r["suffix_found"]]
    assert len(found) > len(rows) // 2
    assert all(keeps(r["prefix"] + r["suffix"]) for r in found)
    assert all(len(r["suffix"]) <= 6 for r in rows)


def test_suffixes_that_reach_the_cap_are_counted(made, tmp_path):
    out = tmp_path / "p.parquet"
    settings = PredictSettings(prefix_lengths="1-2", max_suffix=1, samples=0, way="argmax")
    summary = predict_cases(made["run"], made["cases"], out, settings)
    rows = pq.read_table(out).to_pylist()
    capped = sum(r["suffix"] is not None and len(r["suffix"]) >= 1 for r in rows)
    assert 0 < summary["suffixes_at_cap"] == capped
    assert summary["true_at_cap"] == sum(len(r["true_suffix"]) >= 1 for r in rows)
    result = runner.invoke(
        app,
        ["predict", str(made["run"]), str(made["cases"]), "--prefix-lengths", "1-2",
         "--max-suffix", "1", "--samples", "0", "--way", "argmax", "-o",
         str(tmp_path / "q.parquet")],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert f"{capped} predicted suffixes reach --max-suffix 1" in result.output
