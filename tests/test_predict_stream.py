"""tleaf predict RUN --follow: a live stream of events. After each event the streamed verdicts are
the batch command's for the same prefix, and so are the next-activity probabilities (to 1e-6,
with --samples 0): for an LSTM stepped from its cached state, for one that predicts the resource
too, for one that reads it as an input, and for the prefix table, which re-reads the prefix.
Bad lines of every kind, 1 % of a stream, are skipped and counted exactly by reason, and every
good event still gets its line; an ended case is dropped, its verdicts final, and a later event
for it refused; stdin and a file that grows both work through the command."""

from __future__ import annotations

import json
import random
import threading
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest
import torch
from typer.testing import CliRunner

from tests.conftest import resource_cases
from tleaf_cli.cli.root import app
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.logic.verdicts import Verdict
from tleaf_cli.settings.next_activity import PredictSettings
from tleaf_cli.tasks.next_activity.predict import Predictor
from tleaf_cli.tasks.next_activity.predictions import predict_cases
from tleaf_cli.tasks.next_activity.stream import StreamMonitor
from tleaf_cli.tasks.next_activity.stream_events import (
    BAD_FIELD,
    CLOSED,
    MALFORMED,
    MISSING,
    NOT_OPEN,
    OUT_OF_ORDER,
    REASONS,
    BadEvent,
    read_lines,
    run_stream,
)

runner = CliRunner()

KB = """resp: G(a -> F c)
once_b: F b
no_bb: !F(b & X b)
c_after_b: (!c U b) | G !c
"""


