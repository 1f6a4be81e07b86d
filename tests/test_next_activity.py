"""Next-activity prediction on event logs: the encoding, the soft trace and its rules, training,
prediction under the rules, the suffix evaluation, and the commands' refusals."""

from __future__ import annotations

import json
from dataclasses import replace
from datetime import UTC, datetime, timedelta
from itertools import product
from pathlib import Path

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.settings.next_activity import NextActivitySettings, SuffixSettings, prefix_lengths
from tleaf_cli.tasks.next_activity.batch import CaseBatch
from tleaf_cli.tasks.next_activity.encoding import Encoder
from tleaf_cli.tasks.next_activity.evaluate import evaluate_next_activity, load_run
from tleaf_cli.tasks.next_activity.objective import OBSERVED, logic_term, soft_trace
from tleaf_cli.tasks.next_activity.rules import Rules, allowed_next
from tleaf_cli.tasks.next_activity.suffix_search import predict_suffixes
from tleaf_cli.tasks.next_activity.train import train_next_activity

runner = CliRunner()

# a process with one rule: every case starts with a; b is always followed by c, then the end
VARIANTS = [("a", "b", "c"), ("a", "d", "b", "c"), ("a", "d", "d", "b", "c"), ("a", "c")]


def write_log(path: Path, cases: int = 120, broken: int = 0) -> Path:
    """A CSV log of `cases` cases cycling through VARIANTS, an hour between events; the last
    `broken` cases end in b (they break `G(b -> F c)`)."""
    start = datetime(2024, 1, 1, 9, tzinfo=UTC)
    lines = ["case,activity,timestamp"]
    for i in range(cases):
        variant = VARIANTS[i % len(VARIANTS)]
        if i >= cases - broken:
            variant = ("a", "b")
        for t, activity in enumerate(variant):
            stamp = start + timedelta(days=i, hours=t)
            lines.append(f"c{i},{activity},{stamp.isoformat()}")
    path.write_text("\n".join(lines) + "\n")
    return path


