"""Event logs in: XES and CSV logs (written here) read into `Cases` and a cases artifact, every
bad input a counted skip or one clear error with nothing written, and read-log's exit codes."""

from __future__ import annotations

import gzip
from datetime import UTC, datetime
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.artifacts import read_provenance
from tleaf_cli.data.event_logs import read_cases, write_cases
from tleaf_cli.data.log_readers import (
    BAD_TIMESTAMP,
    EMPTY_CASE,
    LIFECYCLE,
    NO_ACTIVITY,
    NO_TIMESTAMP,
    read_log,
)
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.settings.event_logs import LogSettings

runner = CliRunner()


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


def _event(activity: str | None, stamp: str | None, life: str | None = "complete") -> str:
    attrs = []
    if activity is not None:
        attrs.append(f'<string key="concept:name" value="{activity}"/>')
    if life is not None:
        attrs.append(f'<string key="lifecycle:transition" value="{life}"/>')
    if stamp is not None:
        attrs.append(f'<date key="time:timestamp" value="{stamp}"/>')
    attrs.append('<list key="nested"><string key="concept:name" value="NOT ME"/></list>')
    return "<event>" + "".join(attrs) + "</event>\n"


def _trace(case: str, *events: str) -> str:
    return f'<trace>\n<string key="concept:name" value="{case}"/>\n{"".join(events)}</trace>\n'


HEAD = (
    '<?xml version="1.0" encoding="UTF-8"?>\n<log xes.version="1.0" '
    'xmlns="http://www.xes-standard.org">\n<global scope="event">'
    '<string key="concept:name" value="global default"/></global>\n'
)


def _xes(*traces: str) -> str:
    return HEAD + "".join(traces) + "</log>\n"


GOOD = _xes(
    _trace(
        "c1",
        _event("Assign seriousness", "2012-10-09T14:50:17.000+03:00"),
        _event("Resolve ticket", "2012-10-09T14:51:01.000+03:00"),
    ),
    _trace(
        "c2",
        _event("3", "2012-10-10T10:00:00Z"),
        _event("Assign seriousness", "2012-10-10T09:00:00Z"),  # earlier: sorted before "3"
        _event("Resolve ticket", "2012-10-10T09:00:00Z"),  # a tie: file order kept
    ),
    _trace("c3", _event("Résumé", "2012-10-11T00:00:00")),  # no zone: UTC
)


def _write(path: Path, text: str) -> Path:
    if path.name.endswith(".gz"):
        path.write_bytes(gzip.compress(text.encode()))
    else:
        path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("name", ["log.xes", "log.xes.gz"])
def test_an_xes_log_round_trips_in_time_order(tmp_path: Path, name: str) -> None:
    log = _write(tmp_path / name, GOOD)
    out = tmp_path / "cases.parquet"
    report = read_log(log)
    assert report.params["reordered_cases"] == 1 and report.skips.skipped == {}
    write_cases(report, out, LogSettings())
    cases = read_cases(out)
    by_id = {c.case_id: c for c in cases.cases}
    assert [c.case_id for c in cases.cases] == ["c1", "c2", "c3"]
    assert by_id["c2"].activities == ("Assign seriousness", "Resolve ticket", "3")
    assert by_id["c2"].atoms == ("assign_seriousness", "resolve_ticket", "a3")
    assert by_id["c1"].timestamps[0] == datetime(2012, 10, 9, 11, 50, 17, tzinfo=UTC)
    assert by_id["c3"].timestamps == (datetime(2012, 10, 11, tzinfo=UTC),)
    assert cases.activity_atoms["Résumé"] == "resume"
    assert all(c.split in ("train", "val", "test") for c in cases.cases)
    prov = read_provenance(out)
    assert prov.kind == "cases" and prov.params["reordered_cases"] == 1
    assert prov.inputs[0]["path"] == str(log.resolve())


def test_lifecycle_keeps_complete_events_unless_all(tmp_path: Path) -> None:
    log = _write(
        tmp_path / "l.xes",
        _xes(
            _trace(
                "c1",
                _event("A", "2020-01-01T00:00:00Z", "start"),
                _event("A", "2020-01-01T00:01:00Z", "COMPLETE"),
                _event("B", "2020-01-01T00:02:00Z", None),  # no lifecycle: kept
            )
        ),
    )
    report = read_log(log)
    assert report.cases[0].activities == ("A", "B") and report.skips.skipped == {LIFECYCLE: 1}
    assert read_log(log, LogSettings(lifecycle="all")).cases[0].activities == ("A", "A", "B")
    assert read_log(log, LogSettings(lifecycle="start")).cases[0].activities == ("A", "B")


