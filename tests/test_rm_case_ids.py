"""pipelines/rm_case_ids.py: a log's own cases, with their attributes, under the benchmark CSV's
case ids, matched by their events' times."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from typer.testing import CliRunner

from tleaf_cli.cli.root import app
from tleaf_cli.data.event_logs import Case, read_cases

ROOT = Path(__file__).resolve().parents[1]
OWN = "case:concept:name,concept:name,time:timestamp"  # the log's own (XES-like) columns
BENCH = "CaseID,ActivityID,CompleteTimestamp"  # the benchmark CSV's
runner = CliRunner()


def _read(tmp_path: Path, name: str, rows: list[str], *options: str) -> Path:
    source, out = tmp_path / f"{name}.csv", tmp_path / f"{name}.parquet"
    source.write_text("\n".join(rows) + "\n", encoding="utf-8")
    result = runner.invoke(app, ["read-log", str(source), *options, "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output
    return out


def _match(tmp_path: Path, own: list[str], bench: list[str]) -> subprocess.CompletedProcess:
    """rm_case_ids.py on the own log's rows (its resource kept when it has one, `OWN,
    org:resource`) and the benchmark's, both under their headers; writes out.parquet."""
    resource = ["--attributes", "org:resource"] if own[0].endswith(",org:resource") else []
    own_cases = _read(tmp_path, "own", own, *resource)
    bench_cases = _read(tmp_path, "bench", bench)
    script = ROOT / "pipelines" / "rm_case_ids.py"
    out = tmp_path / "out.parquet"
    return subprocess.run(
        [sys.executable, str(script), str(own_cases), str(bench_cases), "-o", str(out)],
        capture_output=True,
        text=True,
    )


def _cases(tmp_path: Path) -> dict[str, Case]:
    return {c.case_id: c for c in read_cases(tmp_path / "out.parquet").cases}


def test_cases_take_the_benchmarks_ids_and_keep_their_attributes(tmp_path):
    own = [
        f"{OWN},org:resource",
        "A,open,2020-01-01T10:00:00.700+02:00,ann",
        "A,close,2020-01-01T10:05:00.200+02:00,bob",
        "B,open,2020-01-02T09:00:00.000+02:00,cid",
        "B,wait,2020-01-02T09:01:30.000+02:00,cid",
        "B,close,2020-01-02T09:02:00.000+02:00,ann",
    ]
    bench = [
        BENCH,
        "7,0,2020-01-02 07:00:00",
        "7,2,2020-01-02 07:01:30",
        "7,1,2020-01-02 07:02:00",
        "3,0,2020-01-01 08:00:00",
        "3,1,2020-01-01 08:05:00",
        "9,0,2020-01-03 08:00:00",  # dropped from the own log: kept without attributes
        "9,1,2020-01-03 08:00:10",
    ]
    result = _match(tmp_path, own, bench)
    assert result.returncode == 0, result.stderr
    assert "matched 2" in result.stdout and "kept from the CSV 1" in result.stdout
    cases = _cases(tmp_path)
    assert sorted(cases) == ["3", "7", "9"]
    assert cases["7"].activities == ("open", "wait", "close")
    assert cases["7"].attributes["org:resource"] == ("cid", "cid", "ann")
    assert cases["3"].attributes["org:resource"] == ("ann", "bob")  # times cut to the second
    assert cases["9"].activities == ("open", "close")
    assert cases["9"].attributes["org:resource"] == (None, None)


def test_an_activity_id_naming_two_activities_writes_nothing(tmp_path):
    own = [OWN, "A,open,2020-01-01T10:00:00", "B,shut,2020-01-02T10:07:00"]
    bench = [BENCH, "1,0,2020-01-01 10:00:00", "2,0,2020-01-02 10:07:00"]
    result = _match(tmp_path, own, bench)
    assert result.returncode != 0 and "matches XES activities" in result.stderr
    assert not (tmp_path / "out.parquet").exists()


def test_cases_alike_but_for_their_hour_are_told_apart_by_their_start(tmp_path):
    own = [
        f"{OWN},org:resource",
        "A,open,2020-01-01T10:00:00+02:00,ann",
        "A,close,2020-01-01T10:05:00+02:00,bob",
        "C,open,2020-01-01T09:30:15+02:00,cid",  # C and D: one event, same minute and second
        "D,open,2020-01-01T11:30:15+02:00,dan",
    ]
    bench = [
        BENCH,
        "1,0,2020-01-01 08:00:00",
        "1,1,2020-01-01 08:05:00",
        "2,0,2020-01-01 09:30:15",
        "3,0,2020-01-01 07:30:15",
    ]
    result = _match(tmp_path, own, bench)
    assert result.returncode == 0, result.stderr
    assert "matched 3" in result.stdout and "matched by their start 2" in result.stdout
    cases = _cases(tmp_path)
    assert cases["2"].attributes["org:resource"] == ("dan",)
    assert cases["3"].attributes["org:resource"] == ("cid",)