def cases_artifact(tmp_path: Path, **kwargs) -> Path:
    out = tmp_path / "cases.parquet"
    log = write_log(tmp_path / "log.csv", **kwargs)
    result = runner.invoke(app, ["read-log", str(log), "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output
    return out


def rules_file(tmp_path: Path) -> Path:
    path = tmp_path / "rules.ltl"
    path.write_text("init.a: a\nresponse.b.c: G(b -> F c)\n")
    return path


def test_encoder_targets_end_each_case_and_places_unknown_times_by_mean_gaps(tmp_path):
    cases = read_cases(cases_artifact(tmp_path))
    encoder = Encoder.fit(cases)
    assert encoder.atoms == ("a", "b", "c", "d") and encoder.end == 4
    case = next(c for c in cases.cases if c.activities == ("a", "b", "c"))
    assert encoder.targets(case).tolist() == [1, 2, 4]
    full = encoder.features(encoder.indices(case).tolist(), case.timestamps)
    assert full.shape == (3, 5)
    # events past the given times sit their activity's mean gap (an hour here) after the last
    guessed = encoder.features(encoder.indices(case).tolist(), case.timestamps[:1])
    np.testing.assert_allclose(guessed, full, atol=1e-6)
    again = Encoder.from_dict(json.loads(json.dumps(encoder.as_dict())))
    assert again == encoder


def test_soft_trace_observes_the_first_activity_and_renormalises_the_predictions(tmp_path):
    cases = read_cases(cases_artifact(tmp_path))
    encoder = Encoder.fit(cases)
    batch = CaseBatch.of(cases.cases[:4], encoder, torch.device("cpu"))
    logits = torch.randn(4, int(batch.lengths.max()), 5)
    trace = soft_trace(batch, logits)
    assert trace.shape == (4, logits.shape[1], 4)  # the end of case is not a letter
    assert (trace[:, 0].argmax(-1) == batch.activities[:, 0]).all()
    assert trace[:, 0].max(-1).values.eq(0).all() and trace[:, 0].min() == OBSERVED
    torch.testing.assert_close(trace[:, 1:].exp().sum(-1), torch.ones(4, logits.shape[1] - 1))
    torch.testing.assert_close(trace[:, 1:], torch.log_softmax(logits[:, :-1, :4], -1))


def test_the_logic_loss_reads_only_the_cases_that_keep_the_rules(tmp_path):
    cases = read_cases(cases_artifact(tmp_path, cases=8, broken=2))
    encoder = Encoder.fit(cases)
    rules = Rules("kb", ("r",), (RuleSet(["G(b -> F c)"], list(encoder.atoms)),))
    batch = CaseBatch.of(cases.cases, encoder, torch.device("cpu"))
    logits = torch.zeros(len(cases.cases), int(batch.lengths.max()), 5, requires_grad=True)
    values = logic_term("exact", batch, logits, rules)
    plain = values.detach()
    broken = [c.activities == ("a", "b") for c in cases.cases]
    assert all(float(plain[i]) == 0 for i, b in enumerate(broken) if b)
    kept = [i for i, b in enumerate(broken) if not b and "b" in cases.cases[i].activities]
    assert all(float(plain[i]) > 0 for i in kept)  # uniform predictions may break the rule
    values.sum().backward()
    assert logits.grad is not None and torch.isfinite(logits.grad).all()


def test_allowed_next_over_parts_never_refuses_a_token_some_completion_needs():
    """Parts of a conjunction: a refused token has no accepted completion (sound), and the end
    is allowed exactly where every part accepts; a prefix some part rejects for good allows
    everything, as with one DFA."""
    vocabulary = ["a", "b", "c"]
    formulas = ["G(b -> F c)", "!c U a", "G(a -> X !a)"]
    whole = RuleSet(formulas, vocabulary)
    parts = Rules("kb", ("r", "s", "t"), tuple(RuleSet(f, vocabulary) for f in formulas))

    def accepted(seq) -> bool:
        return bool(whole.dfa.accepting[whole.dfa.run(whole.letters(np.array(seq)))])

    tails = [list(tail) for n in range(5) for tail in product(range(3), repeat=n)]
    for prefix in product(range(3), repeat=3):
        allowed = allowed_next(parts, np.array(prefix))
        for t in range(3):
            head = list(prefix[: t + 1])
            live = all(p.dfa.live()[p.dfa.run(p.letters(np.array(head)))] for p in parts.parts)
            assert allowed[t, -1] == (accepted(head) if live else True)
            if not live:
                assert allowed[t].all()
            for token in range(3):
                if not allowed[t, token]:
                    assert not any(accepted([*head, token, *tail]) for tail in tails)


def test_allowed_next_is_what_keeps_some_completion_accepted():
    """Brute force: a token is allowed after a prefix exactly when some completion of at most 4
    more activities (then the end) is accepted."""
    vocabulary = ["a", "b", "c"]
    rule_set = RuleSet(["G(b -> F c)", "!c U a"], vocabulary)
    rules = Rules("kb", ("r", "s"), (rule_set,))
    dfa = rule_set.dfa

    def accepted(seq) -> bool:
        return bool(dfa.accepting[dfa.run(rule_set.letters(np.array(seq)))])

    for prefix in product(range(3), repeat=3):
        allowed = allowed_next(rules, np.array(prefix))
        for t in range(3):
            head = list(prefix[: t + 1])
            tails = [list(tail) for n in range(5) for tail in product(range(3), repeat=n)]
            if not any(accepted(head + tail) for tail in tails):
                assert allowed[t].all()  # a broken prefix allows everything
                continue
            for token in range(3):
                can = any(accepted([*head, token, *tail]) for tail in tails if len(tail) < 4)
                assert allowed[t, token] == can, (prefix, t, token)
            assert allowed[t, 3] == accepted(head)


def test_training_learns_the_process_and_a_run_reloads(tmp_path):
    data = cases_artifact(tmp_path)
    out = tmp_path / "run"
    settings = NextActivitySettings(epochs=25, patience=None, hidden=32, layers=1, lr=1e-2)
    metrics = train_next_activity(data, None, None, out, settings)
    # the next activity is determined but after a (b, c or d) and after d (b or d): 5/8 of
    # prefixes ≈ 0.69 of steps are certain; a model that learned the process gets far past chance
    assert metrics["test"]["accuracy"] > 0.6
    assert metrics["test"]["accuracy_end"] == 1.0  # c always ends a case
    _, encoder, again = load_run(out)
    assert replace(again, lam=None) == settings  # the run's λ is resolved (unused here)
    assert encoder.atoms == ("a", "b", "c", "d")


def test_exact_loss_runs_choose_lambda_with_zero_and_report_it(tmp_path):
    data = cases_artifact(tmp_path)
    settings = NextActivitySettings(logic_loss="exact", lambdas="1", epochs=2, hidden=16, layers=1)
    metrics = train_next_activity(data, rules_file(tmp_path), None, tmp_path / "run", settings)
    choice = metrics["lambda"]
    assert choice["source"] == "validation"
    assert [c["lambda"] for c in choice["candidates"]] == [0.0, 1.0]
    assert (tmp_path / "run" / "lambda-choice" / "lambda-0" / "weights.pt").is_file()


def test_a_reference_run_is_the_lambda_zero_candidate_another_run_would_train(tmp_path):
    data, kb = cases_artifact(tmp_path), rules_file(tmp_path)
    small = dict(epochs=2, hidden=16, layers=1)
    first = NextActivitySettings(logic_loss="exact", lambdas="1", **small)
    train_next_activity(data, kb, None, tmp_path / "a", first)
    zero = tmp_path / "a" / "lambda-choice" / "lambda-0"
    again = NextActivitySettings(logic_loss="exact", lambdas="2", **small)
    trained = train_next_activity(data, kb, None, tmp_path / "b", again)
    taken = train_next_activity(data, kb, None, tmp_path / "c", again, reference=zero)
    # λ 0 trains without the logic term: another run's λ-0 candidate is the same model
    other_zero = torch.load(tmp_path / "b" / "lambda-choice" / "lambda-0" / "weights.pt")
    for name, value in torch.load(zero / "weights.pt").items():
        torch.testing.assert_close(value, other_zero[name], rtol=0, atol=0)
    assert taken["lambda"]["candidates"] == trained["lambda"]["candidates"]
    other = NextActivitySettings(logic_loss="exact", lambdas="2", epochs=2, hidden=8, layers=1)
    with pytest.raises(SettingError, match="hidden"):
        train_next_activity(data, kb, None, tmp_path / "d", other, reference=zero)


def test_eval_scores_suffixes_under_the_rules_and_only_satisfying_cases(tmp_path):
    data = cases_artifact(tmp_path, cases=120, broken=12)
    settings = NextActivitySettings(epochs=4, hidden=16, layers=1)
    train_next_activity(data, None, None, tmp_path / "run", settings)
    rules = rules_file(tmp_path)
    every = evaluate_next_activity(
        tmp_path / "run", data, tmp_path / "all", SuffixSettings(prefix_lengths="1-2"), rules
    )
    kept = evaluate_next_activity(
        tmp_path / "run", data, tmp_path / "kept",
        SuffixSettings(prefix_lengths="1-2", scored="satisfying"), rules,
    )  # fmt: skip
    assert kept["scored_cases"] < every["scored_cases"] == every["test_cases"]
    for k in ("1", "2"):
        row = kept["suffix"][k]
        assert row["rules"]["satisfying"] == 1.0  # every scored prefix can be completed
        assert 0 <= row["argmax"]["dl_similarity"] <= 1
    assert "accuracy_rules" in every["accuracy"]
    written = json.loads((tmp_path / "kept" / "metrics.json").read_text())
    assert written["scored_by"]["names"] == ["init.a", "response.b.c"]
    # the suffixes that stop at the length cap, beside the true suffixes that long
    capped = evaluate_next_activity(
        tmp_path / "run", data, tmp_path / "cap", SuffixSettings(prefix_lengths="1", max_suffix=2)
    )["suffix"]["1"]
    test = [c for c in read_cases(data).cases if c.split == "test"]  # min_suffix 0: all
    assert capped["true_at_cap"] == pytest.approx(np.mean([len(c) - 1 >= 2 for c in test]))
    for way in ("argmax", "beam"):
        assert 0 <= capped[way]["at_cap"] <= 1


def test_suffix_rows_say_which_prefix_they_continue():
    seen = []

    def model(rows):
        seen.extend(zip(rows, rows.owners, strict=True))
        out = np.full((len(rows), 3), np.log(1 / 3))
        return out

    prefixes = [(0,), (1, 1), (0, 1)]
    predict_suffixes(model, prefixes, 2, beam_width=2, max_length=3)
    assert seen and all(row[: len(prefixes[o])] == prefixes[o] for row, o in seen)


def test_settings_refuse_what_does_not_fit():
    with pytest.raises(SettingError):
        NextActivitySettings(logic_loss="none", lambdas="1").check()
    with pytest.raises(SettingError):
        NextActivitySettings(logic_loss="exact", lam=1.0, lambdas="1").check()
    with pytest.raises(SettingError):
        prefix_lengths("3-2")
    assert prefix_lengths("2-4, 7") == (2, 3, 4, 7)


def test_commands_refuse_bad_input_with_one_line(tmp_path):
    data = cases_artifact(tmp_path)
    train = runner.invoke(app, ["train-task", "next-activity", str(data), "--logic-loss", "exact",
                                "-o", str(tmp_path / "r"), "-q"])  # fmt: skip
    assert train.exit_code == 2 and "rules" in train.output and "Traceback" not in train.output
    assert not (tmp_path / "r" / "metrics.json").exists()
    missing = runner.invoke(app, ["eval", "next-activity", str(tmp_path), str(data), "-q"])
    assert missing.exit_code == 2 and "config.json" in missing.output
    run = tmp_path / "run"
    train_next_activity(data, None, None, run, NextActivitySettings(epochs=1, hidden=8, layers=1))
    no_rules = runner.invoke(app, ["eval", "next-activity", str(run), str(data), "--scored",
                                   "satisfying", "-q"])  # fmt: skip
    assert no_rules.exit_code == 2 and "rules" in no_rules.output
    unknown = runner.invoke(app, ["eval", "next-activity", str(run), str(data), "--rules",
                                  str(rules_file(tmp_path)), "--rule", "nope", "-q"])  # fmt: skip
    assert unknown.exit_code == 2 and "nope" in unknown.output
    with pytest.raises(InputError):
        load_run(tmp_path / "nothing")


@pytest.fixture(scope="module")
def abc_q(chain, tmp_path_factory) -> Path:
    """A tiny q trained on the Low tier's formulas over a, b and c."""
    from tleaf_cli.embed.train_meta import train_meta
    from tleaf_cli.settings.meta import MetaSettings

    out = tmp_path_factory.mktemp("q")
    settings = MetaSettings.preset("paper", hidden=16, layers=2, out_dim=8, epochs=1)
    train_meta(chain["dfas"], chain["traces"], chain["edge"], out, settings)
    return out


@pytest.mark.slow
def test_the_tleaf_loss_trains_with_a_q_that_reads_the_rules(abc_q, tmp_path):
    data = cases_artifact(tmp_path)
    settings = NextActivitySettings(logic_loss="tleaf", lam=1.0, epochs=2, hidden=16, layers=1)
    metrics = train_next_activity(data, rules_file(tmp_path), abc_q, tmp_path / "run", settings)
    assert all(h["logic_loss"] > 0 for h in metrics["history"])
    other = tmp_path / "d.ltl"
    other.write_text("existence.d: F d\n")
    with pytest.raises(SettingError) as refused:
        train_next_activity(data, other, abc_q, tmp_path / "r2", settings)
    assert refused.value.setting == "embedder" and " d " in str(refused.value) + " "


# ---- what a careful new user met: a refusal in one line, or a note, never a traceback


def one_line(result) -> str:
    """The single `error:` line of a refused call (exit 2, no traceback)."""
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    return lines[0]


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory) -> tuple[Path, Path]:
    """A cases artifact and a one-epoch run on it, without rules."""
    folder = tmp_path_factory.mktemp("tiny")
    data = cases_artifact(folder, cases=40)
    run = folder / "run"
    train_next_activity(data, None, None, run, NextActivitySettings(epochs=1, hidden=8, layers=1))
    return data, run


def test_eval_on_cases_with_no_activity_the_run_knows_is_one_line(tiny_run, tmp_path):
    """Before: `ValueError: need at least one array to concatenate` from accuracy()."""
    _, run = tiny_run
    log = tmp_path / "other.csv"
    log.write_text(
        "case,activity,timestamp\n"
        + "".join(f"o{i},{a},2024-02-0{i + 1}T0{t}:00:00Z\n" for i in range(3)
                  for t, a in enumerate("qr"))
    )  # fmt: skip
    other = tmp_path / "other.parquet"
    assert tleaf("read-log", log, "-o", other, "--split", "0,0,1", "-q").exit_code == 0
    line = one_line(tleaf("eval", "next-activity", run, other, "-o", tmp_path / "e", "-q"))
    assert str(other) in line and "none of its" in line and "'q'" in line, line
    assert not (tmp_path / "e").exists()


def test_a_model_too_large_for_memory_is_refused_naming_hidden(tiny_run, tmp_path, monkeypatch):
    """Before: a torch allocation traceback; counted on the meta device now, and an allocation
    that still fails is the same refusal."""
    data, _ = tiny_run
    out = tmp_path / "run"
    line = one_line(tleaf("train-task", "next-activity", data, "--hidden", 200000, "-o", out, "-q"))
    assert line.startswith("error: --hidden: ") and "memory" in line, line
    import tleaf_cli.tasks.next_activity.train as train

    def no_memory(*args, **kwargs):
        raise RuntimeError("DefaultCPUAllocator: can't allocate memory: you tried to allocate")

    monkeypatch.setattr(train, "memory_of", lambda device: None)  # the bound unknown
    monkeypatch.setattr(train, "NextActivityLSTM", no_memory)
    line = one_line(tleaf("train-task", "next-activity", data, "--hidden", 64, "-o", out, "-q"))
    assert "--hidden" in line and "does not fit in memory" in line, line


def test_max_events_that_leaves_the_logic_loss_nothing_is_refused(tiny_run, tmp_path):
    """Before: the logic loss was 0.0000 every epoch, and nothing said why."""
    data, _ = tiny_run
    result = tleaf(
        "train-task", "next-activity", data, "--kb", rules_file(tmp_path), "--logic-loss",
        "exact", "--max-events", 1, "--epochs", 1, "-o", tmp_path / "run", "-q",
    )  # fmt: skip
    line = one_line(result)
    assert "--max-events" in line and "logic loss" in line, line
    assert not (tmp_path / "run" / "metrics.json").exists()


def test_an_attribute_with_nothing_to_predict_is_refused_pointing_to_inputs(tmp_path):
    """Before: a head whose loss was 0 and `accuracy_<attribute>: None`. `diag` is written on
    each case's first event only (Sepsis' Diagnose), `kind` is a case attribute."""
    log = tmp_path / "log.csv"
    rows = ["case,activity,timestamp,diag,kind"]
    for i in range(30):
        for t, a in enumerate(VARIANTS[i % len(VARIANTS)]):
            diag = f"d{i % 3}" if t == 0 else ""
            rows.append(f"c{i},{a},2024-01-{1 + i % 28:02d}T0{t}:00:00Z,{diag},k{i % 2}")
    log.write_text("\n".join(rows) + "\n")
    data = tmp_path / "cases.parquet"
    read = tleaf("read-log", log, "-o", data, "--attributes", "diag", "--case-attributes", "kind")
    assert read.exit_code == 0, read.output
    args = ["train-task", "next-activity", data, "--epochs", 1, "-o", tmp_path / "run", "-q"]
    line = one_line(tleaf(*args, "--attributes", "diag"))
    assert "--attributes" in line and "case's first" in line and "inputs diag" in line, line
    line = one_line(tleaf(*args, "--attributes", "kind"))
    assert "case attribute" in line and "case:kind" in line, line


def test_eval_rule_weight_without_rules_and_temperature_bounds_are_one_line(tiny_run, tmp_path):
    """Before: --rule-weight on a run without rules was accepted and weighed nothing; the
    temperature 0 was "must be above 0", -1 "must be at least 0.0"."""
    data, run = tiny_run
    args = ["eval", "next-activity", run, data, "--prefix-lengths", 2, "-o", tmp_path / "e"]
    line = one_line(tleaf(*args, "--rule-weight", 1))
    assert "--rule-weight" in line and "without" in line, line
    for value in (0, -1, "nan"):
        line = one_line(tleaf(*args, "--temperature", value))
        assert "--temperature: must be a finite number above 0" in line, line
    assert not (tmp_path / "e").exists()


def test_resume_without_a_checkpoint_says_it_starts_afresh(tiny_run, tmp_path):
    """Before: --resume into a folder without a checkpoint trained from scratch silently."""
    data, _ = tiny_run
    out = tmp_path / "new"
    args = ["train-task", "next-activity", data, "--epochs", 1, "--hidden", 4, "--layers", 1]
    result = tleaf(*args, "-o", out, "--resume")
    assert result.exit_code == 0, result.output
    assert f"note: no checkpoint in {out}" in result.stderr and "starts afresh" in result.stderr
    again = tleaf(*args, "-o", out, "--resume")  # now there is one: no note
    assert again.exit_code == 0 and "no checkpoint" not in again.stderr, again.output


def test_a_run_folder_given_with_a_trailing_slash_is_written(tiny_run, tmp_path):
    """-o of train-task and eval next-activity is a folder: `newdir/` names it."""
    data, _ = tiny_run
    out = f"{tmp_path / 'newdir'}/"
    args = ["--epochs", 1, "--hidden", 4, "--layers", 1, "-o", out, "-q"]
    assert tleaf("train-task", "next-activity", data, *args).exit_code == 0
    assert (tmp_path / "newdir" / "weights.pt").is_file()
    scored = tleaf("eval", "next-activity", out, data, "-o", f"{tmp_path / 'e'}/", "-q")
    assert scored.exit_code == 0 and (tmp_path / "e" / "metrics.json").is_file(), scored.output


def test_the_help_names_every_model_it_trains():
    """Before: "Train an LSTM", though it trains a Transformer or counts the prefix table too."""
    shown = " ".join(tleaf("train-task", "next-activity", "--help").output.split())
    assert "Train an LSTM" not in shown
    assert "LSTM" in shown and "Transformer" in shown and "prefix-table baseline" in shown