def test_a_log_whose_lifecycle_holds_a_status_keeps_every_event(tmp_path: Path) -> None:
    """BPI 2013 writes statuses there (Accepted, Queued, Completed): no event is 'complete', so
    'auto' keeps them all rather than none."""
    log = _write(
        tmp_path / "l.xes",
        _xes(
            _trace(
                "c1",
                _event("A", "2020-01-01T00:00:00Z", "Accepted"),
                _event("B", "2020-01-01T00:01:00Z", "Completed"),
            ),
            _trace("c2", _event("A", "2020-01-02T00:00:00Z", "Queued")),
        ),
    )
    report = read_log(log)
    assert [c.activities for c in report] == [("A", "B"), ("A",)] and report.skips.skipped == {}
    with_complete = log.read_text().replace('value="Queued"', 'value="complete"')
    report = read_log(_write(tmp_path / "m.xes", with_complete))
    assert [c.activities for c in report] == [("A",)]
    assert report.skips.skipped == {LIFECYCLE: 2, EMPTY_CASE: 1}


def test_bad_events_and_empty_cases_are_skipped_counted_and_named(tmp_path: Path) -> None:
    log = _write(
        tmp_path / "bad.xes",
        _xes(
            _trace("empty"),
            _trace("c1", _event(None, "2020-01-01T00:00:00Z"), _event("A", "2020-01-01")),
            _trace("c2", _event("B", None), _event("C", "yesterday"), _event("D", "2020-01-02")),
        ),
    )
    report = read_log(log)
    assert [c.case_id for c in report] == ["c1", "c2"]
    assert report.skips.skipped == {
        EMPTY_CASE: 1,
        NO_ACTIVITY: 1,
        NO_TIMESTAMP: 1,
        BAD_TIMESTAMP: 1,
    }
    assert report.skips.examples[NO_ACTIVITY][0].startswith("case c1, line ")
    assert "case c2" in report.skips.examples[BAD_TIMESTAMP][0]
    assert "'yesterday'" in report.skips.examples[BAD_TIMESTAMP][0]
    assert "case empty" in report.skips.text()


def test_a_case_whose_every_event_is_skipped_counts_as_empty(tmp_path: Path) -> None:
    log = _write(tmp_path / "l.csv", "CaseID,ActivityID,CompleteTimestamp\n1,a,\n2,b,2020-01-01\n")
    report = read_log(log)
    assert report.skips.skipped == {NO_TIMESTAMP: 1, EMPTY_CASE: 1}
    assert report.skips.examples[NO_TIMESTAMP] == ["case 1, line 2"]


@pytest.mark.parametrize("name", ["log.csv", "log.csv.gz"])
def test_a_csv_log_with_benchmark_headers_is_read_and_says_its_columns(
    tmp_path: Path, name: str
) -> None:
    text = (
        "CaseID,ActivityID,CompleteTimestamp\n"
        "7,2,2012-02-01 10:00:00\n"
        "5,1,2012-01-01 09:00:00\n"
        "7,1,2012-02-01 09:00:00\n"
        "\n"
    )
    report = read_log(_write(tmp_path / name, text))
    assert report.params["keys"] == {
        "case": "CaseID",
        "activity": "ActivityID",
        "timestamp": "CompleteTimestamp",
    }
    assert report.cases[0].case_id == "7" and report.cases[0].activities == ("1", "2")
    assert report.params["reordered_cases"] == 1 and report.events == 3


def test_csv_columns_given_by_name_and_pm4py_defaults(tmp_path: Path) -> None:
    pm4py = "case:concept:name,concept:name,time:timestamp\nx,A,2020-01-01T00:00:00+01:00\n"
    assert read_log(_write(tmp_path / "p.csv", pm4py)).cases[0].case_id == "x"
    own = _write(tmp_path / "o.csv", "ticket;step;when\n")
    own.write_text("ticket,step,when\nt1,open,2020-01-01\n")
    settings = LogSettings(case_key="ticket", activity_key="step", timestamp_key="when")
    assert [(c.case_id, c.activities, c.timestamps) for c in read_log(own, settings)] == [
        ("t1", ("open",), (datetime(2020, 1, 1, tzinfo=UTC),))
    ]
    with pytest.raises(InputError, match="no case column: none of case:concept:name"):
        read_log(own)
    with pytest.raises(InputError, match="no column 'nope' for the activity"):
        read_log(own, LogSettings(case_key="ticket", activity_key="nope"))