@pytest.fixture(scope="module", autouse=True)
def one_thread():
    """One torch thread, as the command streams (one event's model call is too small to share
    out; on a busy machine more threads make it ten times slower)."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


def _train(cases: Path, out: Path, *extra: str) -> Path:
    shape = ["--hidden", "8", "--layers", "1", "--epochs", "1"] if "--model" not in extra else []
    result = runner.invoke(
        app, ["train-task", "next-activity", str(cases), "-o", str(out), "-q", *shape, *extra]
    )
    assert result.exit_code == 0, result.output
    return out


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> dict[str, Path]:
    """A cases artifact keeping the resource, an LSTM over activities, one that predicts the
    resource too, one that reads it as an input, a prefix table, and the rules."""
    folder = tmp_path_factory.mktemp("stream")
    cases = resource_cases(folder, interleave=True)
    kb = folder / "kb.ltl"
    kb.write_text(KB, encoding="utf-8")
    return {
        "folder": folder,
        "cases": cases,
        "lstm": _train(cases, folder / "lstm"),
        "joint": _train(cases, folder / "joint", "--attributes", "org:resource"),
        "inputs": _train(cases, folder / "inputs", "--inputs", "org:resource"),
        "table": _train(cases, folder / "table", "--model", "prefix-table"),
        "kb": kb,
    }


def _events(cases_path: Path, copies: int = 1, end: bool = False) -> list[dict]:
    """Every event of the cases artifact as a stream event, in time order (cases interleaved);
    `copies` of each case under ids of their own (a day apart); `end`: the last event of each
    case carries the end mark."""
    events = []
    for case in read_cases(cases_path).cases:
        for copy in range(copies):
            for t, (activity, stamp) in enumerate(
                zip(case.activities, case.timestamps, strict=True)
            ):
                event = {
                    "case": case.case_id if copies == 1 else f"{case.case_id}.{copy}",
                    "activity": activity,
                    "timestamp": stamp.replace(year=2020 + copy).isoformat(),
                    "attributes": {"org:resource": case.attributes["org:resource"][t]},
                }
                if end and t == len(case) - 1:
                    event["end"] = True
                events.append(event)
    return sorted(events, key=lambda e: e["timestamp"])


@pytest.mark.parametrize("model", ["lstm", "joint", "inputs", "table"])
def test_streamed_predictions_equal_the_batch_ones_prefix_by_prefix(made, model):
    settings = PredictSettings(samples=0, way="argmax", max_suffix=4, prefix_lengths="1-4")
    out = made["folder"] / f"batch-{model}.parquet"
    predict_cases(made[model], made["cases"], out, settings, made["kb"])
    batch = {(r["case_id"], r["prefix_length"]): r for r in pq.read_table(out).to_pylist()}
    monitor = StreamMonitor(Predictor.load(made[model], PredictSettings(samples=0), made["kb"]))
    compared = 0
    for event in _events(made["cases"]):
        line = monitor.feed(event)
        row = batch.get((line["case_id"], line["prefix_length"]))
        if row is None:  # prefixes longer than 4
            continue
        compared += 1
        assert [(r["rule"], r["verdict"]) for r in line["rules"]] == [
            (r["rule"], r["verdict"]) for r in row["rules"]
        ]
        assert [r["probability"] for r in line["rules"]] == [r["probability"] for r in row["rules"]]
        got = [(a["activity"], a["probability"]) for a in line["next_activities"]]
        want = [(a["activity"], a["probability"]) for a in row["next_activities"]]
        assert [a for a, _ in got] == [a for a, _ in want]
        assert [p for _, p in got] == pytest.approx([p for _, p in want], abs=1e-6)
        assert line["end_probability"] == pytest.approx(row["end_probability"], abs=1e-6)
        assert [(a["attribute"], a["value"]) for a in line["next_attributes"]] == [
            (a["attribute"], a["value"]) for a in row["next_attributes"]
        ]
        for a, b in zip(line["next_attributes"], row["next_attributes"], strict=True):
            assert a["probability"] == pytest.approx(b["probability"], abs=1e-6)
    assert compared == len(batch)  # every batch prefix was streamed
    assert monitor.lstm == (model != "table")


def _bad_lines(rng: random.Random, good: list[dict], per_kind: int) -> list[tuple[int, str, str]]:
    """(position in the good stream to insert before, the line, its reason): `per_kind` lines
    of each reason, each placed where it is bad (an out-of-order event right after a good event
    of its case, an event for a case after its end mark)."""
    first = {}
    last_seen = {}
    for i, e in enumerate(good):
        first.setdefault(e["case"], i)
        last_seen[e["case"]] = i
    out = []
    for _ in range(per_kind):
        i = rng.randrange(1, len(good))
        out.append((i, '{"case": "k1", "activity": "a", "timestamp": ', MALFORMED))
        out.append((rng.randrange(len(good)), '["a", "list"]', MALFORMED))
        e = good[rng.randrange(len(good))]
        out.append((rng.randrange(len(good)), json.dumps({"activity": e["activity"]}), MISSING))
        out.append(
            (rng.randrange(len(good)), json.dumps({"case": e["case"], "activity": "a"}), MISSING)
        )
        bad_time = {**e, "timestamp": "yesterday at noon"}
        out.append((rng.randrange(len(good)), json.dumps(bad_time), BAD_FIELD))
        # out of order: right after an event of its case neither first nor last
        later = [i for i, x in enumerate(good) if first[x["case"]] < i < last_seen[x["case"]]]
        i = rng.choice(later)
        early = {**good[i], "timestamp": "2019-12-01T00:00:00+00:00", "end": False}
        out.append((i + 1, json.dumps(early), OUT_OF_ORDER))
        # an event, or an end mark, for a case after its end mark
        ended = [c for c, j in last_seen.items() if j < len(good) - 2]
        case = rng.choice(ended)
        j = rng.randrange(last_seen[case] + 1, len(good))
        out.append((j, json.dumps({**good[last_seen[case]], "end": False}), CLOSED))
        out.append(
            (rng.randrange(len(good)), json.dumps({"case": "nosuch", "end": True}), NOT_OPEN)
        )
    return out


def test_one_percent_bad_lines_of_every_kind_lose_no_good_event(made):
    rng = random.Random(1)
    good = _events(made["cases"], copies=18, end=True)  # 2,574 events, 720 cases
    bad = _bad_lines(rng, good, per_kind=3)  # 24 lines: 1 %
    assert {reason for _, _, reason in bad} == set(REASONS)
    assert 0.008 < len(bad) / (len(good) + len(bad)) < 0.012
    lines, kinds = [], {}
    at = {}
    for i, text, reason in bad:
        at.setdefault(i, []).append((text, reason))
    for i, event in enumerate(good):
        for text, reason in at.get(i, []):
            lines.append(text)
            kinds[len(lines)] = reason
        lines.append(json.dumps(event))
    monitor = StreamMonitor(Predictor.load(made["lstm"], PredictSettings(samples=0), made["kb"]))
    written, reports = [], []
    summary = run_stream(monitor, lines, written.append, reports.append)
    outputs = [json.loads(w) for w in written]
    good_lines = [n for n in range(1, len(lines) + 1) if n not in kinds]
    assert [o["line"] for o in outputs] == good_lines  # every good event, in order
    assert dict(summary.skipped) == {r: 3 * sum(x == r for x in REASONS) for r in REASONS} | {
        MALFORMED: 6,
        MISSING: 6,
    }
    assert sum(summary.skipped.values()) == len(bad) == len(reports)
    for report, (n, reason) in zip(reports, sorted(kinds.items()), strict=True):
        assert report.startswith(f"line {n}: skipped, {reason}")
    assert summary.written == len(good) and summary.ended == 720 and summary.open == 0
    # the bad lines changed nothing: the same stream without them gives the same lines
    clean = StreamMonitor(Predictor.load(made["lstm"], PredictSettings(samples=0), made["kb"]))
    again = [clean.feed(e) for e in good]
    for a, b in zip(outputs, again, strict=True):
        assert a["rules"] == b["rules"] and a["next_activities"] == b["next_activities"]


def test_an_ended_case_is_dropped_with_its_final_verdicts(made):
    monitor = StreamMonitor(Predictor.load(made["lstm"], PredictSettings(samples=0), made["kb"]))
    t = "2024-01-01T10:0{}:00Z"
    monitor.feed({"case": "x", "activity": "a", "timestamp": t.format(0)})
    line = monitor.feed({"case": "x", "activity": "b", "timestamp": t.format(1)})
    now = {r["rule"]: r["verdict"] for r in line["rules"]}
    assert now == {
        "resp": "temporarily violated",
        "once_b": "permanently satisfied",
        "no_bb": "temporarily satisfied",
        "c_after_b": "permanently satisfied",
    }
    end = monitor.feed({"case": "x", "end": True})
    assert end["ended"] and end["reason"] == "the case ended" and end["prefix_length"] == 2
    final = {r["rule"]: (r["verdict"], r["probability"], r["method"]) for r in end["rules"]}
    assert final == {
        "resp": ("permanently violated", 0.0, "exact"),
        "once_b": ("permanently satisfied", 1.0, "exact"),
        "no_bb": ("permanently satisfied", 1.0, "exact"),
        "c_after_b": ("permanently satisfied", 1.0, "exact"),
    }
    assert "x" not in monitor.open and "x" in monitor.closed
    with pytest.raises(BadEvent) as refused:
        monitor.feed({"case": "x", "activity": "c", "timestamp": t.format(2)})
    assert refused.value.reason == CLOSED
    # an event carrying the mark: applied, then the case closed
    monitor.feed({"case": "y", "activity": "a", "timestamp": t.format(0)})
    end = monitor.feed({"case": "y", "activity": "c", "timestamp": t.format(1), "end": True})
    assert end["ended"] and end["prefix_length"] == 2 and not monitor.open
    assert {r["rule"]: r["verdict"] for r in end["rules"]}["resp"] == str(
        Verdict.PERMANENTLY_SATISFIED
    )


def test_an_unknown_activity_keeps_the_verdicts_and_nulls_the_prediction(made):
    monitor = StreamMonitor(Predictor.load(made["lstm"], PredictSettings(samples=0), made["kb"]))
    t = "2024-01-01T10:0{}:00Z"
    monitor.feed({"case": "x", "activity": "a", "timestamp": t.format(0)})
    line = monitor.feed({"case": "x", "activity": "Escalate", "timestamp": t.format(1)})
    assert "'Escalate' was never seen in training" in line["reason"]
    assert line["next_activities"] == [] and line["end_probability"] is None
    assert line["prefix_length"] == 2 and not monitor.knows("Escalate")
    line = monitor.feed({"case": "x", "activity": "b", "timestamp": t.format(2)})
    assert line["reason"] is not None  # the model cannot read the prefix any more
    assert {r["rule"]: r["verdict"] for r in line["rules"]}["once_b"] == "permanently satisfied"
    other = monitor.feed({"case": "z", "activity": "a", "timestamp": t.format(3)})
    assert other["reason"] is None and len(other["next_activities"]) == 3


def test_sampled_probabilities_and_the_suffix_on_request(made):
    settings = PredictSettings(samples=10, max_suffix=4)
    monitor = StreamMonitor(Predictor.load(made["lstm"], settings, made["kb"]), suffix=True)
    line = monitor.feed({"case": "x", "activity": "a", "timestamp": "2024-01-01T10:00:00"})
    for r in line["rules"]:
        if Verdict[r["verdict"].upper().replace(" ", "_")].final:
            assert r["method"] == "exact"
        else:
            assert r["method"] == "sampled"
            assert r["low"] - 1e-9 <= r["probability"] <= r["high"] + 1e-9
    assert line["samples_at_cap"] is not None
    assert isinstance(line["suffix"], list) and len(line["suffix"]) <= 4
    assert line["recommendation_status"] in {"not needed", "found", "none"}


def test_stdin_through_the_command(made, tmp_path):
    good = _events(made["cases"], end=True)[:30]
    text = "\n".join([json.dumps(e) for e in good[:10]] + ["{oops"] + [
        json.dumps(e) for e in good[10:]
    ])  # fmt: skip
    args = ["predict", str(made["lstm"]), "--follow", "--rules", str(made["kb"]), "--samples", "0"]
    result = runner.invoke(app, args, input=text + "\n")
    assert result.exit_code == 1, result.output  # a line was skipped
    lines = [json.loads(x) for x in result.stdout.splitlines()]
    assert len(lines) == 30 and [x["line"] for x in lines] == [*range(1, 11), *range(12, 32)]
    assert "line 11: skipped, malformed JSON" in result.stderr
    assert "1 skipped (1 malformed JSON)" in result.stderr
    # to a file, with the summary beside it; a clean stream exits 0
    out = tmp_path / "live.jsonl"
    clean = "\n".join(json.dumps(e) for e in good) + "\n"
    result = runner.invoke(app, [*args, "-", "-o", str(out), "-q"], input=clean)
    assert result.exit_code == 0, result.output
    assert len(out.read_text().splitlines()) == 30
    summary = json.loads((tmp_path / "live.summary.json").read_text())
    assert summary["written"] == 30 and summary["skipped"] == 0
    assert summary["rule_names"] == ["resp", "once_b", "no_bb", "c_after_b"]


def test_batch_only_options_are_refused_with_follow(made):
    result = runner.invoke(app, ["predict", str(made["lstm"]), "--follow", "--split", "test"])
    assert result.exit_code == 2 and "--split applies to a cases artifact" in result.output
    result = runner.invoke(app, ["predict", str(made["lstm"])])
    assert result.exit_code == 2 and "--follow" in result.output


def test_a_growing_file_is_followed_until_idle(made, tmp_path):
    path = tmp_path / "events.jsonl"
    events = [json.dumps(e) for e in _events(made["cases"])[:6]]
    path.write_text("\n".join(events[:3]) + "\n" + events[3][:10], encoding="utf-8")

    def grow() -> None:  # the rest of a half-written line, then more lines
        time.sleep(0.3)
        with path.open("a", encoding="utf-8") as f:
            f.write(events[3][10:] + "\n")
            f.flush()
            time.sleep(0.2)
            f.write("\n".join(events[4:]) + "\n")

    writer = threading.Thread(target=grow)
    writer.start()
    got = list(read_lines(path, follow=True, until_idle=1.0, poll=0.02))
    writer.join()
    assert [g.decode().rstrip("\n") for g in got] == events
    assert list(read_lines(path, follow=False)) == got


def test_the_memory_of_ended_cases_is_bounded(made):
    """Before: every ended case's id was kept for the stream's life (a set that only grew)."""
    monitor = StreamMonitor(Predictor.load(made["lstm"], PredictSettings(samples=0), made["kb"]))
    monitor.closed_memory = 3
    t = "2024-01-01T10:00:00Z"
    for i in range(5):
        monitor.feed({"case": f"k{i}", "activity": "a", "timestamp": t, "end": True})
    assert list(monitor.closed) == ["k2", "k3", "k4"]  # the last three, oldest first
    with pytest.raises(BadEvent):
        monitor.feed({"case": "k4", "activity": "a", "timestamp": t})
    line = monitor.feed({"case": "k0", "activity": "a", "timestamp": t})  # forgotten: new case
    assert line["prefix_length"] == 1 and "k0" in monitor.open
