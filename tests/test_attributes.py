"""Events with attributes: `read-log --attributes / --case-attributes` keep them in the cases
artifact (XES and CSV alike), `Case.letters` makes an event's activity and attribute atoms true
together, `inspect --stats` shows them, and a name the log lacks is refused naming it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from tleaf_cli.cli.root import app
from tleaf_cli.data.event_logs import read_cases, write_cases
from tleaf_cli.data.log_readers import read_log
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.settings.event_logs import LogSettings

runner = CliRunner()


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


def _event(activity: str, stamp: str, resource: str | None, life: str = "complete") -> str:
    res = "" if resource is None else f'<string key="org:resource" value="{resource}"/>'
    return (
        f'<event><string key="concept:name" value="{activity}"/>{res}'
        f'<string key="lifecycle:transition" value="{life}"/>'
        f'<date key="time:timestamp" value="{stamp}"/></event>\n'
    )


XES = (
    '<?xml version="1.0" encoding="UTF-8"?>\n<log xes.version="1.0">\n'
    '<trace><string key="concept:name" value="c1"/><string key="channel" value="web"/>\n'
    + _event("Open", "2020-01-01T10:00:00", "Value 1")
    + _event("Open", "2020-01-01T09:30:00", "Value 9", life="start")  # dropped: not complete
    + _event("Closed", "2020-01-01T09:00:00", "Value 3")  # earlier: sorted first
    + "</trace>\n"
    '<trace><string key="concept:name" value="c2"/>\n'
    + _event("Open", "2020-01-02T10:00:00", None)
    + "</trace>\n</log>\n"
)

CSV = (
    "case:concept:name,concept:name,time:timestamp,org:resource,channel\n"
    "c1,Open,2020-01-01T10:00:00,Value 1,web\n"
    "c2,Open,2020-01-02T10:00:00,,\n"
    "c1,Closed,2020-01-01T09:00:00,Value 3,\n"
)

SETTINGS = LogSettings(attributes=("org:resource",), case_attributes=("channel",))


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize(("name", "text"), [("log.xes", XES), ("log.csv", CSV)])
def test_attributes_follow_their_events_and_round_trip(tmp_path: Path, name, text) -> None:
    cases = read_log(_write(tmp_path / name, text), SETTINGS)
    c1, c2 = cases.cases
    assert c1.activities == ("Closed", "Open")
    assert c1.attributes == {"org:resource": ("Value 3", "Value 1")}
    assert c1.case_attributes == {"channel": "web"}
    assert c2.attributes == {"org:resource": (None,)}  # a missing value is None
    assert c2.case_attributes == {"channel": None}
    assert cases.attribute_names == ("org:resource",)
    assert c1.letters() == (
        frozenset({"closed", "org_resource__value_3"}),
        frozenset({"open", "org_resource__value_1"}),
    )
    assert c2.letters() == (frozenset({"open"}),)
    out = tmp_path / "cases.parquet"
    write_cases(cases, out, SETTINGS)
    table = pq.read_table(out)
    assert table.column("event:org:resource").to_pylist() == [["Value 3", "Value 1"], [None]]
    assert table.column("case:channel").to_pylist() == ["web", None]
    back = read_cases(out)
    assert [c.attributes for c in back] == [c.attributes for c in cases]
    assert [c.case_attributes for c in back] == [c.case_attributes for c in cases]
    assert back.attribute_names == ("org:resource",)
    assert back.case_attribute_names == ("channel",)


def test_a_log_read_without_attributes_reads_as_before(tmp_path: Path) -> None:
    cases = read_log(_write(tmp_path / "log.xes", XES))
    out = tmp_path / "cases.parquet"
    write_cases(cases, out, LogSettings())
    assert pq.read_table(out).column_names == [
        "case_id", "activities", "atoms", "timestamps", "split"
    ]  # fmt: skip
    back = read_cases(out)
    assert back.cases[0].attributes == {} and back.attribute_names == ()
    assert back.cases[0].letters() == (frozenset({"closed"}), frozenset({"open"}))


@pytest.mark.parametrize(("name", "text"), [("log.xes", XES), ("log.csv", CSV)])
def test_an_attribute_the_log_lacks_is_named_with_some_it_has(tmp_path: Path, name, text) -> None:
    log = _write(tmp_path / name, text)
    with pytest.raises(InputError, match=r"org:role.*org:resource"):
        read_log(log, LogSettings(attributes=("org:role",)))
    with pytest.raises(InputError, match="'segment'"):
        read_log(log, LogSettings(case_attributes=("segment",)))


def test_the_command_keeps_attributes_and_stats_show_them(tmp_path: Path) -> None:
    log = _write(tmp_path / "log.xes", XES)
    out = tmp_path / "cases.parquet"
    result = tleaf(
        "read-log", log, "-o", out, "--attributes", "org:resource", "--case-attributes", "channel"
    )
    assert result.exit_code == 0, result.output
    assert "attributes: org:resource, case channel" in result.output
    stats = tleaf("inspect", out, "--stats")
    assert stats.exit_code == 0, stats.output
    assert "org:resource: 2 distinct values, on 2 of 3 events" in stats.output
    assert "Value 3 (1)" in stats.output
    assert "case attribute channel: 1 distinct values, on 1 of 2 cases" in stats.output


def test_the_command_refuses_a_missing_attribute_in_one_line(tmp_path: Path) -> None:
    log = _write(tmp_path / "log.csv", CSV)
    out = tmp_path / "cases.parquet"
    result = tleaf("read-log", log, "-o", out, "--attributes", "org:role")
    assert result.exit_code == 2
    assert "no column 'org:role'" in result.output
    assert not out.exists()


def test_attribute_settings_are_checked() -> None:
    with pytest.raises(SettingError, match="twice"):
        LogSettings(attributes=("a", "a")).check()
    with pytest.raises(SettingError):
        LogSettings(attributes="org:resource").check()  # type: ignore[arg-type]


def test_split_cases_keeps_the_attributes(tmp_path: Path) -> None:
    cases = read_log(_write(tmp_path / "log.csv", CSV), SETTINGS)
    source, out = tmp_path / "cases.parquet", tmp_path / "fold.parquet"
    write_cases(cases, source, SETTINGS)
    result = tleaf("split-cases", source, "-o", out, "--protocol", "thirds")
    assert result.exit_code == 0, result.output
    back = read_cases(out)
    assert [dataclasses.replace(c, split="x") for c in back] == [
        dataclasses.replace(c, split="x") for c in read_cases(source)
    ]