def test_xes_traces_sharing_a_case_id_stay_apart_renamed_and_counted(tmp_path: Path) -> None:
    # pm4py keeps two traces named c1 as two traces: merging them would interleave two runs
    log = _write(
        tmp_path / "dup.xes",
        _xes(
            _trace("c1", _event("A", "2020-01-01T00:00:00Z")),
            _trace("c1#2", _event("B", "2020-01-02T00:00:00Z")),  # an id the renaming must skip
            _trace("c1", _event("C", "2020-01-03T00:00:00Z")),
            _trace("c1", _event("D", "2020-01-04T00:00:00Z")),
            _trace("c2", _event("E", "2020-01-05T00:00:00Z")),
        ),
    )
    report = read_log(log)
    day = [datetime(2020, 1, d, tzinfo=UTC) for d in range(1, 6)]
    assert [(c.case_id, c.activities, c.timestamps) for c in report] == [
        ("c1", ("A",), (day[0],)),
        ("c1#2", ("B",), (day[1],)),
        ("c1#3", ("C",), (day[2],)),
        ("c1#4", ("D",), (day[3],)),
        ("c2", ("E",), (day[4],)),
    ]
    assert report.params["duplicate_case_ids"] == {"count": 2, "examples": ["c1", "c1"]}
    assert "duplicate case ids (kept apart as <id>#2, ...): 2 (c1, c1)" in report.skips.text()
    out = tmp_path / "cases.parquet"
    result = tleaf("read-log", log, "-o", out)
    assert result.exit_code == 0 and "duplicate case ids" in result.output, result.output
    assert read_provenance(out).params["duplicate_case_ids"] == {
        "count": 2,
        "examples": ["c1", "c1"],
    }
    assert len({c.case_id for c in read_cases(out).cases}) == 5


def test_csv_rows_of_a_case_spread_over_the_file_are_merged_and_counted(tmp_path: Path) -> None:
    text = (
        "CaseID,ActivityID,CompleteTimestamp\n"
        "a,1,2020-01-01\n"
        "a,2,2020-01-02\n"
        "b,1,2020-01-01\n"
        "a,3,2020-01-03\n"  # a again after b
        "c,1,2020-01-01\n"
        "b,2,2020-01-02\n"  # b again after a and c
        "b,3,2020-01-03\n"
    )
    log = _write(tmp_path / "spread.csv", text)
    report = read_log(log)
    assert [(c.case_id, c.activities) for c in report] == [
        ("a", ("1", "2", "3")),
        ("b", ("1", "2", "3")),
        ("c", ("1",)),
    ]
    assert report.params["spread_cases"] == 2
    assert report.params["duplicate_case_ids"]["count"] == 0
    assert "cases merged from rows spread over the file: 2" in report.skips.text()
    out = tmp_path / "cases.parquet"
    write_cases(report, out, LogSettings())
    assert read_provenance(out).params["spread_cases"] == 2
    contiguous = _write(tmp_path / "ok.csv", text.replace("a,3,", "b,0,").replace("c,1", "b,9"))
    assert read_log(contiguous).params["spread_cases"] == 0


def test_split_order_file_takes_the_first_cases_for_training(tmp_path: Path) -> None:
    rows = "".join(f"{i},A,2020-01-01\n" for i in range(9))
    log = _write(tmp_path / "l.csv", "CaseID,ActivityID,CompleteTimestamp\n" + rows)
    out = tmp_path / "c.parquet"
    write_cases(read_log(log), out, LogSettings(split=(2 / 3, 0, 1 / 3), split_order="file"))
    assert [c.split for c in read_cases(out).cases] == ["train"] * 6 + ["test"] * 3
    write_cases(read_log(log), out, LogSettings(split=(2 / 3, 0, 1 / 3), seed=1))
    random = [c.split for c in read_cases(out).cases]
    assert random.count("train") == 6 and random != ["train"] * 6 + ["test"] * 3


def test_a_truncated_gz_is_an_error_naming_the_file(tmp_path: Path) -> None:
    whole = gzip.compress((GOOD * 1).encode())
    log = tmp_path / "cut.xes.gz"
    log.write_bytes(whole[: len(whole) // 2])
    with pytest.raises(InputError, match=r"cut\.xes\.gz: truncated or damaged gzip"):
        read_log(log)


def test_malformed_xml_is_an_error_naming_the_line(tmp_path: Path) -> None:
    log = _write(tmp_path / "bad.xes", GOOD.replace("</trace>", "</trac>", 1))
    with pytest.raises(InputError, match=r"bad\.xes: line \d+: malformed XML"):
        read_log(log)


def test_a_log_without_cases_and_a_foreign_file_are_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no case with events"):
        read_log(_write(tmp_path / "e.xes", _xes(_trace("only"))))
    with pytest.raises(InputError, match="not an event log"):
        read_log(_write(tmp_path / "log.json", "{}"))
    with pytest.raises(SettingError):
        LogSettings(split=(0.5, 0.5, 0.5)).check()


def test_read_log_writes_the_artifact_and_says_what_it_read(tmp_path: Path) -> None:
    log = _write(tmp_path / "log.xes.gz", GOOD)
    out = tmp_path / "cases.parquet"
    result = tleaf("read-log", log, "-o", out, "--split-order", "file", "--split", "1,0,0")
    assert result.exit_code == 0, result.output
    assert "3 cases, 6 events, 4 activities" in result.output
    assert "cases sorted by time: 1" in result.output
    assert {c.split for c in read_cases(out).cases} == {"train"}
    shown = tleaf("inspect", out, "--rows", "2")
    assert shown.exit_code == 0 and "cases artifact" in shown.output, shown.output


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("cut.xes.gz", gzip.compress(GOOD.encode())[:200], "truncated or damaged gzip"),
        ("bad.xes", GOOD.replace("</log>", "").encode(), "malformed XML"),
        ("bad.csv", b"a,b\n1,2\n", "no case column"),
        ("bad.txt", b"x", "not an event log"),
    ],
)
def test_read_log_bad_input_exits_2_with_one_line_and_nothing_written(
    tmp_path: Path, name: str, content: bytes, message: str
) -> None:
    log = tmp_path / name
    log.write_bytes(content)
    out = tmp_path / "cases.parquet"
    result = tleaf("read-log", log, "-o", out)
    assert result.exit_code == 2, result.output
    assert message in result.output and "Traceback" not in result.output
    assert len(result.output.strip().splitlines()) == 1, result.output
    assert list(tmp_path.iterdir()) == [log]  # no artifact, no temporary file


def test_read_log_refuses_bad_split_text(tmp_path: Path) -> None:
    log = _write(tmp_path / "l.csv", "CaseID,ActivityID,CompleteTimestamp\n1,a,2020-01-01\n")
    result = tleaf("read-log", log, "-o", tmp_path / "c.parquet", "--split", "0.5,0.6")
    assert result.exit_code == 2 and "--split" in result.output, result.output


def test_read_log_refuses_a_seed_that_file_order_would_ignore(tmp_path: Path) -> None:
    log = _write(tmp_path / "l.csv", "CaseID,ActivityID,CompleteTimestamp\n1,a,2020-01-01\n")
    out = tmp_path / "c.parquet"
    result = tleaf("read-log", log, "-o", out, "--split-order", "file", "--seed", "3")
    assert result.exit_code == 2 and "--seed" in result.output, result.output
    assert not out.exists()


def test_inspect_stats_of_a_cases_artifact_gives_the_logs_figures(tmp_path: Path) -> None:
    # lengths 1, 2, 3, 3 (median 2.5); variants: (A), (A, B), (A, B, C) twice -> 3
    rows = [("1", "A"), ("2", "A"), ("2", "B"), ("3", "A"), ("3", "B"), ("3", "C")]
    rows += [("4", "A"), ("4", "B"), ("4", "C")]
    text = "CaseID,ActivityID,CompleteTimestamp\n" + "".join(
        f"{case},{act},2020-01-0{i % 9 + 1}\n" for i, (case, act) in enumerate(rows)
    )
    log = _write(tmp_path / "l.csv", text)
    out = tmp_path / "cases.parquet"
    read = tleaf("read-log", log, "-o", out, "--split-order", "file", "--split", "0.5,0.25,0.25")
    assert read.exit_code == 0, read.output
    shown = tleaf("inspect", out, "--stats")
    assert shown.exit_code == 0, shown.output
    assert "no statistics" not in shown.output
    assert "cases: train 2, val 1, test 1" in shown.output
    assert "events: 9; activities: 3; variants: 3" in shown.output
    assert "case length: min 1, median 2.5, max 3, mean 2.2" in shown.output
    lines = [line for line in shown.output.splitlines() if "│" in line or "|" in line]
    table = [[c.strip() for c in line.replace("│", "|").split("|")[1:-1]] for line in lines]
    assert ["A", "4", "44.4%", "4", "100.0%"] in table
    assert ["C", "2", "22.2%", "2", "50.0%"] in table
    order = [row[0] for row in table if row and row[0] in ("A", "B", "C")]
    assert order == ["A", "B", "C"]  # most frequent first
